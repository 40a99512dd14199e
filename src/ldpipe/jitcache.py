"""Generated source modules whose numba code is cached on disk across processes.

numba reuses compiled code from its on-disk cache only for functions defined in
a real source file (closures get a new cache entry in every process). ldpipe
therefore writes the source it generates per system (kernels, engine) to a file
named by the hash of its text, imports it, and lets ``@njit(cache=True)`` keep
the machine code beside it. A second process, e.g. the next Snakemake tile job,
then loads the compiled code instead of compiling it again. Processes that need the
same uncompiled module at once (two pytest-xdist workers, two tile jobs of one map, two
notebooks) compile it once: one holds the module's lock while it compiles, the others wait,
then load what it saved (:class:`CompileLock`).

With ``$LDPIPE_COMPILE_LOG`` set to a file, every process appends one JSON line to it per
generated module loaded and per function of one compiled (not found in numba's cache): the
module, the wall and CPU seconds of the compile, and who asked (the pytest test, the Snakemake
rule); and one per wait for another process's compile of a module, with the seconds waited.
``benchmarks/cold_start.py`` counts compiles and waits with it.
"""

from __future__ import annotations

import fcntl
import functools
import hashlib
import importlib.util
import json
import math
import os
import re
import sys
import threading
import time
import types
from pathlib import Path
from typing import TYPE_CHECKING, Callable, ClassVar

from .io.atomic import atomic_path
from .logs import get_logger, tell_user

if TYPE_CHECKING:
    from numba.core.dispatcher import Dispatcher

logger = get_logger(__name__)

_LOCK = threading.Lock()
# The module name of each (cache directory, hash of a source) loaded by this process.
_NAMES: dict[tuple[Path, str], str] = {}
# The generated modules each loaded generated module imports, directly or through another.
_BELOW: dict[str, frozenset[str]] = {}
GENERATED_PREFIX = "ldpipe_generated_"
COMPILE_LOG_VARIABLE = "LDPIPE_COMPILE_LOG"
#: What the first compile of a generated module tells the user, once per module and process
#: (measured: 10-17 s per engine on an idle machine, minutes on a loaded one).
COMPILING_NOTICE = ("ldpipe: compiling {what} for this machine (its first use): this usually takes 10 to 60 s, "
                    "once; later runs, in this process or any other, load it from the cache ({cache}) in under a "
                    "second")
#: Seconds after a compile notice in which the next compiles (of the same call) are not told again.
NOTICE_QUIET_S = 300.0
# How long a process waits for another's compile of a module before compiling it itself: far
# above the slowest module's compile (about 270 s on a loaded 2-core machine), so only a holder
# that hangs (stopped, in a debugger) is ever given up on.
LOCK_PATIENCE_S = 1800.0


def cache_directory() -> Path:
    """``$LDPIPE_CACHE_DIR``, else ``$XDG_CACHE_HOME/ldpipe``, else ``~/.cache/ldpipe``."""
    if os.environ.get("LDPIPE_CACHE_DIR"):
        return Path(os.environ["LDPIPE_CACHE_DIR"])
    base = os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache"
    return Path(base) / "ldpipe"


def module_digest(source: str) -> str:
    """The hash that names the file of ``source``: the numba version and the text, so an upgrade
    never meets an old cache."""
    import numba  # here, not with this module (see load_generated_module)

    return hashlib.sha256(f"{numba.__version__}\n{source}".encode()).hexdigest()[:20]


def module_name(source: str, prefix: str) -> str:
    """The name a generated module of ``source`` is first written and imported under:
    ``ldpipe_generated_<prefix>_<hash>``, ``prefix``'s non-word characters replaced by ``_``.

    A module that another generated module imports is named in the importer's text by this
    name, so a change of its text changes the importer's text, and with it the importer's file.
    """
    return GENERATED_PREFIX + re.sub(r"\W", "_", prefix) + f"_{module_digest(source)}"


def load_generated_module(source: str, prefix: str, imports: tuple[types.ModuleType, ...] = ()) -> types.ModuleType:
    """Import ``source`` as a module from a file named by its hash (written once, atomically).

    The file is :func:`module_name`'s. The same text under another prefix (two names for one
    system: the same kernels, the same engine) reuses the file already there, and with it numba's
    compiled code.

    ``imports``: the generated modules ``source`` imports (by their :func:`module_name`), loaded
    by the caller first, so that the import statement finds them in ``sys.modules``, in this
    process as in one that finds everything in the cache. Their compile locks are then below this
    module's: a compile of this module that needs one of their functions waits for it
    (:class:`CompileLock`).
    """
    # numba is imported here, not with this module: a process that plans or reads stage files
    # (Snakemake's planning, a figure job) imports ldpipe's systems and code generator, never
    # loading a module.
    from numba.core.dispatcher import Dispatcher

    register_compile_recorder()
    digest = module_digest(source)
    with _LOCK:
        directory = cache_directory()
        name = _NAMES.get((directory, digest))
        if name is None:
            existing = sorted(directory.glob(f"{GENERATED_PREFIX}*_{digest}.py"))
            name = existing[0].stem if existing else module_name(source, prefix)
            _NAMES[directory, digest] = name
        if name in sys.modules:
            return sys.modules[name]
        directory.mkdir(parents=True, exist_ok=True)
        path = directory / f"{name}.py"
        write_source(path, source)
        record_compile_event({"event": "load", "module": name})
        below = frozenset().union(*({module.__name__, *_BELOW.get(module.__name__, ())} for module in imports))
        _BELOW[name] = below
        spec = importlib.util.spec_from_file_location(name, path)
        module = importlib.util.module_from_spec(spec)
        sys.modules[name] = module
        try:
            spec.loader.exec_module(module)
        except BaseException:
            del sys.modules[name]
            raise
        lock = CompileLock(directory / f"{name}.lock", name, below)
        for value in vars(module).values():
            if isinstance(value, Dispatcher) and value.py_func.__module__ == name:
                value.compile = functools.partial(lock.compile, value, value.compile)
        return module


