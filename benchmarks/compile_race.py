"""Processes that need one uncompiled engine module at once: what they compile, and what it costs.

Each round starts ``--processes`` processes together on an empty, private cache
(``LDPIPE_CACHE_DIR`` and ``NUMBA_CACHE_DIR`` in a temporary folder), each computing the same
small LD (Barbanis 2 DoF, ``--scheme`` at 8 lanes: the module tests/engine/test_cache.py races
on), with the ldpipe of each ``--src`` folder first on the path; the rounds alternate between
the folders. It reports per round the wall seconds, the CPU seconds of the processes
(``getrusage`` of the children), the functions compiled and the waits (``LDPIPE_COMPILE_LOG``),
and the load average before and after.

    python benchmarks/compile_race.py --src OLD/src src --rounds 2
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

CHILD = """
import sys

import numpy as np
from ldpipe.engine import LDSettings, compute_ld
from ldpipe.systems import make_system

system = make_system("barbanis_2dof", {"builtin": "barbanis_2dof"})
states = np.array([[0.5, 0.0, 0.3, 2.0], [1.0, 0.2, -0.3, 1.5]])
compute_ld(system, states, +1, LDSettings(scheme=sys.argv[1], dt=0.05, tau=5.0, block=8))
"""


def load_average() -> str:
    return ", ".join(f"{v:.2f}" for v in os.getloadavg())


def race(src: Path, scheme: str, processes: int) -> dict:
    """One round: ``processes`` children at once on an empty cache, with ``src`` first on the path."""
    with tempfile.TemporaryDirectory(prefix="ldpipe-race-") as folder:
        log = Path(folder) / "compiles.jsonl"
        env = {**os.environ, "PYTHONPATH": str(src), "LDPIPE_CACHE_DIR": str(Path(folder) / "ldpipe"),
               "NUMBA_CACHE_DIR": str(Path(folder) / "numba"), "LDPIPE_COMPILE_LOG": str(log)}
        load = load_average()
        before = resource.getrusage(resource.RUSAGE_CHILDREN)
        start = time.perf_counter()
        children = [subprocess.Popen([sys.executable, "-c", CHILD, scheme], env=env) for _ in range(processes)]
        codes = [child.wait() for child in children]
        wall = time.perf_counter() - start
        after = resource.getrusage(resource.RUSAGE_CHILDREN)
        records = [json.loads(line) for line in log.read_text().splitlines()] if log.is_file() else []
    compiles = [r for r in records if r["event"] == "compile"]
    waits = [r for r in records if r["event"] == "wait"]
    return {"src": str(src), "codes": codes, "wall_s": wall,
            "cpu_s": (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime),
            "compiles": len(compiles), "compile_cpu_s": sum(r["cpu_s"] for r in compiles),
            "waits": len(waits), "waited_s": sum(r["wall_s"] for r in waits),
            "load_before": load, "load_after": load_average()}


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--src", nargs="+", type=Path, required=True, help="folders holding the ldpipe package")
    parser.add_argument("--scheme", default="sym4", help="the engine's scheme (default sym4)")
    parser.add_argument("--processes", type=int, default=2, help="processes started together (default 2)")
    parser.add_argument("--rounds", type=int, default=2, help="rounds per folder, alternating (default 2)")
    args = parser.parse_args(argv)
    print(f"{os.cpu_count()} cores; {args.processes} processes per round, barbanis_2dof {args.scheme} at 8 lanes")
    print("| round | src | exit codes | wall s | CPU s | functions compiled | compile CPU s | waits | waited s "
          "| load before | load after |")
    print("| ---: | --- | --- | ---: | ---: | ---: | ---: | ---: | ---: | --- | --- |")
    for k in range(args.rounds):
        for src in args.src:
            r = race(src.resolve(), args.scheme, args.processes)
            print(f"| {k + 1} | {r['src']} | {r['codes']} | {r['wall_s']:.1f} | {r['cpu_s']:.1f} | {r['compiles']} "
                  f"| {r['compile_cpu_s']:.1f} | {r['waits']} | {r['waited_s']:.1f} | {r['load_before']} "
                  f"| {r['load_after']} |", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
