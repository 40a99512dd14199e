"""Curves of a structures file drawn on an axes: stable in the stable manifolds' colour, unstable in
the unstable ones', over an LD map or on their own."""

from __future__ import annotations

from pathlib import Path

import xarray as xr

from ..core.structures.curves import curves_of
from ..io.contracts import STRUCTURES
from ..io.datafile import open_stage_file
from . import style


def draw_structure_curves(ax, sources: list[str | Path | xr.Dataset], *, linewidth: float = 0.9,
                          along: tuple[str, str] | None = None) -> tuple[str, str]:
    """Every curve of each structures file in ``sources`` on ``ax``; returns the files' axes.
    ``along``: the coordinates ``ax`` draws across and up, when they are the files' axes swapped
    (``ds.ldpipe.plot(x=...)`` can put the map's second axis across)."""
    axes = ("", "")
    for source in sources:
        structures = open_stage_file(source, stage=STRUCTURES)
        axes = tuple(structures.attrs["axes"].split())
        across, up = (1, 0) if along is not None and tuple(along) == axes[::-1] else (0, 1)
        for manifold, color in (("stable", style.STABLE_COLOR), ("unstable", style.UNSTABLE_COLOR)):
            for k, curve in enumerate(curves_of(structures, manifold=manifold)):
                ax.plot(curve[:, across], curve[:, up], color=color, linewidth=linewidth,
                        label=f"{manifold} (extracted)" if k == 0 else None)
    return axes
