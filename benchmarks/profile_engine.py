"""Where the engine's time goes: the block driver instrumented with the CPU's cycle counter.

The engine's generated module (``ldpipe.engine.codegen.engine_source``) is copied twice. The
timing copy has timers around each phase of ``process`` (lane refill, step attempt, fast
quadrature, special quadrature, events, the scalar per-lane pass) and around each part of
``special`` (SPECIAL_PARTS), and only the counters that sit outside its loops over items. The
counting copy adds the counters of the special path's cases and of why items go to the scalar
``component_integral`` (REASONS); they are taken from a run of their own because a counter
inside a loop over items stops LLVM from vectorizing it (measured: ``special`` 1.5x slower at
rtol 1e-4 and 1e-5 with them). Both copies are compiled without numba's disk cache into a
temporary directory; the library is not touched. Runs single-threaded so that the cycle counts
of one thread add up.

Run: ``.venv/bin/python benchmarks/profile_engine.py [--n 120] [--scheme dop853] [--rtol 1e-5 1e-10]``
"""

from __future__ import annotations

import argparse
import importlib.util
import re
import sys
import tempfile
import time
from pathlib import Path

import numba
import numpy as np


PHASES = ("refill", "set h", "attempt", "fast", "special", "events", "lane pass")
# the parts of "special", each timed from the end of the one before (the last: the scatter with
# the scalar fallbacks); they add up to "special"
SPECIAL_PARTS = (
    ("gather", "    n_nodes = glx.shape[0]\n    # Sign changes"),
    ("sign scan", "    # The case, the starting guess"),
    ("cases", "    if n_pair > 0:\n"),
    ("pair check", "    # Newton, kept inside"),
    ("Newton", "    # converged? |v(r)|"),
    ("converged?", "    # J(r -> 0) and J(r -> 1)"),
    ("Jacobi pieces", "    two_roots(W, CB"),
    ("two roots", "    one_dip(W, CB"),
    ("one dip", "    # scatter; the rest by the scalar path\n"),
    ("scatter, scalar", "window, roots)\n\n\n# ---- flag_checks ----"),
)
# counted in both copies (outside the loops over items), then in the counting copy only
COUNTERS = ("block iterations", "lane steps", "special items", "scalar fallbacks",
            "near-touch beside a root to scalar", "inside", "near left", "near right", "other case",
            "not converged", "one dip")
# why an item goes to the scalar path, counted where ``special`` decides it (see ``_count_reasons``)
# ("2 changes clean" and "1 change, root near an end": ``two_roots``'s cases, 0 once routed there
# but for a root near each end; "0 changes, dip": a possible near-touch with no root near either
# end is ``one_dip``'s case, 0 once routed there)
REASONS = ("zero sample", "2 changes clean", "2 changes, root near an end", "3+ changes",
           "1 change, root near an end", "0 changes, dip, no root near an end", "0 changes, dip (other)",
           "0 changes, other", "pair kept", "inside: Newton failed", "left/right: Newton failed",
           "left/right: no root (keep fast)", "two roots: to scalar", "one dip: to scalar")
# the timer array: PHASES, SPECIAL_PARTS, COUNTERS, REASONS
O_PARTS = len(PHASES)
O_COUNTERS = O_PARTS + len(SPECIAL_PARTS)
O_REASONS = O_COUNTERS + len(COUNTERS)
N_TIMERS = O_REASONS + len(REASONS)

CYCLES_SOURCE = '''
from llvmlite import ir
from numba.core import cgutils, types
from numba.extending import intrinsic


@intrinsic
def tick(typingctx):
    """The CPU's cycle counter (llvm.readcyclecounter)."""

    def codegen(context, builder, signature, args):
        fnty = ir.FunctionType(ir.IntType(64), [])
        fn = cgutils.get_or_insert_function(builder.module, fnty, "llvm.readcyclecounter")
        return builder.call(fn, [])

    return types.int64(), codegen
'''


def _replace(text: str, old: str, new: str, count: int = 1) -> str:
    if text.count(old) != count:
        raise RuntimeError(f"instrumentation: expected {count} occurrence(s) of {old!r}, found {text.count(old)}")
    return text.replace(old, new)


# "not converged": items whose Newton did not meet the test (a left/right one whose root does not
# exist keeps the fast value: "no root" of REASONS). It added R_OK before, so that each pair flag
# cleared by ``pair_check`` (no root to converge to) counted 2.


