"""The engine's compiled code is cached on disk: a second process loads it instead of compiling.

The engine is generated as one source module per (system, scheme, block size) and loaded
through ldpipe.jitcache (see ldpipe.engine.codegen). Expected values here are invariants:
numba's own cache statistics of the compiled driver (a miss where nothing was cached, hits
and no miss afterwards), and bitwise equality of the results of processes that compiled and
processes that loaded the code (the same program, strict IEEE arithmetic).
"""

import ast
import builtins
import collections
import errno
import json
import logging
import os
import subprocess
import sys
import symtable
import threading
from pathlib import Path
from types import SimpleNamespace

import pytest

from ldpipe import jitcache
from ldpipe.engine import SCHEMES, LDSettings
from ldpipe.engine.codegen import engine_compiled, engine_modules, engine_source

# Run in a subprocess: a small LD computation; prints the LDs (as hex, for bitwise comparison)
# and the cache statistics of the compiled driver ``process``.
CHILD = """
import json
import numpy as np
from ldpipe.engine import LDSettings, compute_ld
from ldpipe.engine.integrator import get_runner
from ldpipe.systems import make_system

system = make_system("barbanis_2dof", {"builtin": "barbanis_2dof"})
states = np.array([[0.5, 0.0, 0.3, 2.0], [1.0, 0.2, -0.3, 1.5], [-1.0, 0.5, 0.8, 1.0], [2.0, -1.0, 0.0, 2.5]])
settings = LDSettings(scheme="sym4", dt=0.05, tau=5.0, block=8)
result = compute_ld(system, states, +1, settings)
stats = get_runner(system, settings.scheme, settings.lanes).stats
print(json.dumps({
    "ld": [float(x).hex() for x in result.ld],
    "hits": sum(stats.cache_hits.values()),
    "misses": sum(stats.cache_misses.values()),
}))
"""


def start_child(cache_dir, log):
    env = {**os.environ, "LDPIPE_CACHE_DIR": str(cache_dir), "LDPIPE_COMPILE_LOG": str(log)}
    return subprocess.Popen([sys.executable, "-c", CHILD], env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)


def finish(child):
    out, err = child.communicate(timeout=600)
    assert child.returncode == 0, err
    return json.loads(out.strip().splitlines()[-1])


def read_log(path):
    return [json.loads(line) for line in path.read_text().splitlines()]


@pytest.mark.slow
def test_second_process_loads_the_compiled_engine(tmp_path, barbanis, monkeypatch):
    # Two processes start on an empty cache at once: one compiles the engine, the other waits for
    # its lock and loads what it saved (numba's cache statistics: misses in one, none in the
    # other); every function is compiled once (the compile log). The file and numba's cache
    # entries are written atomically, so neither may fail or read a torn file; a third process
    # afterwards must load everything from the cache.
    cache, log = tmp_path / "cache", tmp_path / "compiles.jsonl"
    monkeypatch.setenv("LDPIPE_CACHE_DIR", str(cache))
    monkeypatch.delenv("NUMBA_CACHE_DIR", raising=False)
    lanes = LDSettings(scheme="sym4", dt=0.05, tau=5.0, block=8).lanes  # the children's engine
    assert not engine_compiled(barbanis, "sym4", lanes)
    racing = [start_child(cache, log), start_child(cache, log)]
    first = [finish(child) for child in racing]
    assert engine_compiled(barbanis, "sym4", lanes)  # what the later process loads without a miss
    later = finish(start_child(cache, log))
    assert sorted(run["misses"] > 0 for run in first) == [False, True]  # the cache really started empty
    assert later["hits"] > 0 and later["misses"] == 0
    compiled = collections.Counter((r["module"], r["function"]) for r in read_log(log) if r["event"] == "compile")
    assert compiled and set(compiled.values()) == {1}
    # compiled here or loaded from disk, the same machine code gives the same bits
    assert first[0]["ld"] == first[1]["ld"] == later["ld"]
    generated = list(cache.glob("ldpipe_generated_engine_*.py"))
    assert len(generated) == 1 and not list(cache.glob(".*.tmp"))


