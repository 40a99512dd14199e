"""The ``ldpipe`` accessor of xarray Datasets: ``ds.ldpipe.plot()`` draws a stage file.

Registered when ldpipe is imported, so any Dataset has it, however it was opened; the drawing
code (matplotlib) is imported only when something is drawn.
"""

from __future__ import annotations

from importlib import import_module

import xarray as xr

from .io.datafile import STAGE_ATTRIBUTE

#: The module that draws a stage file (:func:`ldpipe.figures.dataset.draw_stage_file`).
DRAWING_MODULE = "ldpipe.figures.dataset"


@xr.register_dataset_accessor("ldpipe")
class LdpipeAccessor:
    """ldpipe's methods on a Dataset holding a stage file."""

    def __init__(self, dataset: xr.Dataset):
        self._dataset = dataset

    @property
    def stage(self) -> str | None:
        """The stage that wrote the file (None for a Dataset ldpipe did not write)."""
        return self._dataset.attrs.get(STAGE_ATTRIBUTE)

    def plot(self, variable=None, ax=None, **options):
        """Draw what the file holds on ``ax`` (a new figure's if None) and return the axes.

        An LD map draws ``variable`` (``"ld_forward"``, ``"ftle_backward"``, a flag ...; by
        default the LD, forward plus backward) with the map's first axis horizontal, as the
        workflow's figures draw it, its missing points grey, with matplotlib's ``cmap``, ``vmin``, ``vmax``, ``norm``, ``ax``,
        ``add_colorbar``; see :func:`ldpipe.plot` for every option. ``ds.ldpipe.plot(ax)``, an
        axes first, draws the default on it."""
        if variable is not None and not isinstance(variable, str):  # ds.ldpipe.plot(ax): the axes given first
            variable, ax = None, variable
        return import_module(DRAWING_MODULE).draw_stage_file(self._dataset, ax, variable, **options)
