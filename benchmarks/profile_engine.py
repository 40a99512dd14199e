"""Where the engine's time goes: the block driver instrumented with the CPU's cycle counter.

The engine's generated module, as one module (``ldpipe.engine.codegen.engine_modules(...).inlined``:
the common modules' templates pasted in place of their imports), is copied twice. The
timing copy has timers around each phase of ``process`` (lane refill, step attempt, fast
quadrature, special quadrature, events, the scalar per-lane pass) and around each part of
``special`` (SPECIAL_PARTS), and only the counters that sit outside its loops over items. The
counting copy adds the counters of the special path's cases and of why items go to the scalar
``component_integral`` (REASONS); they are taken from a run of their own because a counter
inside a loop over items stops LLVM from vectorizing it (measured: ``special`` 1.5x slower at
rtol 1e-4 and 1e-5 with them). Both copies are compiled without numba's disk cache into a
temporary directory; the library is not touched. Runs single-threaded so that the cycle counts
of one thread add up.

The probes are placed by the code they sit next to, found with :mod:`ast` in the generated
text (a call such as ``fast(...)``, an assignment to a name, a loop over a range), never by
comments or whitespace: the templates carry no markers, and editing their comments moves no
probe. An anchor that is missing or not unique stops the run with a message naming it (see
PROCESS_PHASES and SPECIAL_PARTS).

Run: ``.venv/bin/python benchmarks/profile_engine.py [--n 120] [--scheme dop853] [--rtol 1e-5 1e-10]``
"""

from __future__ import annotations

import argparse
import ast
import importlib.util
import re
import sys
import tempfile
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numba
import numpy as np


# A statement found by the code it holds: ``match`` is a test of an ast node, ``what`` says it in
# words for the error message.
@dataclass(frozen=True)
class Anchor:
    what: str
    match: Callable[[ast.AST], bool]


def calls(name: str) -> Anchor:
    return Anchor(f"a call to `{name}(`",
                  lambda n: isinstance(n, ast.Call) and isinstance(n.func, ast.Name) and n.func.id == name)


def call_statement(name: str) -> Anchor:
    """A statement that is a call to ``name`` and nothing else."""
    return Anchor(f"a statement `{name}(...)`",
                  lambda n: isinstance(n, ast.Expr) and calls(name).match(n.value))


def assigns(name: str) -> Anchor:
    def match(n):
        if isinstance(n, ast.Assign):
            targets = n.targets
        elif isinstance(n, (ast.AugAssign, ast.AnnAssign)):
            targets = [n.target]
        else:
            return False
        return any(isinstance(t, ast.Name) and t.id == name for target in targets for t in ast.walk(target))

    return Anchor(f"an assignment to `{name}`", match)


def adds_to(name: str) -> Anchor:
    return Anchor(f"`{name} += ...`", lambda n: isinstance(n, ast.AugAssign) and isinstance(n.target, ast.Name)
                  and n.target.id == name)


def loops_over(name: str) -> Anchor:
    return Anchor(f"a `for` loop whose range uses `{name}`",
                  lambda n: isinstance(n, ast.For) and any(isinstance(t, ast.Name) and t.id == name
                                                           for t in ast.walk(n.iter)))


def if_test(condition: str) -> Anchor:
    """An ``if`` (or ``elif``) whose condition is ``condition`` (compared as ``ast.unparse`` writes it)."""
    return Anchor(f"an `if {condition}:`", lambda n: isinstance(n, ast.If) and ast.unparse(n.test) == condition)


def if_calls(name: str) -> Anchor:
    return Anchor(f"an `if` whose condition calls `{name}(`",
                  lambda n: isinstance(n, ast.If) and any(calls(name).match(t) for t in ast.walk(n.test)))