@pytest.mark.parametrize(("scheme", "entry"), [*((s, "process") for s in SCHEMES), ("dop853", "flow_process")])
def test_generated_module_defines_every_name_it_uses(barbanis, scheme, entry):
    # The templates use names the header defines (sizes, offsets, kernels): every global a
    # function reads must be bound at module level or be a builtin. Both drivers: the LD
    # engine's and ldpipe.core.trajectories's.
    # The same holds in each common module the engine imports from, and the names an engine or a
    # common module imports are names the module it imports them from binds.
    order = 12 if scheme == "taylor" else None
    modules = engine_modules(barbanis, scheme, 8, order, entry)
    bound = {}
    missing = set()
    for name, text in [*((m.name, m.text) for m in modules.common), ("<engine>", modules.engine)]:
        table = symtable.symtable(text, name, "exec")
        defined = {s.get_name() for s in table.get_symbols() if s.is_assigned() or s.is_imported()}
        bound[name] = {s.get_name() for s in table.get_symbols() if s.is_assigned()}
        for child in table.get_children():
            for function in [child, *child.get_children()]:
                for symbol in function.get_symbols():
                    used = symbol.get_name()
                    if symbol.is_global() and used not in defined and not hasattr(builtins, used):
                        missing.add((name, function.get_name(), used))
        for node in ast.parse(text).body:
            if isinstance(node, ast.ImportFrom) and node.module.startswith(jitcache.GENERATED_PREFIX):
                missing |= {(name, node.module, alias.name) for alias in node.names
                            if alias.name not in bound[node.module]}
    assert modules.common and not missing


def test_kernel_source_may_not_shadow_engine_names(barbanis):
    # A kernel constant named like an engine constant would silently change one or the other.
    system = SimpleNamespace(name="clash", n_dof=2, kernel_source=barbanis.kernel_source + "\nLANES = 3\n",
                             mass_matrix=None, hamiltonian=True)
    with pytest.raises(ValueError, match="LANES"):
        engine_source(system, "dop853", 8)


# A generated module of one small function, compiled by ldpipe.jitcache in a child process.
LOGGED_CHILD = """
import sys

from ldpipe.jitcache import njit_functions

(double,) = njit_functions("def double(x):\\n    return 2.0 * x\\n", ("double",), sys.argv[1])
print(double(1.5))
"""


def run_logged_child(env, prefix):
    child = subprocess.run([sys.executable, "-c", LOGGED_CHILD, prefix], env=env, capture_output=True, text=True,
                           timeout=300)
    assert child.returncode == 0 and child.stdout.strip() == "3.0", child.stderr


def test_compile_log_records_compiles_and_loads(tmp_path):
    # Invariant of numba's cache: the first process compiles the function (one compile line with
    # its times), the second loads it from the disk cache (a load line and no compile line).
    log = tmp_path / "compiles.jsonl"
    env = {**os.environ, "LDPIPE_CACHE_DIR": str(tmp_path / "cache"), "LDPIPE_COMPILE_LOG": str(log)}
    for _ in range(2):
        run_logged_child(env, "compile_log_check")
    records = [json.loads(line) for line in log.read_text().splitlines()]
    first, second = sorted({r["pid"] for r in records}, key=[r["pid"] for r in records].index)
    events = {pid: [(r["event"], r.get("function")) for r in records if r["pid"] == pid] for pid in (first, second)}
    assert events[first] == [("load", None), ("compile", "double")]
    assert events[second] == [("load", None)]
    compiled = next(r for r in records if r["event"] == "compile")
    assert compiled["module"].startswith("ldpipe_generated_compile_log_check_")
    assert compiled["wall_s"] > 0 and compiled["cpu_s"] > 0