def compiled_in_cache(source: str, function: str) -> bool:
    """Whether numba's disk cache holds machine code of ``function`` of the generated module of
    ``source``: its cache index, beside the module's file. Loading the module then compiles nothing.

    False where it cannot tell (``$NUMBA_CACHE_DIR`` moves numba's cache elsewhere). An index
    that numba finds stale (its module's file rewritten) still reads True here; the load then
    compiles, as it would have.
    """
    if os.environ.get("NUMBA_CACHE_DIR"):
        return False
    directory = cache_directory()
    tag = f"py{sys.version_info.major}{sys.version_info.minor}"
    for path in directory.glob(f"{GENERATED_PREFIX}*_{module_digest(source)}.py"):
        if any((directory / "__pycache__").glob(f"{path.stem}.{function}-*.{tag}.nbi")):
            return True
    return False


def write_source(path: Path, source: str) -> None:
    """Put ``source`` at ``path`` atomically, never replacing the same text another process put there.

    numba's cache index is keyed by the source file's modification time: a file rewritten after
    another process imported it would void that process's cache entries, and the module would
    be compiled again. A new file is therefore linked into place (which fails if one is there);
    only a file with other text (torn or edited by hand) is replaced.
    """
    if path.is_file() and path.read_text() == source:
        return
    # Linked only if no file is there (another process's, linked just now, has the same text: the
    # name is its hash); a torn or edited file is replaced.
    with atomic_path(path, replace=path.is_file()) as temporary:
        temporary.write_text(source)


