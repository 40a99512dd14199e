"""The engine's compiled code is cached on disk: a second process loads it instead of compiling.

The engine is generated as one source module per (system, scheme, block size) and loaded
through ldpipe.jitcache (see ldpipe.engine.codegen). Expected values here are invariants:
numba's own cache statistics of the compiled driver (a miss where nothing was cached, hits
and no miss afterwards), and bitwise equality of the results of processes that compiled and
processes that loaded the code (the same program, strict IEEE arithmetic).
"""

import builtins
import json
import os
import subprocess
import sys
import symtable
from types import SimpleNamespace

import pytest

from ldpipe.engine import SCHEMES
from ldpipe.engine.codegen import engine_source

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


def start_child(cache_dir):
    env = {**os.environ, "LDPIPE_CACHE_DIR": str(cache_dir)}
    return subprocess.Popen([sys.executable, "-c", CHILD], env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)


def finish(child):
    out, err = child.communicate(timeout=600)
    assert child.returncode == 0, err
    return json.loads(out.strip().splitlines()[-1])


@pytest.mark.slow
def test_second_process_loads_the_compiled_engine(tmp_path):
    # Two processes start on an empty cache at once (both may compile; the file and numba's
    # cache entries are written atomically, so neither may fail or read a torn file); a third
    # process afterwards must load everything from the cache.
    racing = [start_child(tmp_path), start_child(tmp_path)]
    first = [finish(child) for child in racing]
    later = finish(start_child(tmp_path))
    assert any(run["misses"] > 0 for run in first)  # the cache really started empty
    assert later["hits"] > 0 and later["misses"] == 0
    # compiled here or loaded from disk, the same machine code gives the same bits
    assert first[0]["ld"] == first[1]["ld"] == later["ld"]
    generated = list(tmp_path.glob("ldpipe_generated_engine_*.py"))
    assert len(generated) == 1 and not list(tmp_path.glob(".*.tmp"))


@pytest.mark.parametrize(("scheme", "entry"), [*((s, "process") for s in SCHEMES), ("dop853", "flow_process")])
def test_generated_module_defines_every_name_it_uses(barbanis, scheme, entry):
    # The templates use names the header defines (sizes, offsets, kernels): every global a
    # function reads must be bound at module level or be a builtin. Both drivers: the LD
    # engine's and ldpipe.flow's.
    order = 12 if scheme == "taylor" else None
    table = symtable.symtable(engine_source(barbanis, scheme, 8, order, entry), "<engine>", "exec")
    defined = {s.get_name() for s in table.get_symbols() if s.is_assigned() or s.is_imported()}
    missing = set()
    for child in table.get_children():
        for function in [child, *child.get_children()]:
            for symbol in function.get_symbols():
                name = symbol.get_name()
                if symbol.is_global() and name not in defined and not hasattr(builtins, name):
                    missing.add((function.get_name(), name))
    assert not missing


def test_kernel_source_may_not_shadow_engine_names(barbanis):
    # A kernel constant named like an engine constant would silently change one or the other.
    system = SimpleNamespace(name="clash", n_dof=2, kernel_source=barbanis.kernel_source + "\nLANES = 3\n",
                             mass_matrix=None)
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