def test_compiled_in_cache_says_whether_numba_saved_the_function(tmp_path, monkeypatch):
    # Expected values from numba's own cache: nothing before the first process; after it compiled
    # ``double`` (its compile line), the function is in the cache, and a function it never had is
    # not. With numba's cache moved elsewhere the answer is "cannot tell": False.
    cache, log = tmp_path / "cache", tmp_path / "compiles.jsonl"
    monkeypatch.setenv("LDPIPE_CACHE_DIR", str(cache))
    monkeypatch.delenv("NUMBA_CACHE_DIR", raising=False)
    source = jitcache.njit_module_source("def double(x):\n    return 2.0 * x\n", ("double",))
    assert not jitcache.compiled_in_cache(source, "double")
    run_logged_child({**os.environ, "LDPIPE_COMPILE_LOG": str(log)}, "compiled_in_cache_check")
    assert [r["function"] for r in read_log(log) if r["event"] == "compile"] == ["double"]
    assert jitcache.compiled_in_cache(source, "double")
    assert not jitcache.compiled_in_cache(source, "dou")
    assert not jitcache.compiled_in_cache(source.replace("2.0", "3.0"), "double")
    monkeypatch.setenv("NUMBA_CACHE_DIR", str(tmp_path / "numba"))
    assert not jitcache.compiled_in_cache(source, "double")


def test_the_same_source_under_another_name_reuses_the_compiled_module(tmp_path):
    # Invariant: the file is named by the hash of its text, so a second name for the same text
    # (two names for one system) finds the first file and numba's cache beside it: one file, and
    # the second process loads it under the first name without compiling.
    log = tmp_path / "compiles.jsonl"
    env = {**os.environ, "LDPIPE_CACHE_DIR": str(tmp_path / "cache"), "LDPIPE_COMPILE_LOG": str(log)}
    run_logged_child(env, "first_name")
    run_logged_child(env, "second_name")
    records = [json.loads(line) for line in log.read_text().splitlines()]
    assert [r["event"] for r in records] == ["load", "compile", "load"]
    assert records[0]["module"] == records[2]["module"] and "first_name" in records[2]["module"]
    assert len(list((tmp_path / "cache").glob("ldpipe_generated_*.py"))) == 1


# Two of these start at once on an empty cache: each loads a one-function module, waits at a
# barrier (a file per process in argv[1]) until both are there, then calls the function. A
# listener makes numba's compile last 3 s, so two compiles started together would overlap.
RACING_CHILD = """
import json
import os
import sys
import time
from pathlib import Path

from numba.core import event

from ldpipe.jitcache import njit_functions


class SlowCompile(event.Listener):
    def on_start(self, ev):
        time.sleep(3.0)

    def on_end(self, ev):
        pass


event.register("numba:compile", SlowCompile())
(double,) = njit_functions("def double(x):\\n    return 2.0 * x\\n", ("double",), "compile_lock_check")
barrier = Path(sys.argv[1])
(barrier / str(os.getpid())).touch()
while len(list(barrier.iterdir())) < 2:
    time.sleep(0.01)
value = double(1.5)
stats = double.stats
print(json.dumps({"pid": os.getpid(), "value": value, "hits": sum(stats.cache_hits.values()),
                  "misses": sum(stats.cache_misses.values())}))
"""


def race(tmp_path, child, roles):
    """Start the script ``child`` once per role (its arguments: a barrier folder, the role) at once,
    on an empty cache of their own; (their outputs by role, the compile log's records)."""
    barrier, log = tmp_path / "barrier", tmp_path / "compiles.jsonl"
    barrier.mkdir()
    env = {**os.environ, "LDPIPE_CACHE_DIR": str(tmp_path / "cache"), "LDPIPE_COMPILE_LOG": str(log)}
    racing = [subprocess.Popen([sys.executable, "-c", child, str(barrier), role], env=env, stdout=subprocess.PIPE,
                               stderr=subprocess.PIPE, text=True) for role in roles]
    return [finish(process) for process in racing], read_log(log)


