"""Where an engine module's numba compile spends its CPU time, for two versions side by side.

Each run compiles one module kind in a fresh process with an empty private cache
(``$LDPIPE_CACHE_DIR`` a new temporary folder), so nothing is loaded from numba's disk cache, and
reports the CPU seconds of the first call (the compile), split by phase:

- numba's front end per pass (bytecode analysis, type inference, rewrites, ...), and the
  lowering to LLVM IR (``lowering``: NativeLowering less the LLVM work inside it);
- LLVM: the function passes run on each function's own IR (``llvm function passes``), the
  module passes run once a function's library has its callees linked in (``llvm module
  passes``), and the machine code generated for that library (``llvm codegen``).

numba compiles every function a compiled function calls as a library of its own (once per
argument-type signature) and links the callee's library into the caller's, where the module
passes and the code generation run again over all of it: the deeper a callee sits in the call
tree, the more often LLVM works on its code. ``--functions`` lists the CPU seconds per function
(its own front end and LLVM work, callees excluded) and its signatures.

After the compile the worker computes the module's results on a small test grid and reports
their hash, so that two versions can be checked bit for bit (``equal`` column).

``--second`` then compiles the same kind for a second system of the same shape (Hénon–Heiles, a
formula system with 2 DoF) in a fresh process on the same cache, and reports that compile's CPU
seconds (``second CPU s``): what the second engine of a shape costs once the first is compiled
(the LD quadrature's common modules are then loaded from the cache).

    .venv/bin/python benchmarks/compile_time.py --old ../baseline/src --new src --kinds dop853 rk4 --rounds 2
    .venv/bin/python benchmarks/compile_time.py --new src --kinds dop853 --functions 25   # one version, its profile
    .venv/bin/python benchmarks/compile_time.py --old ../baseline/src --new src --kinds dop853 --second

Kinds: ``dop853``, ``rk4``, ``sym4``, ``sym6``, ``taylor`` (LD maps of Barbanis 2 DoF, 64 lanes,
the default LD settings), ``flow`` (``ldpipe.core.trajectories.integrate``'s dop853 driver, 32 lanes) and
``vector-field`` (the forced Duffing oscillator's first-order DOP853 LDs).
"""

from __future__ import annotations

import argparse
import hashlib
import json
import os
import subprocess
import sys
import tempfile
import time
from collections import defaultdict
from pathlib import Path

import numpy as np

KINDS = ("dop853", "rk4", "sym4", "sym6", "taylor", "flow", "vector-field")
HENON_HEILES = {"formula": "(x**2 + y**2)/2 + lam*(x**2*y - y**3/3)", "coordinates": ["x", "y"],
                "parameters": {"lam": 1.0}}
DUFFING = {"vector_field": {"x": "y", "y": "x - x**3 - delta*y + F*cos(omega*t)"}, "coordinates": ["x", "y"],
           "parameters": {"delta": 0.25, "F": 0.3, "omega": 1.2}}


class PhaseTimer:
    """CPU seconds (this thread) per (function, phase), each phase's time without the phases nested in it."""

    def __init__(self):
        self.stack = []  # [function, phase, start, time of nested phases]
        self.seconds = defaultdict(float)

    def enter(self, function: str, phase: str) -> None:
        self.stack.append([function, phase, time.thread_time(), 0.0])

    def exit(self) -> None:
        function, phase, start, nested = self.stack.pop()
        spent = time.thread_time() - start
        self.seconds[function, phase] += spent - nested
        if self.stack:
            self.stack[-1][3] += spent

    def wrap(self, cls, method: str, phase: str) -> None:
        """Time ``cls.method`` as ``phase`` of the function its library is named after."""
        original = getattr(cls, method)
        timer = self

        def timed(library, *args, **kwargs):
            timer.enter(library.name, phase)
            try:
                return original(library, *args, **kwargs)
            finally:
                timer.exit()

        setattr(cls, method, timed)


