"""Normal-form stage: the saddle's normal form, the flux over it by energy and order, the NHIM points.

The study is :func:`ldpipe.core.normal_form.study.normal_form_dataset`'s; this module reads the
system's equilibria file and the files of the studies it compares with, calls it and writes.
"""

from __future__ import annotations

from pathlib import Path

import xarray as xr

from ..core.normal_form.study import normal_form_dataset
from ..io.datafile import write_product


def run_normal_form(*, output: str | Path, equilibria: str | Path | xr.Dataset,
                    transport_file: str | Path | xr.Dataset | None = None,
                    saddle_flux_file: str | Path | xr.Dataset | None = None, **parameters) -> Path:
    """The normal form of the study's saddle and everything computed from it; writes ``output``.

    ``transport_file`` and ``saddle_flux_file`` are the files of the studies the parameters
    ``transport`` and ``saddle_flux`` name, if they do."""
    return write_product(output, lambda: normal_form_dataset(parameters, equilibria, transport=transport_file,
                                                          saddle_flux=saddle_flux_file))
