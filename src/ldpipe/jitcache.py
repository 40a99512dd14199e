"""Generated source modules whose numba code is cached on disk across processes.

numba reuses compiled code from its on-disk cache only for functions defined in
a real source file (closures get a new cache entry in every process). ldpipe
therefore writes the source it generates per system (kernels, engine) to a file
named by the hash of its text, imports it, and lets ``@njit(cache=True)`` keep
the machine code beside it. A second process, e.g. the next Snakemake tile job,
then loads the compiled code instead of compiling it again.

With ``$LDPIPE_COMPILE_LOG`` set to a file, every process appends one JSON line to it per
generated module loaded and per function of one compiled (not found in numba's cache): the
module, the wall and CPU seconds of the compile, and who asked (the pytest test, the Snakemake
rule). ``benchmarks/cold_start.py`` counts compiles with it.
"""

from __future__ import annotations

import hashlib
import importlib.util
import json
import os
import re
import sys
import threading
import time
import types
from pathlib import Path
from typing import Callable

import numba
from numba.core import event

_LOCK = threading.Lock()
# The module name of each (cache directory, hash of a source) loaded by this process.
_NAMES: dict[tuple[Path, str], str] = {}
GENERATED_PREFIX = "ldpipe_generated_"
COMPILE_LOG_VARIABLE = "LDPIPE_COMPILE_LOG"


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
    The same text under another prefix (two names for one system: the same kernels, the same
    engine) reuses the file already there, and with it numba's compiled code.
    """
    digest = hashlib.sha256(f"{numba.__version__}\n{source}".encode()).hexdigest()[:20]
    with _LOCK:
        directory = cache_directory()
        name = _NAMES.get((directory, digest))
        if name is None:
            existing = sorted(directory.glob(f"{GENERATED_PREFIX}*_{digest}.py"))
            name = existing[0].stem if existing else GENERATED_PREFIX + re.sub(r"\W", "_", prefix) + f"_{digest}"
            _NAMES[directory, digest] = name
        if name in sys.modules:
            return sys.modules[name]
        directory.mkdir(parents=True, exist_ok=True)
        path = directory / f"{name}.py"
        if not path.is_file() or path.read_text() != source:
            temporary = path.with_name(f".{path.name}.{os.getpid()}.{threading.get_ident()}.tmp")
            temporary.write_text(source)
            os.replace(temporary, path)
        record_compile_event({"event": "load", "module": name})
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


def compile_log_context() -> dict:
    """Who is compiling: the process, the pytest test running, the Snakemake job's rule and wildcards."""
    context = {"pid": os.getpid()}
    if os.environ.get("PYTEST_CURRENT_TEST"):
        context["test"] = os.environ["PYTEST_CURRENT_TEST"]
    job = getattr(sys.modules.get("__main__"), "snakemake", None)  # a Snakemake script: directive's object
    if job is not None:
        context["rule"] = str(getattr(job, "rule", ""))
        context["wildcards"] = dict(getattr(job, "wildcards", {}).items())
        context["log"] = [str(path) for path in getattr(job, "log", [])]
    return context


def record_compile_event(record: dict) -> None:
    """Append ``record`` and :func:`compile_log_context` as one JSON line to ``$LDPIPE_COMPILE_LOG``, if set."""
    path = os.environ.get(COMPILE_LOG_VARIABLE)
    if path:
        line = json.dumps({**record, **compile_log_context()}) + "\n"
        with open(path, "a") as log:  # one short append per line: lines of parallel processes do not mix
            log.write(line)


class CompileRecorder(event.Listener):
    """Times each outermost numba compile of a generated module's function (its callees compile inside it).

    numba raises "numba:compile" only on a cache miss, so a function loaded from the disk cache
    records nothing.
    """

    def __init__(self):
        self.local = threading.local()

    def on_start(self, ev):
        depth = getattr(self.local, "depth", 0)
        self.local.depth = depth + 1
        if depth == 0:
            self.local.started = (time.perf_counter(), time.thread_time())

    def on_end(self, ev):
        self.local.depth -= 1
        if self.local.depth:
            return
        function = ev.data["dispatcher"].py_func
        module = getattr(function, "__module__", "") or ""
        if module.startswith(GENERATED_PREFIX):
            wall, cpu = self.local.started
            record_compile_event({"event": "compile", "module": module, "function": function.__qualname__,
                                  "wall_s": time.perf_counter() - wall, "cpu_s": time.thread_time() - cpu})


if os.environ.get(COMPILE_LOG_VARIABLE):
    event.register("numba:compile", CompileRecorder())