def install(timer: PhaseTimer) -> None:
    """Time numba's passes (by the ``numba:run_pass`` event) and LLVM's work (by wrapping the code library)."""
    from numba.core import codegen, event

    class Passes(event.Listener):
        def on_start(self, ev):
            name = ev.data["name"].split(" [")[0]
            timer.enter(ev.data["qualname"], "lowering" if name.endswith("lowering") else name)

        def on_end(self, ev):
            timer.exit()

    event.register("numba:run_pass", Passes())
    timer.wrap(codegen.CPUCodeLibrary, "_optimize_functions", "llvm function passes")
    timer.wrap(codegen.CPUCodeLibrary, "_optimize_final_module", "llvm module passes")
    timer.wrap(codegen.JITCodeLibrary, "_finalize_specific", "llvm codegen")


def digest(*arrays) -> str:
    hasher = hashlib.sha256()
    for array in arrays:
        hasher.update(np.ascontiguousarray(array).tobytes())
    return hasher.hexdigest()


def barbanis_states(n: int) -> np.ndarray:
    """compare.py's section of Barbanis 2 DoF (y = 0, p_y > 0) at E = 15, on an n x n grid."""
    x, px = (a.ravel() for a in np.meshgrid(np.linspace(-5.6, 5.6, n), np.linspace(-5.6, 5.6, n)))
    kinetic_y = 2.0 * (15.0 - 0.5 * x**2) - px**2
    keep = kinetic_y > 0.0
    return np.column_stack([x[keep], np.zeros(keep.sum()), px[keep], np.sqrt(kinetic_y[keep])])


def run_kind(kind: str, n: int, second: bool = False) -> tuple[float, float, str]:
    """(CPU s, wall s) of the first call of ``kind`` (the compile), and the hash of its results on
    the test grid; of Hénon–Heiles in place of Barbanis with ``second`` (a Hamiltonian kind)."""
    from ldpipe.engine import LDSettings, compute_ld
    from ldpipe.systems import make_system

    if kind == "vector-field":
        system = make_system("duffing_forced", DUFFING)
        x, y = (a.ravel() for a in np.meshgrid(np.linspace(-1.6, 1.6, n), np.linspace(-1.2, 1.2, n)))
        states = np.column_stack([x, y])
        variants = [LDSettings(scheme="dop853", tau=10.0),
                    LDSettings(scheme="dop853", tau=10.0, p=0.3, region_lower=(-1.0, -1.0), region_upper=(1.0, 1.0)),
                    LDSettings(scheme="dop853", tau=10.0, p="arclength")]

        def call(rows):
            results = [compute_ld(system, rows, +1, settings, t0=1.5) for settings in variants[:1 if len(rows) <= 8 else None]]
            return [array for r in results for array in (r.ld, r.time, r.end_state, r.steps, r.exit_face)]
    elif kind == "flow":
        from ldpipe.core.trajectories import FlowSettings, integrate

        system = make_system("barbanis_2dof", {"builtin": "barbanis_2dof"})
        states = barbanis_states(n)

        def call(rows):
            result = integrate(system, rows, 20.0, FlowSettings(), sample_times=np.linspace(0.0, 20.0, 5),
                               section=("y", 0.0, 1), max_crossings=4)
            return result.samples, result.crossings, result.crossing_times, result.status, result.steps
    else:
        system = make_system("barbanis_2dof", {"builtin": "barbanis_2dof"})
        if second:
            system = make_system("henon_heiles", HENON_HEILES)
        states = barbanis_states(n)
        step = {"dt": 0.05} if kind in ("rk4", "sym4", "sym6") else {}
        scheme = "taylor" if kind == "taylor" else kind
        if scheme == "taylor":  # the default settings' order and block for every variant: one module
            default = LDSettings(scheme=scheme, tau=20.0)
            step = {"taylor_order": default.order, "block": default.lanes}
        # the default LD settings (M_1/2), then the other integrand kinds and a region box (run-time arguments)
        variants = [LDSettings(scheme=scheme, tau=20.0, **step),
                    LDSettings(scheme=scheme, tau=20.0, p=0.3, region_lower=(-4.0, -3.0), region_upper=(4.0, 3.0), **step),
                    LDSettings(scheme=scheme, tau=20.0, p=1.0, **step),
                    LDSettings(scheme=scheme, tau=20.0, p="arclength", **step)]

        def call(rows):
            results = [compute_ld(system, rows, +1, settings) for settings in variants[:1 if len(rows) <= 8 else None]]
            return [array for r in results for array in (r.ld, r.time, r.end_state, r.steps, r.energy_error, r.exit_face)]

    wall, cpu = time.perf_counter(), time.thread_time()
    call(states[:8])
    cpu, wall = time.thread_time() - cpu, time.perf_counter() - wall
    return cpu, wall, digest(*call(states))  # (the first call compiled everything the others run)


