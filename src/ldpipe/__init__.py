"""ldpipe: phase-space structures of index-1 saddles from Lagrangian descriptors.

The Python API (:mod:`ldpipe.api`) is re-exported here and imported on first use, so that
``import ldpipe`` stays cheap (no numba, no matplotlib): ``ldpipe.system``, ``ldpipe.section``,
one function per stage (``ldpipe.equilibria``, ``ldpipe.ld_map``, ``ldpipe.periodic_orbits``,
``ldpipe.manifolds``, ``ldpipe.map_manifolds``, ``ldpipe.poincare``, ``ldpipe.nhim``, ``ldpipe.orbit_validation``,
``ldpipe.nhim_sampling``, ``ldpipe.transport``, ``ldpipe.saddle_flux``, ``ldpipe.normal_form``,
``ldpipe.accuracy_cost``, ``ldpipe.structures``, ``ldpipe.fsle``, ``ldpipe.lavd``),
``ldpipe.open_dataset`` and ``ldpipe.plot``. Every Dataset has the accessor ``ds.ldpipe.plot()``
once ldpipe is imported. Bad input raises :class:`ConfigError` (a :class:`LdpipeError`), whose
one-line message names the argument and what was expected.
"""

from importlib import import_module

from . import accessor  # noqa: F401  (registers ds.ldpipe)
from ._version import __version__
from .errors import ConfigError, LdpipeError, OutputError, StageFileError

#: The names :mod:`ldpipe.api` exports, available as ``ldpipe.NAME``.
API = (
    "accuracy_cost", "chaos_indicators", "equilibria", "fsle", "lavd", "ld_map", "manifolds", "map_manifolds",
    "nhim", "nhim_sampling", "normal_form", "open_dataset", "orbit_validation", "periodic_orbits", "plot",
    "poincare", "saddle_flux", "section", "structures", "system", "transport",
)

__all__ = ["ConfigError", "LdpipeError", "OutputError", "StageFileError", "__version__", *API]


def __getattr__(name: str):
    # The API module imports every stage (and numba): loaded when a name of it is first used.
    if name in API:
        return getattr(import_module(f"{__name__}.api"), name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def __dir__() -> list[str]:
    # what a user may call on: the API and the errors (the layers below are ldpipe's own)
    return sorted(__all__)
