"""NHIM studies in the Python API."""

from __future__ import annotations

import copy
import tempfile
from collections.abc import Sequence
from pathlib import Path

import xarray as xr

from ..config import validate_config
from ..errors import ConfigError
from ..io.contracts import LD_GRID, NHIM, UPO
from ..io.datafile import open_stage_file, stage_parameters
from ..stages.nhim import run_nhim_study
from .arguments import arguments_of

def nhim(maps: Sequence[xr.Dataset], *, study: str = "study", references: Sequence[xr.Dataset] = (),
         threads: int | None = None, **refinement) -> xr.Dataset:
    """NHIM points of variable-time LD maps, detected and refined (the NHIM study stage).

    Parameters
    ----------
    maps : sequence of xarray.Dataset
        Variable-time LD maps (:func:`ld_map`), one slice each.
    study : str
        The study's name, recorded in the file (default ``"study"``).
    references : sequence of xarray.Dataset
        Periodic-orbit families (:func:`periodic_orbits`), each with an orbit at every map's energy:
        every point is compared with its crossing of the map's section.
    threads : int, optional
        Threads (default every core).
    **refinement
        Keys of the configuration's ``nhim.refinement`` block: ``tolerance``, ``rtol``, ``atol``,
        ``max_time``, ``zoom``, ...

    Returns
    -------
    xarray.Dataset
        The study's file (contract ``nhim``). It records the maps by their titles where the
        pipeline records their paths.

    Examples
    --------
    >>> points = ldpipe.nhim([m], references=[orbits], tolerance=1e-8)  # doctest: +SKIP
    """
    if not maps:
        raise ConfigError("ldpipe.nhim: argument 'maps': give at least one LD map")
    recorded = stage_parameters(open_stage_file(maps[0], stage=LD_GRID, only=True))
    with arguments_of("nhim", "nhim.refinement"):
        # the refinement block is validated in a configuration holding the maps' system
        config = validate_config({"systems": {recorded["system_name"]: copy.deepcopy(recorded["system_spec"])},
                                  "nhim": {"refinement": dict(refinement)}})
        families = [stage_parameters(open_stage_file(orbits, stage=UPO))["family"] for orbits in references]
        with tempfile.TemporaryDirectory() as scratch:
            path = run_nhim_study(study=study, refinement=config["nhim"]["refinement"], maps=list(maps),
                                  references=families, reference_files=list(references), threads=threads,
                                  output=Path(scratch) / "nhim.nc")
            return open_stage_file(path, stage=NHIM)