# The phases of ``process``, in the statements of its main loop (the ``while`` around the call to
# ``attempt``): each phase ends before or after the statement of that loop holding its anchor
# (None: the loop's last statement), and the next begins there; the first begins with the loop's
# body. The anchors are calls, so that the driver's own statements (refill, step control) may
# move; a call that is renamed or moved out of the loop stops the run, naming it.
PROCESS_PHASES = (
    ("refill", "after", calls("load_lane")),
    ("set h", "before", calls("attempt")),
    ("attempt", "before", calls("fast")),
    ("fast", "after", calls("fast")),
    ("special", "after", calls("special")),
    ("events", "before", calls("first_exit")),
    ("lane pass", "after", None),
)
PHASES = tuple(name for name, _, _ in PROCESS_PHASES)
# the parts of "special", each timed from the end of the one before (the last: the scatter with
# the scalar fallbacks) to the statement of special's body holding its anchor; they add up to
# "special"
SPECIAL_PARTS = (
    ("gather", assigns("n_nodes")),
    ("sign scan", assigns("dip_width")),
    ("cases", calls("pair_check")),
    ("pair check", loops_over("N_NEWTON")),
    ("Newton", assigns("good")),
    ("converged?", loops_over("gjx")),
    ("Jacobi pieces", calls("two_roots")),
    ("two roots", calls("one_dip")),
    ("one dip", assigns("VC")),
    ("scatter, scalar", None),  # to the end of special
)
# counted in both copies (outside the loops over items), then in the counting copy only.
# "lane steps": the lanes with a step (h != 0, the workspace's idle-lane rule) at each attempt;
# "not converged": items whose Newton did not meet the test (a left/right one whose root does
# not exist keeps the fast value: "no root" of REASONS).
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


class InstrumentationError(RuntimeError):
    """An anchor of the instrumentation is missing from the generated code, or not unique."""


class Probes:
    """Lines of code put into a source text at places found in its ast; applied all at once.

    Every place is taken from the tree of the text as it was given, so the order in which
    probes are added does not move the others; probes at the same place keep the order they
    were added in.
    """

    def __init__(self, source: str):
        self.lines = source.splitlines(keepends=True)
        self.tree = ast.parse(source)
        self.inserts: list[tuple[int, int, str]] = []  # (line index, order, text)
        self.columns: list[tuple[int, int, str]] = []  # (line index, byte column, text)

    def function(self, name: str) -> ast.FunctionDef:
        found = [n for n in self.tree.body if isinstance(n, ast.FunctionDef) and n.name == name]
        if len(found) != 1:
            raise InstrumentationError(f"instrumentation: expected one module-level `def {name}` in the generated "
                                       f"engine, found {len(found)}")
        return found[0]

    @staticmethod
    def statement(function: ast.FunctionDef, anchor: Anchor) -> ast.stmt:
        """The one statement, at any depth of ``function``, that ``anchor`` matches."""
        found = [n for n in ast.walk(function) if isinstance(n, ast.stmt) and anchor.match(n)]
        if len(found) != 1:
            raise InstrumentationError(f"instrumentation: expected {anchor.what} exactly once in `{function.name}`, "
                                       f"found {len(found)}; update the anchors in benchmarks/profile_engine.py")
        return found[0]

    @staticmethod
    def holder(body: list[ast.stmt], anchor: Anchor, where: str) -> ast.stmt:
        """The one statement of ``body`` that holds a node ``anchor`` matches."""
        found = [s for s in body if any(anchor.match(n) for n in ast.walk(s))]
        if len(found) != 1:
            raise InstrumentationError(f"instrumentation: expected one statement holding {anchor.what} in {where}, "
                                       f"found {len(found)}; update the anchors in benchmarks/profile_engine.py")
        return found[0]

    def _add(self, index: int, indent: int, code: str) -> None:
        text = "".join(" " * indent + line + "\n" for line in code.strip("\n").splitlines())
        self.inserts.append((index, len(self.inserts), text))

    def before(self, node: ast.stmt, code: str) -> None:
        self._add(node.lineno - 1, node.col_offset, code)

    def after(self, node: ast.stmt, code: str) -> None:
        self._add(node.end_lineno, node.col_offset, code)

    def first_in(self, body: list[ast.stmt], code: str) -> None:
        """Before the first statement of ``body`` (after a docstring)."""
        first = body[0]
        docstring = isinstance(first, ast.Expr) and isinstance(first.value, ast.Constant) and len(body) > 1
        self.before(body[1] if docstring else first, code)

    def append_argument(self, last: ast.AST, name: str) -> None:
        """``, name`` right after the last argument ``last`` of a call or a ``def``."""
        self.columns.append((last.end_lineno - 1, last.end_col_offset, f", {name}"))

    def apply(self) -> str:
        lines = list(self.lines)
        for index, column, text in sorted(self.columns, reverse=True):
            raw = lines[index].encode()  # ast's columns count UTF-8 bytes
            lines[index] = (raw[:column] + text.encode() + raw[column:]).decode()
        out = []
        pending = sorted(self.inserts)
        k = 0
        for index, line in enumerate(lines + [""]):
            while k < len(pending) and pending[k][0] == index:
                out.append(pending[k][2])
                k += 1
            out.append(line)
        return "".join(out)


