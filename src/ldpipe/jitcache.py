"""Generated source modules whose numba code is cached on disk across processes.

numba reuses compiled code from its on-disk cache only for functions defined in
a real source file (closures get a new cache entry in every process). ldpipe
therefore writes the source it generates per system (kernels, engine) to a file
named by the hash of its text, imports it, and lets ``@njit(cache=True)`` keep
the machine code beside it. A second process, e.g. the next Snakemake tile job,
then loads the compiled code instead of compiling it again.
"""

from __future__ import annotations

import hashlib
import importlib.util
import os
import re
import sys
import threading
import types
from pathlib import Path
from typing import Callable

import numba

_LOCK = threading.Lock()


def cache_directory() -> Path:
    """``$LDPIPE_CACHE_DIR``, else ``$XDG_CACHE_HOME/ldpipe``, else ``~/.cache/ldpipe``."""
    if os.environ.get("LDPIPE_CACHE_DIR"):
        return Path(os.environ["LDPIPE_CACHE_DIR"])
    base = os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache"
    return Path(base) / "ldpipe"


def load_generated_module(source: str, prefix: str) -> types.ModuleType:
    """Import ``source`` as a module from a file named by its hash (written once, atomically).

    The numba version is part of the hash, so an upgrade never meets an old cache. ``prefix``
    (e.g. a system's name) starts the file name, its non-word characters replaced by ``_``.
    """
    digest = hashlib.sha256(f"{numba.__version__}\n{source}".encode()).hexdigest()[:20]
    name = "ldpipe_generated_" + re.sub(r"\W", "_", prefix) + f"_{digest}"
    with _LOCK:
        if name in sys.modules:
            return sys.modules[name]
        directory = cache_directory()
        directory.mkdir(parents=True, exist_ok=True)
        path = directory / f"{name}.py"
        if not path.is_file() or path.read_text() != source:
            temporary = path.with_name(f".{path.name}.{os.getpid()}.{threading.get_ident()}.tmp")
            temporary.write_text(source)
            os.replace(temporary, path)
        spec = importlib.util.spec_from_file_location(name, path)
        module = importlib.util.module_from_spec(spec)
        sys.modules[name] = module
        try:
            spec.loader.exec_module(module)
        except BaseException:
            del sys.modules[name]
            raise
        return module


def njit_functions(source: str, names: tuple[str, ...], prefix: str) -> list[Callable]:
    """The functions ``names`` that ``source`` defines, each compiled by ``njit(cache=True)``.

    For a system's kernels (compiled lazily, on first call, or loaded from numba's disk cache).
    """
    # Strict IEEE arithmetic (no fastmath): with fastmath, code compiled in this process and
    # code loaded from the disk cache can round differently, and results must not depend on
    # which process compiled them.
    footer = "\nfrom numba import njit as _njit\n\n" + "".join(f"{name} = _njit(cache=True)({name})\n" for name in names)
    module = load_generated_module(source + footer, prefix=prefix)
    return [getattr(module, name) for name in names]
