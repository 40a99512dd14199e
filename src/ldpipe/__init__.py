"""ldpipe: phase-space structures of index-1 saddles from Lagrangian descriptors.

The Python API (:mod:`ldpipe.api`) is re-exported here and imported on first use, so that
``import ldpipe`` stays cheap (no numba, no matplotlib): ``ldpipe.system``, ``ldpipe.section``,
one function per stage (``ldpipe.equilibria``, ``ldpipe.ld_map``, ``ldpipe.periodic_orbits``,
``ldpipe.manifolds``, ``ldpipe.poincare``, ``ldpipe.nhim``, ``ldpipe.transport``,
``ldpipe.saddle_flux``), ``ldpipe.open_dataset`` and ``ldpipe.plot``. Every Dataset has the
accessor ``ds.ldpipe.plot()`` once ldpipe is imported.
"""

import sys
import types
from importlib import import_module
from importlib.metadata import PackageNotFoundError, version

try:
    __version__ = version("ldpipe")
except PackageNotFoundError:  # running from a source tree that was not installed
    __version__ = "0+unknown"

from . import accessor  # noqa: E402, F401  (registers ds.ldpipe; after __version__, which it reaches)

#: The names :mod:`ldpipe.api` exports, available as ``ldpipe.NAME``.
API = (
    "equilibria", "ld_map", "manifolds", "nhim", "open_dataset", "periodic_orbits", "plot", "poincare",
    "saddle_flux", "section", "system", "transport",
)

__all__ = ["__version__", *API]


class _Package(types.ModuleType):
    """ldpipe's own module type: the API's names win over the subpackages named alike
    (``ldpipe.equilibria``, ``ldpipe.nhim``, ``ldpipe.transport`` ...), which the import system sets
    as attributes of the package when it loads them. Those stay importable by their full names
    (``from ldpipe.nhim import study_map_slice``, ``importlib.import_module("ldpipe.nhim")``)."""

    def __getattribute__(self, name: str):
        if name in API:
            # The API module imports every stage (and numba): loaded when a name of it is first used.
            return getattr(import_module(f"{__name__}.api"), name)
        return super().__getattribute__(name)

    def __dir__(self) -> list[str]:
        return sorted({*super().__dir__(), *API})


sys.modules[__name__].__class__ = _Package