def worker(kind: str, n: int, second: bool = False) -> None:
    """Compile ``kind`` in this process (the version first on sys.path); JSON on stdout."""
    import ldpipe

    timer = PhaseTimer()
    install(timer)
    cpu, wall, result_hash = run_kind(kind, n, second)
    from ldpipe.jitcache import GENERATED_PREFIX

    signatures = {}
    for name, module in list(sys.modules.items()):
        if name.startswith(GENERATED_PREFIX):
            for attribute, value in vars(module).items():
                overloads = getattr(value, "overloads", None)
                if overloads and getattr(value, "py_func", None) is not None and value.py_func.__module__ == name:
                    signatures[attribute] = [str(sig) for sig in overloads]
    json.dump({"ldpipe": ldpipe.__file__, "kind": kind, "cpu": cpu, "wall": wall, "hash": result_hash,
               "seconds": [[f, p, s] for (f, p), s in timer.seconds.items()], "signatures": signatures}, sys.stdout)


def run(source: Path, kind: str, n: int, second: bool = False) -> dict:
    """The worker's record of ``kind``; with ``second``, its ``second`` entry is the record of a
    second system's compile after it, on the same cache."""
    with tempfile.TemporaryDirectory(prefix="ldpipe-compile-") as cache:
        # one numba thread: the compile runs in the calling thread, where the phases are timed
        env = {**os.environ, "PYTHONPATH": str(source.resolve()), "LDPIPE_CACHE_DIR": cache, "NUMBA_NUM_THREADS": "1"}
        env.pop("LDPIPE_COMPILE_LOG", None)
        records = []
        for extra in ([], ["--second"])[:2 if second else 1]:
            done = subprocess.run([sys.executable, __file__, "--worker", kind, "--n", str(n), *extra], env=env,
                                  capture_output=True, text=True)
            if done.returncode:
                raise SystemExit(f"{source} {kind} {' '.join(extra)}: the worker failed\n{done.stderr}")
            records.append(json.loads(done.stdout))
    result = records[0]
    if second:
        result["second"] = records[1]
    if not Path(result["ldpipe"]).resolve().is_relative_to(source.resolve()):
        raise SystemExit(f"{source}: the worker imported ldpipe from {result['ldpipe']}")
    return result


def phases(result: dict) -> dict[str, float]:
    """CPU seconds by phase: the front end's passes together, lowering, and each LLVM phase."""
    totals = defaultdict(float)
    for _, phase, seconds in result["seconds"]:
        totals[phase if phase.startswith(("llvm", "lowering")) else "numba front end"] += seconds
    return totals


