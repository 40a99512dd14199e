"""Stage files in the Python API: opened from disk, and drawn."""

from __future__ import annotations

from pathlib import Path

import xarray as xr

from ..io.datafile import STAGE_ATTRIBUTE, open_stage_file
from .arguments import api_function


@api_function()
def open_dataset(path: str | Path) -> xr.Dataset:
    """Any stage file, loaded into memory and checked to be one (its stage from its own attributes).

    Parameters
    ----------
    path : str or Path
        A file an ldpipe stage wrote.

    Returns
    -------
    xarray.Dataset
        As the stage that wrote it reads it (flags as booleans); ``ds.ldpipe.plot()`` draws it.

    Raises
    ------
    StageFileError
        naming the file, if it is missing, unreadable or not an ldpipe stage file.

    Examples
    --------
    >>> m = ldpipe.open_dataset("results/ld/fig3_dE0.125.nc")  # doctest: +SKIP
    """
    from ..errors import StageFileError

    path = Path(path)
    if not path.is_file():
        raise StageFileError(f"{path}: no such file")
    with xr.open_dataset(path, engine="netcdf4") as handle:
        stage = handle.attrs.get(STAGE_ATTRIBUTE)
    if stage is None:
        raise StageFileError(f"{path}: not written by ldpipe (no {STAGE_ATTRIBUTE!r} attribute)")
    return open_stage_file(path, stage=str(stage))


@api_function()
def plot(dataset: xr.Dataset, ax=None, variable: str | None = None, **options):
    """Draw what a stage file holds on ``ax`` (a new figure's if None); ``ds.ldpipe.plot()`` calls this.

    Parameters
    ----------
    dataset : xarray.Dataset
        A stage file: an LD map (``ld_grid``), a periodic-orbit family (``upo``), a Poincaré
        section (``poincare``), manifolds (``manifolds``) or equilibria (``equilibria``).
    ax : matplotlib Axes, optional
        Where to draw.
    variable : str, optional
        For an LD map, the variable drawn: ``"ld_forward"``, ``"ftle_forward"``, a flag such as
        ``"allowed"`` ...; by default the LD ``descriptor``. It is drawn as the workflow's
        figures draw it, the map's first axis horizontal (``lon``, ``x``: xarray's own
        ``.plot()`` puts the last one there unless given ``x=``), with missing
        points (never integrated, or not defined) in grey and the axes and colour bar labelled
        with their symbols and units.
    **options
        For an LD map: ``descriptor`` (``"total"``, ``"forward"``, ``"backward"``),
        ``color_percentiles``, ``color_limits``, ``manifolds`` (manifold files drawn over it), the
        figure keys of those names, and matplotlib's ``cmap``, ``vmin``, ``vmax``, ``norm``,
        ``add_colorbar``, xarray's ``x`` and ``y`` (the coordinate drawn horizontally,
        vertically); for a Poincaré section: ``point_size``.

    Returns
    -------
    matplotlib Axes

    Examples
    --------
    >>> m.ldpipe.plot(descriptor="forward")  # doctest: +SKIP
    >>> m.ldpipe.plot("ftle_forward", cmap="magma", vmin=0)  # doctest: +SKIP
    """
    from ..figures.dataset import draw_stage_file

    return draw_stage_file(dataset, ax, variable, **options)