class CompileLock:
    """One process at a time compiles the functions of one generated module; the others wait, then load.

    Each dispatcher of the module has its ``compile`` wrapped by :meth:`compile`. numba's
    ``Dispatcher.compile`` looks in memory, then in its disk cache, then compiles and saves:
    around the outermost call, in this order, the wrapper takes numba's global compiler lock
    (re-entrant; it already keeps the threads of a process from compiling at once) and an
    exclusive ``flock`` on ``path``, a file beside the module. A process that finds the lock
    taken waits, and its own ``compile`` then finds what the holder saved in numba's cache. The
    nested compiles of callees (the kernels and templates ``process`` calls) happen inside the
    outermost one, under the lock already held.

    Deadlock-free: a thread waits for a module's lock only while holding no other module's, or
    only locks of modules that import it (``below``: an engine compiling a function of the
    common modules it imports, see :mod:`ldpipe.engine.codegen`). Imports between generated
    modules never go round in a circle, so every chain of waits goes down them and ends. The
    wait, rather than compiling alongside, is what lets two engines racing for one common module
    compile it once. Any other nesting (none today) only tries the lock, and compiles without it
    if it is taken.

    The operating system releases an ``flock`` when its holder exits, crashed or not. A file
    system without ``flock`` (some NFS and FUSE mounts), or a cache folder the process cannot
    create files in, means compiling without waiting (a debug log line says so). A holder that
    hangs is waited for :data:`LOCK_PATIENCE_S` at most. Each wait is a ``wait`` line of the
    compile log: the module, the function, the seconds waited.
    """

    # The locks this process holds, outermost first (guarded by numba's global compiler lock).
    held: ClassVar[list["CompileLock"]] = []
    # The modules whose compile this process has announced (:data:`COMPILING_NOTICE`), and when it
    # last did: the modules one call compiles (the system's kernels, then its engine) are told once.
    announced: ClassVar[set[str]] = set()
    last_notice: ClassVar[float] = -math.inf

    def __init__(self, path: Path, module: str, below: frozenset[str] = frozenset()):
        self.path = path
        self.module = module
        self.below = below  # the generated modules this one imports, directly or not

    def compile(self, dispatcher: Dispatcher, compile_function: Callable, signature):
        """``compile_function(signature)`` (the dispatcher's own ``compile``) under this lock."""
        from numba.core import sigutils
        from numba.core.compiler_lock import global_compiler_lock

        with global_compiler_lock:
            if self in CompileLock.held or tuple(sigutils.normalize_signature(signature)[0]) in dispatcher.overloads:
                return compile_function(signature)  # a callee's compile inside ours, or compiled already
            patient = all(self.module in outer.below for outer in CompileLock.held)
            self.announce(dispatcher.py_func.__qualname__)
            descriptor = self.acquire(dispatcher.py_func.__qualname__, patient)
            CompileLock.held.append(self)
            try:
                return compile_function(signature)
            finally:
                CompileLock.held.pop()
                if descriptor is not None:
                    os.close(descriptor)  # releases the flock

    def announce(self, function: str) -> None:
        """Tell the user that ``function``'s compile (an outermost one: callees of other modules
        compile inside it, untold) will take a while, unless numba's cache beside the module holds
        it: once per module, and once for the modules one call compiles one after another
        (:data:`NOTICE_QUIET_S`)."""
        if CompileLock.held or self.module in CompileLock.announced or os.environ.get("NUMBA_CACHE_DIR"):
            return  # inside another's compile, announced, or numba's cache is elsewhere (a load looks like a compile)
        tag = f"py{sys.version_info.major}{sys.version_info.minor}"
        if any((self.path.parent / "__pycache__").glob(f"{self.module}.{function}-*.{tag}.nbi")):
            return
        CompileLock.announced.add(self.module)
        now = time.monotonic()
        if now - CompileLock.last_notice < NOTICE_QUIET_S:
            return
        CompileLock.last_notice = now
        what = self.module.removeprefix(GENERATED_PREFIX).rsplit("_", 1)[0]
        tell_user(logger, COMPILING_NOTICE.format(what=f"the engine of {what!r}", cache=self.path.parent))

    def acquire(self, function: str, patient: bool) -> int | None:
        """A descriptor of the lock file, ``flock``-ed; None if there is no lock to be had (compile anyway)."""
        try:
            descriptor = os.open(self.path, os.O_RDWR | os.O_CREAT, 0o666)
        except OSError as error:
            logger.debug("compiling %s.%s without a lock: cannot open %s (%s)", self.module, function, self.path, error)
            return None
        started = time.perf_counter()
        pause = 0.0
        try:
            while True:
                try:
                    fcntl.flock(descriptor, fcntl.LOCK_EX | fcntl.LOCK_NB)
                    break
                except BlockingIOError:  # another process holds it
                    pass
                except OSError as error:
                    logger.debug("compiling %s.%s without a lock: the file system refuses flock on %s (%s)",
                                 self.module, function, self.path, error)
                    os.close(descriptor)
                    return None
                waited = time.perf_counter() - started
                if not patient:
                    logger.debug("compiling %s.%s while another process holds its lock (inside the compile of a "
                                 "module that does not import it, where waiting could deadlock)", self.module, function)
                    os.close(descriptor)
                    return None
                if waited > LOCK_PATIENCE_S:
                    logger.warning("compiling %s.%s after waiting %.0f s for the process holding %s",
                                   self.module, function, waited, self.path)
                    os.close(descriptor)
                    return None
                pause = min(2 * pause or 0.01, 0.25)
                time.sleep(pause)
        except BaseException:
            os.close(descriptor)
            raise
        if pause:
            record_compile_event({"event": "wait", "module": self.module, "function": function,
                                  "wall_s": time.perf_counter() - started})
        return descriptor


def njit_functions(source: str, names: tuple[str, ...], prefix: str) -> list[Callable]:
    """The functions ``names`` that ``source`` defines, each compiled by ``njit(cache=True)``.

    For a system's kernels (compiled lazily, on first call, or loaded from numba's disk cache).
    """
    # Strict IEEE arithmetic (no fastmath): with fastmath, code compiled in this process and
    # code loaded from the disk cache can round differently, and results must not depend on
    # which process compiled them.
    module = load_generated_module(njit_module_source(source, names), prefix=prefix)
    return [getattr(module, name) for name in names]


def njit_module_source(source: str, names: tuple[str, ...]) -> str:
    """The text of :func:`njit_functions`' module: ``source``, then ``names`` compiled by ``njit(cache=True)``."""
    return source + "\nfrom numba import njit as _njit\n\n" + "".join(f"{name} = _njit(cache=True)({name})\n" for name in names)


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


def compile_recorder():
    """A numba event listener that times each outermost compile of a generated module's function
    (its callees compile inside it) into the compile log.

    numba raises "numba:compile" only on a cache miss, so a function loaded from the disk cache
    records nothing. The class is made on first use: its base is numba's.
    """
    from numba.core import event

    class CompileRecorder(event.Listener):
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

    return CompileRecorder()


_recorder = None  # the compile log's listener, registered once per process


def register_compile_recorder() -> None:
    """With ``$LDPIPE_COMPILE_LOG`` set, listen to numba's compiles (once per process).

    Called before a generated module is loaded: every compile the log counts is of a function
    of such a module, so none happens before.
    """
    global _recorder
    if _recorder is not None or not os.environ.get(COMPILE_LOG_VARIABLE):
        return
    from numba.core import event

    with _LOCK:
        if _recorder is None:
            _recorder = compile_recorder()
            event.register("numba:compile", _recorder)
