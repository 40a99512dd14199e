"""The ``ldpipe`` accessor of xarray Datasets: ``ds.ldpipe.plot(ax)`` draws a stage file.

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

    def plot(self, ax=None, **options):
        """Draw what the file holds on ``ax`` (a new figure's if None) and return the axes; see
        :func:`ldpipe.plot` for the options."""
        return import_module(DRAWING_MODULE).draw_stage_file(self._dataset, ax, **options)