def _mark(timer: int, start: str, end: str) -> str:
    """Add the cycles since ``start`` to PT[timer]; the next interval starts now (``end``)."""
    return f"{end} = tick()\nPT[{timer}] += {end} - {start}\n{start} = {end}"


def instrumented_source(source: str, counting: bool) -> str:
    """``source`` with timers in ``process`` and ``special`` and the counters outside its loops
    over items; with ``counting`` also the counters inside them (see the module docstring)."""
    probes = Probes(source)
    # the copies are compiled apart from numba's cache; tick is the cycle counter (CYCLES_SOURCE)
    jit = [n for n in probes.tree.body if assigns("JIT").match(n)]
    if len(jit) != 1:
        raise InstrumentationError(f"instrumentation: expected one module-level `JIT = ...`, found {len(jit)}")
    probes.after(jit[0], 'JIT = {**JIT, "cache": False}\nfrom ldpipe_cycles import tick')
    _instrument_process(probes)
    special = probes.function("special")
    # special takes the timer array PT as its last argument, and starts its clock
    probes.append_argument(special.args.args[-1], "PT")
    probes.first_in(special.body, "_ts = tick()")
    c = O_COUNTERS
    probes.before(probes.statement(special, if_test("m == 0")), f"PT[{c + 2}] += m")
    probes.first_in(probes.statement(special, if_test("ok == 0.0")).body, f"PT[{c + 3}] += 1")
    # near-touch checks beside a root that go on to the scalar path
    probes.first_in(probes.statement(special, if_calls("touch_matters")).body, f"PT[{c + 4}] += 1")
    if counting:
        probes.after(probes.statement(special, assigns("alone")),
                     f"PT[{c + 10}] += alone\nPT[{c + 5}] += inside\nPT[{c + 6}] += left\nPT[{c + 7}] += right\n"
                     f"PT[{c + 8}] += not (inside | left | right | at0 | at1)")
        probes.before(probes.statement(special, assigns("keep")), f"PT[{c + 9}] += (ok == 1.0) & (~good)")
        _count_reasons(probes, special, O_REASONS)
    else:
        for i, (name, anchor) in enumerate(SPECIAL_PARTS):
            mark = _mark(O_PARTS + i, "_ts", "_tn")
            if anchor is None:
                probes.after(special.body[-1], mark)
            else:
                probes.before(probes.holder(special.body, anchor, f"the body of `special` (part {name!r})"), mark)
    return probes.apply()