def test_processes_needing_one_module_at_once_compile_it_once(tmp_path):
    # Invariants of the lock and numba's cache: of two processes that need the same uncompiled
    # function at the same moment, one compiles it (a miss in numba's statistics, the only
    # compile line of the log) and the other waits for it (a wait line, most of the 3 s compile
    # long) and then loads it from the disk cache (a hit, no miss).
    outputs, records = race(tmp_path, RACING_CHILD, ("first", "second"))
    runs = {run["pid"]: run for run in outputs}
    assert [run["value"] for run in runs.values()] == [3.0, 3.0]
    compiles = [r for r in records if r["event"] == "compile"]
    assert [r["function"] for r in compiles] == ["double"]
    compiler = compiles[0]["pid"]
    (waiter,) = set(runs) - {compiler}
    assert runs[compiler]["misses"] == 1
    assert runs[waiter]["misses"] == 0 and runs[waiter]["hits"] == 1
    (wait,) = [r for r in records if r["event"] == "wait"]
    assert wait["pid"] == waiter and wait["function"] == "double" and wait["module"] == compiles[0]["module"]
    assert wait["wall_s"] > 1.0


# A module B that calls a function of a module A it imports (as an engine calls its common
# modules'). Role "a" calls A's function itself, its compile made 3 s long, while role "b", half a
# second later, calls B's: B's compile needs A's function, whose lock "a" holds.
NESTED_CHILD = """
import json
import os
import sys
import time
from pathlib import Path

from numba.core import event

from ldpipe.jitcache import load_generated_module, module_name

A = "from numba import njit\\n\\n\\n@njit(cache=True)\\ndef double(x):\\n    return 2.0 * x\\n"
B = ("from numba import njit\\nfrom " + module_name(A, "nested_a") + " import double\\n\\n\\n"
     "@njit(cache=True)\\ndef quad(x):\\n    return double(double(x))\\n")
barrier, role = Path(sys.argv[1]), sys.argv[2]


class SlowCompile(event.Listener):
    def on_start(self, ev):
        if role == "a":
            time.sleep(3.0)

    def on_end(self, ev):
        pass


event.register("numba:compile", SlowCompile())
a = load_generated_module(A, "nested_a")
b = load_generated_module(B, "nested_b", (a,))
(barrier / role).touch()
while len(list(barrier.iterdir())) < 2:
    time.sleep(0.01)
if role == "a":
    value = a.double(1.5)
else:
    time.sleep(0.5)
    value = b.quad(1.5)
stats = a.double.stats
print(json.dumps({"pid": os.getpid(), "value": value, "misses": sum(stats.cache_misses.values()),
                  "hits": sum(stats.cache_hits.values())}))
"""


def test_a_compile_needing_an_imported_function_waits_for_its_compile(tmp_path):
    # Invariant of the lock and numba's cache: "b", compiling B's function, needs A's function
    # while "a" compiles it; it waits for A's lock (a wait line in the log, most of the 3 s long)
    # and loads A's function from the disk cache (a hit, no miss), so it is compiled once.
    outputs, records = race(tmp_path, NESTED_CHILD, ("a", "b"))
    runs = dict(zip("ab", outputs))
    assert runs["a"]["value"] == 3.0 and runs["b"]["value"] == 6.0
    assert runs["a"]["misses"] == 1
    assert runs["b"]["misses"] == 0 and runs["b"]["hits"] == 1
    waits = [r for r in records if r["event"] == "wait"]
    assert [(r["pid"], r["function"]) for r in waits] == [(runs["b"]["pid"], "double")]
    assert waits[0]["module"].startswith("ldpipe_generated_nested_a_") and waits[0]["wall_s"] > 1.0