def print_profile(result: dict, top: int) -> None:
    per_function = defaultdict(lambda: defaultdict(float))
    for function, phase, seconds in result["seconds"]:
        group = "llvm" if phase.startswith("llvm") else ("lowering" if phase == "lowering" else "front end")
        per_function[function.split(".")[-1]][group] += seconds
    signatures = result["signatures"]
    print(f"\n{result['kind']}: {result['cpu']:.1f} CPU s; {len(signatures)} functions compiled, "
          f"{sum(map(len, signatures.values()))} signatures")
    print("| function | signatures | front end s | lowering s | LLVM s |")
    print("| --- | ---: | ---: | ---: | ---: |")
    ranked = sorted(per_function.items(), key=lambda item: -sum(item[1].values()))
    for function, groups in ranked[:top]:
        print(f"| {function} | {len(signatures.get(function, [])) or '-'} | {groups['front end']:.2f} | "
              f"{groups['lowering']:.2f} | {groups['llvm']:.2f} |")
    twice = {name: sigs for name, sigs in signatures.items() if len(sigs) > 1}
    for name, sigs in sorted(twice.items()):
        print(f"  {name}: {len(sigs)} signatures: " + " / ".join(sigs))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--old", type=Path, help="the src folder of the version to compare against")
    parser.add_argument("--new", type=Path, default=Path(__file__).resolve().parents[1] / "src")
    parser.add_argument("--kinds", nargs="+", choices=KINDS, default=["dop853"])
    parser.add_argument("--rounds", type=int, default=1)
    parser.add_argument("--n", type=int, default=20, help="test grid points per side for the results' hash")
    parser.add_argument("--functions", type=int, default=0, help="list the N costliest functions of each compile")
    parser.add_argument("--json", type=Path, help="write every run's record here")
    parser.add_argument("--second", action="store_true",
                        help="then time a second system of the same shape on the same cache (the LD kinds of Barbanis)")
    parser.add_argument("--worker", choices=KINDS, help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.worker:
        return worker(args.worker, args.n, args.second)
    versions = ("old", "new") if args.old else ("new",)
    print(f"load average before: {' '.join(f'{v:.2f}' for v in os.getloadavg())}, {os.cpu_count()} CPUs")
    runs = {(version, kind): [] for version in versions for kind in args.kinds}
    for round_ in range(args.rounds):
        for kind in args.kinds:
            for version in versions if round_ % 2 == 0 else versions[::-1]:
                second = args.second and kind not in ("flow", "vector-field")
                runs[version, kind].append(run(getattr(args, version), kind, args.n, second))
    print(f"load average after: {' '.join(f'{v:.2f}' for v in os.getloadavg())}")
    if args.json:
        args.json.write_text(json.dumps({f"{v} {k}": r for (v, k), r in runs.items()}))
    names = ["numba front end", "lowering", "llvm function passes", "llvm module passes", "llvm codegen", "other"]
    print(f"\ncompile CPU s (first call, empty cache), best of {args.rounds} round(s); phases of the best run")
    print("| kind | version | CPU s | runs | " + " | ".join(names) + " | results equal |")
    print("| --- | --- | ---: | --- | " + " | ".join("---:" for _ in names) + " | --- |")
    for kind in args.kinds:
        for version in versions:
            rows = runs[version, kind]
            best = min(rows, key=lambda row: row["cpu"])
            totals = phases(best)
            totals["other"] = best["cpu"] - sum(totals.values())  # imports, caching, Python outside the passes
            equal = ("yes" if all(r["hash"] == runs["old", kind][0]["hash"] for r in runs["new", kind]) else "NO") \
                if args.old else "-"
            print(f"| {kind} | {version} | {best['cpu']:.1f} | {', '.join(format(r['cpu'], '.1f') for r in rows)} | "
                  + " | ".join(f"{totals[name]:.1f}" for name in names) + f" | {equal} |")
    if args.second:
        print(f"\nthe second system's compile on the same cache, CPU s, best of {args.rounds} round(s)")
        print("| kind | version | first CPU s | second CPU s | runs (second) |")
        print("| --- | --- | ---: | ---: | --- |")
        for kind in [kind for kind in args.kinds if kind not in ("flow", "vector-field")]:
            for version in versions:
                rows = runs[version, kind]
                seconds = [row["second"]["cpu"] for row in rows]
                print(f"| {kind} | {version} | {min(row['cpu'] for row in rows):.1f} | {min(seconds):.1f} | "
                      + ", ".join(f"{v:.1f}" for v in seconds) + " |")
    if args.functions:
        for (version, kind), rows in runs.items():
            print(f"\n## {version}")
            print_profile(min(rows, key=lambda row: row["cpu"]), args.functions)


if __name__ == "__main__":
    main()
