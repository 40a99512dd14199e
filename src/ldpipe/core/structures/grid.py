"""The start grid of the structures computed from trajectories (FSLE, LAVD): a section block read
into its two axes and the fixed coordinates."""

from __future__ import annotations

import numpy as np

from ...errors import ConfigError


def section_grid(section: dict, coordinates, where: str) -> tuple[tuple[tuple[str, np.ndarray], ...], dict]:
    """``(axes, fixed)`` of ``section`` (``{"axes": [{name, range, points}] × 2, "fixed": {...}}``,
    as an LD map's section block): each axis' name and values, and the other coordinates' values.
    A ConfigError beginning with ``where`` unless the axes and fixed name each of ``coordinates``
    once."""
    axes_spec = section.get("axes", [])
    if len(axes_spec) != 2:
        raise ConfigError(f"{where}: section: expected two axes")
    axes = tuple((axis["name"], np.linspace(*axis["range"], int(axis["points"]))) for axis in axes_spec)
    fixed = dict(section.get("fixed") or {})
    names = [name for name, _ in axes] + list(fixed)
    unknown = sorted(set(names) - set(coordinates))
    missing = sorted(set(coordinates) - set(names))
    if unknown or missing or len(set(names)) != len(names):
        raise ConfigError(f"{where}: section: axes and fixed must name each of {list(coordinates)} once "
                          f"(unknown {unknown}, missing {missing})")
    return axes, fixed