def instrumented_source(source: str, counting: bool) -> str:
    """``source`` with timers in ``process`` and ``special`` and the counters outside its loops
    over items; with ``counting`` also the counters inside them (see the module docstring)."""
    s = source.replace('"cache": True', '"cache": False')
    s = _replace(s, "from numba import njit\n", "from numba import njit\nfrom ldpipe_cycles import tick\n")
    # process gets the timer array as its last argument; special gets it too
    s = _replace(s, "o_ld, o_time, o_escaped, o_left, o_eerr, o_steps, o_failed, o_end, o_face,\n):",
                 "o_ld, o_time, o_escaped, o_left, o_eerr, o_steps, o_failed, o_end, o_face, PT,\n):")
    s = _replace(s, "def special(W, SP, kind, p, glx, glw, gjx, gjf, window, CB, ITEM, roots):\n",
                 "def special(W, SP, kind, p, glx, glw, gjx, gjf, window, CB, ITEM, roots, PT):\n    _ts = tick()\n")
    s = _replace(s, "special(W, SP, kind, p_exp, glx, glw, gjx, gjf, window, CB, ITEM, roots)",
                 "special(W, SP, kind, p_exp, glx, glw, gjx, gjf, window, CB, ITEM, roots, PT)")
    c = O_COUNTERS
    s = _replace(s, "    if m == 0:\n        return\n    for k in range(NC):\n",
                 f"    PT[{c + 2}] += m\n    if m == 0:\n        return\n    for k in range(NC):\n")
    s = _replace(s, "        elif ok == 0.0:\n", f"        elif ok == 0.0:\n            PT[{c + 3}] += 1\n")
    # near-touch checks beside a root that go on to the scalar path
    s = _replace(s, "]), window):\n                W[OFC + item] = component_integral(",
                 f"]), window):\n                PT[{c + 4}] += 1\n                W[OFC + item] = component_integral(")
    if counting:
        s = _replace(s, "        CB[R_OK * CBS + t] = ONE_DIP if alone else CB[R_OK * CBS + t]\n",
                     "        CB[R_OK * CBS + t] = ONE_DIP if alone else CB[R_OK * CBS + t]\n"
                     f"        PT[{c + 10}] += alone\n"
                     f"        PT[{c + 5}] += inside\n        PT[{c + 6}] += left\n        PT[{c + 7}] += right\n"
                     f"        PT[{c + 8}] += not (inside | left | right | at0 | at1)\n")
        s = _replace(s, "        keep = ok if good else (KEEP_FAST if (no_root & (ok != 0.0)) else 0.0)\n",
                     f"        PT[{c + 9}] += (ok == 1.0) & (~good)\n"
                     "        keep = ok if good else (KEEP_FAST if (no_root & (ok != 0.0)) else 0.0)\n")
        s = _count_reasons(s, O_REASONS)
    else:
        for i, (_, anchor) in enumerate(SPECIAL_PARTS):
            mark = f"    _tn = tick(); PT[{O_PARTS + i}] += _tn - _ts; _ts = _tn\n"
            if anchor.startswith("window, roots)"):  # the end of special
                s = _replace(s, anchor, anchor.replace("\n\n\n", "\n" + mark + "\n\n", 1))
            else:
                s = _replace(s, anchor, mark + anchor)
    # phases of the main loop
    s = _replace(s, "    while True:\n        for j in range(lanes):\n            # an idle lane",
                 "    while True:\n        _t = tick()\n        for j in range(lanes):\n            # an idle lane")
    s = _replace(s, "        n_active = 0\n        for j in range(lanes):\n            if active[j]:\n",
                 "        _u = tick(); PT[0] += _u - _t; _t = _u\n"
                 "        n_active = 0\n        for j in range(lanes):\n            if active[j]:\n")
    s = _replace(s, "        attempt(W, rtol, atol)\n",
                 f"        PT[{c}] += 1; PT[{c + 1}] += n_active\n"
                 "        _u = tick(); PT[1] += _u - _t; _t = _u\n"
                 "        attempt(W, rtol, atol)\n")
    s = _replace(s, "        fast(W, kind, p_exp, glx, glw, window, SP)\n",
                 "        _u = tick(); PT[2] += _u - _t; _t = _u\n"
                 "        fast(W, kind, p_exp, glx, glw, window, SP)\n"
                 "        _u = tick(); PT[3] += _u - _t; _t = _u\n")
    s = _replace(s, "        any_escape = flag_escapes(qn, radius, esc_flag)\n",
                 "        _u = tick(); PT[4] += _u - _t; _t = _u\n"
                 "        any_escape = flag_escapes(qn, radius, esc_flag)\n")
    s = _replace(s, "\n        for j in range(lanes):\n            if not active[j]:\n                continue\n",
                 "\n        _u = tick(); PT[5] += _u - _t; _t = _u\n"
                 "        for j in range(lanes):\n            if not active[j]:\n                continue\n")
    s = _replace(s, "                o_face[k] = face\n                active[j] = False\n",
                 "                o_face[k] = face\n                active[j] = False\n"
                 "        PT[6] += tick() - _t\n")
    return s


