"""Curves of a structures file drawn on an axes: stable in the stable manifolds' colour, unstable in
the unstable ones', over an LD map or on their own."""

from __future__ import annotations

from pathlib import Path

import xarray as xr

from ..core.structures.curves import curves_of
from ..io.contracts import STRUCTURES
from ..io.datafile import open_stage_file
from . import style


def draw_structure_curves(ax, sources: list[str | Path | xr.Dataset], *, linewidth: float = 0.9) -> tuple[str, str]:
    """Every curve of each structures file in ``sources`` on ``ax``; returns the files' axes."""
    axes = ("", "")
    for source in sources:
        structures = open_stage_file(source, stage=STRUCTURES)
        axes = tuple(structures.attrs["axes"].split())
        for manifold, color in (("stable", style.STABLE_COLOR), ("unstable", style.UNSTABLE_COLOR)):
            for k, curve in enumerate(curves_of(structures, manifold=manifold)):
                ax.plot(curve[:, 0], curve[:, 1], color=color, linewidth=linewidth,
                        label=f"{manifold} (extracted)" if k == 0 else None)
    return axes
