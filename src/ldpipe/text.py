"""How ldpipe writes numbers for people: help texts, plot labels."""

from __future__ import annotations


def short_number(value: float) -> str:
    """1e-08 -> '1e-8', 50.0 -> '50', 0.05 -> '0.05': compact, as a person writes it."""
    text = f"{value:g}"
    if "e" in text:
        mantissa, exponent = text.split("e")
        text = f"{mantissa}e{int(exponent)}"
    return text
