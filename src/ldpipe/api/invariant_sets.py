"""NHIM studies in the Python API."""

from __future__ import annotations

import copy
from collections.abc import Sequence

import xarray as xr

from ..config import validate_config
from ..core.nhim.study import nhim_study_dataset
from ..errors import ConfigError
from ..io.contracts import LD_GRID, UPO
from ..io.datafile import open_stage_file, stage_parameters
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
        # the parameters config.parameters gives a study of these maps and families
        parameters = {"study": study, "refinement": config["nhim"]["refinement"], "references": families}
        return nhim_study_dataset(parameters, list(maps), list(references), threads=threads)
