"""How ldpipe writes numbers for people: help texts, plot labels."""

from __future__ import annotations


#: Time units as a rate's denominator names them: 1/day, not 1/days.
SINGULAR_TIMES = {"seconds": "second", "secs": "sec", "minutes": "minute", "mins": "min", "hours": "hour",
                  "hrs": "hr", "days": "day"}


def per_time(time_units: str | None) -> str:
    """The units of a rate (an FTLE) per ``time_units`` (a system's, say ``days``): ``1/day``;
    ``1/time`` where the system does not name its time's unit (None)."""
    if not time_units:
        return "1/time"
    return "1/" + SINGULAR_TIMES.get(time_units, time_units)


def short_number(value: float) -> str:
    """1e-08 -> '1e-8', 50.0 -> '50', 0.05 -> '0.05': compact, as a person writes it."""
    text = f"{value:g}"
    if "e" in text:
        mantissa, exponent = text.split("e")
        text = f"{mantissa}e{int(exponent)}"
    return text