def _count_reasons(s: str, r: int) -> str:
    """Counters of REASONS (from PT[r] on) in ``special``: the case of each item left to the scalar
    path by the case section, the pair flags ``pair_check`` keeps, and Newton's failures."""
    s = _replace(s, "        n_pair += 1 if pair else 0\n",
                 "        n_pair += 1 if pair else 0\n"
                 "        _scalar = CB[R_OK * CBS + t] == 0.0\n"
                 "        _ends = near_left | near_right | zero0 | zero1\n"
                 f"        PT[{r}] += _scalar & (nsc >= 10.0)\n"
                 f"        PT[{r + 1}] += _scalar & (nsc == 2.0) & (~_ends)\n"
                 f"        PT[{r + 2}] += _scalar & (nsc == 2.0) & _ends\n"
                 f"        PT[{r + 3}] += _scalar & (nsc >= 3.0) & (nsc < 10.0)\n"
                 f"        PT[{r + 4}] += _scalar & (nsc == 1.0)\n"
                 f"        PT[{r + 5}] += _scalar & (nsc == 0.0) & dip & alone\n"
                 f"        PT[{r + 6}] += _scalar & (nsc == 0.0) & dip & (~alone)\n"
                 f"        PT[{r + 7}] += _scalar & (nsc == 0.0) & (~dip)\n")
    s = _replace(s, "        pair_check(CB, m, glx)\n",
                 "        _n0 = 0\n        for t in range(m):\n            _n0 += CB[R_OK * CBS + t] == 0.0\n"
                 "        pair_check(CB, m, glx)\n"
                 f"        for t in range(m):\n            PT[{r + 8}] += CB[R_OK * CBS + t] == 0.0\n"
                 f"        PT[{r + 8}] -= _n0\n")
    s = _replace(s, "        keep = ok if good else (KEEP_FAST if (no_root & (ok != 0.0)) else 0.0)\n",
                 "        keep = ok if good else (KEEP_FAST if (no_root & (ok != 0.0)) else 0.0)\n"
                 "        _failed = (ok == 1.0) & (~good)\n"
                 "        _inside = CB[R_FA * CBS + t] != 0.0\n"
                 f"        PT[{r + 9}] += _failed & _inside\n"
                 f"        PT[{r + 10}] += _failed & (~_inside) & (~no_root)\n"
                 f"        PT[{r + 11}] += _failed & (~_inside) & no_root\n")
    s = _replace(s, "    two_roots(W, CB, ITEM, m, kind, p, glx, glw, gjx, gjf)",
                 "    _n0 = 0\n    for t in range(m):\n        _n0 += CB[R_OK * CBS + t] == 0.0\n"
                 "    two_roots(W, CB, ITEM, m, kind, p, glx, glw, gjx, gjf)\n"
                 f"    for t in range(m):\n        PT[{r + 12}] += CB[R_OK * CBS + t] == 0.0\n"
                 f"    PT[{r + 12}] -= _n0\n   ")
    s = _replace(s, "    one_dip(W, CB, ITEM, m, kind, p, glx, glw, window)",
                 "    _n0 = 0\n    for t in range(m):\n        _n0 += CB[R_OK * CBS + t] == 0.0\n"
                 "    one_dip(W, CB, ITEM, m, kind, p, glx, glw, window)\n"
                 f"    for t in range(m):\n        PT[{r + 13}] += CB[R_OK * CBS + t] == 0.0\n"
                 f"    PT[{r + 13}] -= _n0\n   ")
    return s


def load_instrumented(system, scheme: str, lanes: int, directory: Path, order: int | None = None,
                      counting: bool = False):
    from ldpipe.engine.codegen import engine_source

    (directory / "ldpipe_cycles.py").write_text(CYCLES_SOURCE)
    if str(directory) not in sys.path:
        sys.path.insert(0, str(directory))
    source = instrumented_source(engine_source(system, scheme, lanes, order), counting)
    kind = "counted" if counting else "timed"
    name = f"{kind}_" + re.sub(r"\W", "_", f"{system.name}_{scheme}{order or ''}_{lanes}")
    path = directory / f"{name}.py"
    path.write_text(source)
    spec = importlib.util.spec_from_file_location(name, path)
    module = importlib.util.module_from_spec(spec)
    sys.modules[name] = module
    spec.loader.exec_module(module)
    return module.process