def tiny_module(cache, tag):
    """A one-function generated module in the cache folder ``cache``, its text unique to ``tag``
    (a process keeps one module per text), not compiled yet."""
    (double,) = jitcache.njit_functions(f"def double(x):  # {tag}\n    return 2.0 * x\n", ("double",), "lock_check")
    assert Path(sys.modules[double.__module__].__file__).parent == cache
    return double


# Holds an flock on the file argv[1] until killed: a process compiling the module, then crashing.
HOLDER = """
import fcntl
import os
import sys
import time

descriptor = os.open(sys.argv[1], os.O_RDWR | os.O_CREAT)
fcntl.flock(descriptor, fcntl.LOCK_EX)
print("held", flush=True)
time.sleep(600)
"""


def test_a_crashed_holder_releases_the_lock(tmp_path, monkeypatch):
    # The operating system drops a dead process's flock: a process waiting for a holder that is
    # killed (1 s after it took the lock) stops waiting and compiles the function itself (a miss).
    cache, log = tmp_path / "cache", tmp_path / "compiles.jsonl"
    monkeypatch.setenv("LDPIPE_CACHE_DIR", str(cache))
    monkeypatch.setenv("LDPIPE_COMPILE_LOG", str(log))
    double = tiny_module(cache, tmp_path.name)
    lock = Path(sys.modules[double.__module__].__file__).with_suffix(".lock")  # the module's lock file, beside it
    holder = subprocess.Popen([sys.executable, "-c", HOLDER, str(lock)], stdout=subprocess.PIPE, text=True)
    try:
        assert holder.stdout.readline() == "held\n"
        threading.Timer(1.0, holder.kill).start()
        assert double(1.5) == 3.0
    finally:
        holder.kill()
        holder.communicate(timeout=60)
    assert sum(double.stats.cache_misses.values()) == 1
    (wait,) = [r for r in read_log(log) if r["event"] == "wait"]
    assert wait["module"] == double.__module__ and wait["function"] == "double" and wait["wall_s"] > 0.5


def test_without_flock_the_module_compiles_unlocked(tmp_path, monkeypatch, caplog):
    # A file system refusing flock (NFS without a lock manager: ENOLCK) must not stop or hang a
    # compile: the function is compiled without the lock, and a debug line says so.
    def refuse(descriptor, operation):
        raise OSError(errno.ENOLCK, os.strerror(errno.ENOLCK))

    monkeypatch.setenv("LDPIPE_CACHE_DIR", str(tmp_path))
    monkeypatch.setattr(jitcache, "fcntl", SimpleNamespace(flock=refuse, LOCK_EX=1, LOCK_NB=2))
    caplog.set_level(logging.DEBUG, logger=jitcache.__name__)
    double = tiny_module(tmp_path, tmp_path.name)
    assert double(1.5) == 3.0
    assert "refuses flock" in caplog.text and double.__module__ in caplog.text


def test_the_first_compile_is_announced_and_a_load_is_not(tmp_path):
    # In a notebook (a Jupyter kernel loaded) the first process compiles ``double`` and says so on
    # standard error, once; the second loads it from numba's cache (the compile log's invariant
    # above) and says nothing.
    env = {**os.environ, "LDPIPE_CACHE_DIR": str(tmp_path / "cache")}
    env.pop("NUMBA_CACHE_DIR", None)
    notebook = "import sys, types\nsys.modules['ipykernel'] = types.ModuleType('ipykernel')\n" + LOGGED_CHILD
    told = []
    for _ in range(2):
        child = subprocess.run([sys.executable, "-c", notebook, "notice_check"], env=env, capture_output=True,
                               text=True, timeout=300)
        assert child.returncode == 0 and child.stdout.strip() == "3.0", child.stderr
        told.append([line for line in child.stderr.splitlines() if line.startswith("ldpipe: compiling")])
    assert len(told[0]) == 1 and "'notice_check'" in told[0][0] and "10 to 60 s" in told[0][0]
    assert told[1] == []