def _instrument_process(probes: Probes) -> None:
    """Timers of PROCESS_PHASES in ``process``'s main loop, the counters of block iterations and
    lane steps before the step attempt, and PT as ``process``'s and ``special``'s last argument."""
    process = probes.function("process")
    probes.append_argument(process.args.args[-1], "PT")
    probes.append_argument(_one_call(process, "special").args[-1], "PT")
    attempt = _one_call(process, "attempt")
    loops = [n for n in ast.walk(process) if isinstance(n, ast.While) and any(m is attempt for m in ast.walk(n))]
    if len(loops) != 1:
        raise InstrumentationError(f"instrumentation: expected one `while` loop around the call to `attempt(` in "
                                   f"`process`, found {len(loops)}")
    body = loops[0].body
    where = "the main loop of `process`"
    probes.first_in(body, "_t = tick()")
    # the lanes a step attempt advances: h != 0 in the workspace (the first argument of attempt)
    workspace = ast.unparse(attempt.args[0])
    counters = (f"PT[{O_COUNTERS}] += 1\nfor _j in range(LANES):\n"
                f"    PT[{O_COUNTERS + 1}] += {workspace}[OH + _j] != 0.0")
    previous = -1
    for i, (name, side, anchor) in enumerate(PROCESS_PHASES):
        statement = body[-1] if anchor is None else probes.holder(body, anchor, f"{where} (phase {name!r})")
        position = body.index(statement) + (0.5 if side == "after" else 0.0)
        if position < previous:
            raise InstrumentationError(f"instrumentation: phase {name!r} of `process` ends before the phase before "
                                       "it; the order of PROCESS_PHASES no longer matches the driver")
        previous = position
        # (the last phase closes the turn of the loop: the next starts the clock again)
        mark = f"PT[{i}] += tick() - _t" if i == len(PROCESS_PHASES) - 1 else _mark(i, "_t", "_u")
        code = f"{counters}\n{mark}" if name == "set h" else mark
        (probes.after if side == "after" else probes.before)(statement, code)


def _one_call(function: ast.FunctionDef, name: str) -> ast.Call:
    found = [n for n in ast.walk(function) if calls(name).match(n)]
    if len(found) != 1:
        raise InstrumentationError(f"instrumentation: expected one call to `{name}(` in `{function.name}`, "
                                   f"found {len(found)}")
    return found[0]


def _count_reasons(probes: Probes, special: ast.FunctionDef, r: int) -> None:
    """Counters of REASONS (from PT[r] on) in ``special``: the case of each item left to the scalar
    path by the case section, the pair flags ``pair_check`` keeps, and Newton's failures."""
    probes.after(probes.statement(special, adds_to("n_pair")),
                 "_scalar = CB[R_OK * CBS + t] == 0.0\n"
                 "_ends = near_left | near_right | zero0 | zero1\n"
                 f"PT[{r}] += _scalar & (nsc >= 10.0)\n"
                 f"PT[{r + 1}] += _scalar & (nsc == 2.0) & (~_ends)\n"
                 f"PT[{r + 2}] += _scalar & (nsc == 2.0) & _ends\n"
                 f"PT[{r + 3}] += _scalar & (nsc >= 3.0) & (nsc < 10.0)\n"
                 f"PT[{r + 4}] += _scalar & (nsc == 1.0)\n"
                 f"PT[{r + 5}] += _scalar & (nsc == 0.0) & dip & alone\n"
                 f"PT[{r + 6}] += _scalar & (nsc == 0.0) & dip & (~alone)\n"
                 f"PT[{r + 7}] += _scalar & (nsc == 0.0) & (~dip)")
    probes.after(probes.statement(special, assigns("keep")),
                 "_failed = (ok == 1.0) & (~good)\n"
                 "_inside = CB[R_FA * CBS + t] != 0.0\n"
                 f"PT[{r + 9}] += _failed & _inside\n"
                 f"PT[{r + 10}] += _failed & (~_inside) & (~no_root)\n"
                 f"PT[{r + 11}] += _failed & (~_inside) & no_root")
    # the items a check or a rule sends to the scalar path: R_OK 0 after it, not before
    for timer, name in ((r + 8, "pair_check"), (r + 12, "two_roots"), (r + 13, "one_dip")):
        statement = probes.statement(special, call_statement(name))
        probes.before(statement, "_n0 = 0\nfor _k in range(m):\n    _n0 += CB[R_OK * CBS + _k] == 0.0")
        probes.after(statement, f"for _k in range(m):\n    PT[{timer}] += CB[R_OK * CBS + _k] == 0.0\n"
                                f"PT[{timer}] -= _n0")


def load_instrumented(system, scheme: str, lanes: int, directory: Path, order: int | None = None,
                      counting: bool = False):
    from ldpipe.engine.codegen import engine_modules

    (directory / "ldpipe_cycles.py").write_text(CYCLES_SOURCE)
    if str(directory) not in sys.path:
        sys.path.insert(0, str(directory))
    source = instrumented_source(engine_modules(system, scheme, lanes, order).inlined, counting)
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