def profile(process, system, states, settings) -> tuple[np.ndarray, float]:
    """Run the instrumented ``process`` over ``states`` in one unit; (timers, wall seconds)."""
    from ldpipe.engine import api

    captured = {}

    def fake_run_units(_runner, st, _unit, args, outputs, _threads):
        captured["args"] = (st, args, outputs)

    real = api.run_units
    api.run_units = fake_run_units
    real_get = api.get_runner
    api.get_runner = lambda *a, **k: None
    try:
        api.compute_ld(system, states, +1, settings)
    finally:
        api.run_units = real
        api.get_runner = real_get
    st, args, outputs = captured["args"]
    timers = np.zeros(N_TIMERS)
    start = time.perf_counter()
    process(st, 0, st.shape[0], *args, *outputs, timers)
    return timers, time.perf_counter() - start


def main() -> None:
    from ldpipe.testing import reference_ld as ref
    from ldpipe.engine import LDSettings
    from ldpipe.systems import make_system

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--n", type=int, default=120, help="grid side on U_xpx, x and p_x in [-5.6, 5.6]")
    parser.add_argument("--scheme", default="dop853")
    parser.add_argument("--rtol", type=float, nargs="*", default=[1e-5, 1e-10])
    parser.add_argument("--p", default="0.5", help="0.5 or arclength")
    parser.add_argument("--quad-nodes", type=int, default=None)
    parser.add_argument("--block", type=int, default=64)
    parser.add_argument("--window", type=float, default=None)
    parser.add_argument("--taylor-order", type=int, default=None, help="taylor scheme: order (default from rtol)")
    args = parser.parse_args()
    numba.set_num_threads(1)
    system = make_system("barbanis_2dof", {"builtin": "barbanis_2dof"})
    x, px = np.meshgrid(np.linspace(-5.6, 5.6, args.n), np.linspace(-5.6, 5.6, args.n), indexing="ij")
    states, allowed = ref.section_state(x.ravel(), px.ravel(), ref.E_SADDLE - 0.125)
    states = np.ascontiguousarray(states[allowed])
    p = args.p if args.p == "arclength" else float(args.p)
    with tempfile.TemporaryDirectory() as tmp:
        start = time.perf_counter()
        for rtol in args.rtol:
            settings = LDSettings(scheme=args.scheme, rtol=rtol, atol=rtol, p=p, quad_nodes=args.quad_nodes,
                                  block=args.block, taylor_order=args.taylor_order,
                                  **({} if args.window is None else {"window": args.window}))
            runs = {}
            for counting in (False, True):
                process = load_instrumented(system, args.scheme, args.block, Path(tmp), settings.order, counting)
                profile(process, system, states[:16], settings)  # compile
                runs[counting] = profile(process, system, states, settings)
            if start is not None:
                print(f"compiled and run in {time.perf_counter() - start:.1f} s; {len(states)} trajectories, "
                      f"tau 50, p {p}")
                start = None
            timers, wall = runs[False]
            counted = runs[True][0]
            cycles = timers[:O_PARTS]
            total = cycles.sum()
            counts = dict(zip(COUNTERS, counted[O_COUNTERS:O_REASONS]))
            reasons = dict(zip(REASONS, counted[O_REASONS:]))
            lane_steps = counts["lane steps"]
            if timers[O_COUNTERS + 1] != lane_steps:
                raise RuntimeError("the timing and the counting copies took different steps")
            order = "" if settings.order is None else f" order {settings.order}"
            print(f"\n{args.scheme}{order} rtol {rtol:g}: wall {wall:.2f} s, {50.0 * len(states) / wall:.3g} time units/s "
                  f"(1 thread), {lane_steps / len(states):.0f} steps per trajectory, "
                  f"lane occupancy {lane_steps / (counts['block iterations'] * args.block):.2f}, "
                  f"{total / lane_steps:.0f} cycles per lane step")
            for name, c in zip(PHASES, cycles):
                print(f"  {name:>10}: {c / total:6.1%}  {c / lane_steps:7.1f} cycles/lane step")
                if name == "special":
                    for (part, _), c in zip(SPECIAL_PARTS, timers[O_PARTS:O_COUNTERS]):
                        print(f"    {part:>16}: {c / total:6.1%}  {c / lane_steps:7.1f}")
            print("  per lane step: " + ", ".join(f"{k} {v / lane_steps:.3f}" for k, v in counts.items()
                                                    if k not in ("block iterations", "lane steps")))
            print("  to the scalar path, per 1000 lane steps: "
                  + ", ".join(f"{k} {1000.0 * v / lane_steps:.1f}" for k, v in reasons.items()))

if __name__ == "__main__":
    main()
