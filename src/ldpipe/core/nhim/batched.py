"""Many slices at once: each slice's search as a task that asks for trajectories, answered in batches.

Refining one NHIM point is a chain of small, dependent integrations (each bisection step waits for
the last), so one slice at a time leaves the engine waiting on a few trajectories per call: its
cost is the latency of the longest trajectory, ~200 calls a point. Written as a generator (a
*task*) that yields its requests -- ``("fates", direction, points)``, ``("ld", points)``,
``("residence", points)`` -- a slice's search runs unchanged alongside hundreds of others:
:func:`run_tasks` gathers the pending requests of every task, answers each kind with one engine
call over all their points, and resumes the tasks with their share.

:func:`bisect_task` is the bisection of fate switches as such a task (each segment in its own
direction of time); :func:`bisect_fate_switch` runs it alone. The refinement of a point
(:func:`ldpipe.core.nhim.refinement.refine_by_fates_task`) is built on it, and
:func:`ldpipe.core.nhim.refine_by_fates` runs that alone: one algorithm, batched or not.
"""

from __future__ import annotations

from collections.abc import Generator
from dataclasses import replace

import numpy as np

from ...engine import compute_ld
from ..sections import solve_momentum
from .fates import Cost, RefinementFailed, RefinementSettings, clip_to_allowed, fate_settings
from .slices import SliceProblem

#: A task: yields requests, receives their answers, returns its result.
Task = Generator


def _states(problems: list[SliceProblem], points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """:func:`ldpipe.core.nhim.section_point_states` of rows of many slices of one family at once (one
    potential call): row k is ``points[k]`` on ``problems[k]``."""
    first = problems[0]
    system, section = first.system, first.section
    phase = system.phase_coordinates
    n = system.n_dof
    states = np.zeros((len(points), 2 * n))
    states[:, phase.index(section.axes[0])] = points[:, 0]
    states[:, phase.index(section.axes[1])] = points[:, 1]
    for name in section.fixed:
        states[:, phase.index(name)] = [p.section.fixed[name] for p in problems]
    signs = np.array([p.section.sign for p in problems], dtype=np.float64)
    # the one solver of a section's momentum (kinetic matrix included), each row with its slice's sign
    allowed, solved = solve_momentum(system, states, phase.index(section.solve) - n, first.energy, signs)
    states[allowed, phase.index(section.solve)] = solved[allowed]
    return states, allowed


def _reverse(states: np.ndarray, directions: np.ndarray, n: int) -> np.ndarray:
    """States whose forward flow is the given direction's: H(q, p) = |p|^2/2 + V(q) is reversible,
    so the trajectory backward in time from (q, p) has the positions of the one forward from
    (q, -p) (same exit, side and exit time; the same LD, |dq/dt| and |dp/dt| being equal). One
    forward engine call then serves both directions."""
    states = states.copy()
    states[directions < 0, n:] *= -1.0
    return states


def _answer(kind: str, problems: list[SliceProblem], points: np.ndarray, directions: np.ndarray,
            refinement: RefinementSettings, cost: Cost) -> dict[str, np.ndarray]:
    """One engine call for every row of one kind of request."""
    base = problems[0]
    n = base.system.n_dof
    states, allowed = _states(problems, points)
    if kind == "fates":
        fate = np.zeros(len(states), dtype=np.int64)
        exit_time = np.full(len(states), refinement.max_time)
        run_time, steps = np.zeros(len(states)), np.zeros(len(states), dtype=np.int64)
        if allowed.any():
            start = _reverse(states[allowed], directions[allowed], n)
            result = compute_ld(base.system, start, +1, fate_settings(base, refinement))
            left = (result.left_region | result.escaped) & ~result.failed
            side = np.sign((result.end_state[:, :n] - base.saddle) @ base.reaction).astype(np.int64)
            fate[allowed] = np.where(left, side, 0)
            exit_time[allowed] = np.where(left, result.time, refinement.max_time)
            run_time[allowed], steps[allowed] = result.time, result.steps
            cost.add(int(allowed.sum()), float(result.time.sum()), int(result.steps.sum()))
        return {"fate": fate, "exit_time": exit_time, "allowed": allowed, "time": run_time, "steps": steps}
    # "ld": the map's LD settings; "residence": DOP853 at the refinement's tolerances to max_time.
    settings = base.ld_settings
    if kind == "residence":
        settings = replace(settings, scheme="dop853", rtol=refinement.rtol, atol=refinement.atol,
                           tau=refinement.max_time)
    out = {name: np.zeros(len(states)) for name in ("ld_forward", "ld_backward", "exit_time_forward",
                                                     "exit_time_backward")}
    out.update(allowed=allowed, steps_forward=np.zeros(len(states), dtype=np.int64),
               steps_backward=np.zeros(len(states), dtype=np.int64))
    if allowed.any():
        k = int(allowed.sum())
        both = np.vstack([states[allowed], _reverse(states[allowed], -np.ones(k), n)])
        result = compute_ld(base.system, both, +1, settings)
        for suffix, part in (("forward", slice(0, k)), ("backward", slice(k, 2 * k))):
            out[f"ld_{suffix}"][allowed] = result.ld[part]
            out[f"exit_time_{suffix}"][allowed] = result.time[part]
            out[f"steps_{suffix}"][allowed] = result.steps[part]
        cost.add(2 * k, float(result.time.sum()), int(result.steps.sum()))
    return out


def run_tasks(tasks: list[Task], refinement: RefinementSettings, cost: Cost | None = None) -> list:
    """Run tasks of slices of one family together; returns each task's result, in order.

    A task yields ``(problem, kind, points, directions)``: ``kind`` one of ``"fates"``, ``"ld"``,
    ``"residence"``; ``points`` shape (k, 2) on ``problem``'s slice; ``directions`` shape (k,), +1 or
    -1, the direction of time of each fate (ignored otherwise: both directions are computed). It
    receives a dict of arrays of shape (k,): ``fate``, ``exit_time``, ``allowed``, and the trajectories'
    integration ``time`` and ``steps`` (0 where not allowed) for fates;
    ``ld_forward``, ``ld_backward``, ``exit_time_forward``, ``exit_time_backward``, ``steps_forward``,
    ``steps_backward`` and ``allowed`` otherwise. Each round answers every pending request, one engine call per kind.
    """
    cost = Cost() if cost is None else cost
    results: list = [None] * len(tasks)
    pending: dict[int, tuple] = {}

    def advance(i: int, answer) -> None:
        try:
            pending[i] = tasks[i].send(answer)
        except StopIteration as stop:
            results[i] = stop.value
            pending.pop(i, None)

    for i in range(len(tasks)):
        advance(i, None)
    while pending:
        by_kind: dict[str, list[int]] = {}
        for i, (_, kind, _, _) in pending.items():
            by_kind.setdefault(kind, []).append(i)
        answers = {}
        for kind, indices in by_kind.items():
            sizes = [len(pending[i][2]) for i in indices]
            problems = [pending[i][0] for i, size in zip(indices, sizes) for _ in range(size)]
            points = np.vstack([np.reshape(pending[i][2], (-1, 2)) for i in indices])
            directions = np.concatenate([np.broadcast_to(pending[i][3], (size,)) for i, size in zip(indices, sizes)])
            answer = _answer(kind, problems, points, directions, refinement, cost)
            bounds = np.cumsum([0, *sizes])
            for i, lo, hi in zip(indices, bounds[:-1], bounds[1:]):
                answers[i] = {name: values[lo:hi] for name, values in answer.items()}
        for i, answer in answers.items():
            advance(i, answer)
    return results


def charging(task: Task, cost: Cost) -> Task:
    """``task`` unchanged, charging ``cost`` with the trajectories of its own requests as
    :func:`run_tasks` charges a batch's (so a task run among others is costed as if run alone:
    the same counts, and its own rows' times and steps summed in the same order)."""
    answer = None
    while True:
        try:
            request = task.send(answer)
        except StopIteration as stop:
            return stop.value
        answer = yield request
        allowed = answer["allowed"]
        if not allowed.any():
            continue
        if request[1] == "fates":
            cost.add(int(allowed.sum()), float(answer["time"][allowed].sum()), int(answer["steps"][allowed].sum()))
        else:
            both = np.concatenate([answer["exit_time_forward"][allowed], answer["exit_time_backward"][allowed]])
            steps = int(answer["steps_forward"][allowed].sum()) + int(answer["steps_backward"][allowed].sum())
            cost.add(2 * int(allowed.sum()), float(both.sum()), steps)


def bisect_task(problem: SliceProblem, starts: np.ndarray, ends: np.ndarray, directions: np.ndarray,
                settings: RefinementSettings):
    """:func:`ldpipe.core.nhim.bisect_fate_switch` as a task, each segment in its own direction of time
    (so the forward and backward curves are bisected in the same rounds): returns (points, widths)."""
    directions = np.asarray(directions)
    lo = clip_to_allowed(problem, np.array(starts, dtype=np.float64), np.array(ends, dtype=np.float64))
    hi = clip_to_allowed(problem, np.array(ends, dtype=np.float64), np.array(starts, dtype=np.float64))
    fates = (yield problem, "fates", np.vstack([lo, hi]), np.concatenate([directions, directions]))["fate"]
    f_lo, f_hi = fates[: len(lo)], fates[len(lo):]
    bad = (f_lo * f_hi) != -1
    if bad.any():
        names = sorted({"forward" if d > 0 else "backward" for d in directions[bad]})
        raise RefinementFailed(
            f"map {problem.name}: {int(bad.sum())} of {len(lo)} segments do not bracket a switch of the "
            f"{' and '.join(names)} fate (end fates {f_lo[bad].tolist()}, {f_hi[bad].tolist()})"
        )
    width = np.linalg.norm(hi - lo, axis=1)
    while np.any(width > settings.bisection_precision):
        active = width > settings.bisection_precision
        middle = 0.5 * (lo[active] + hi[active])
        f_mid = (yield problem, "fates", middle, directions[active])["fate"]
        index = np.flatnonzero(active)
        same_lo = f_mid == f_lo[index]
        same_hi = f_mid == f_hi[index]
        lo[index[same_lo]] = middle[same_lo]
        hi[index[same_hi]] = middle[same_hi]
        stuck = ~(same_lo | same_hi)  # still inside after max_time: on the manifold as far as integration tells
        lo[index[stuck]] = middle[stuck]
        hi[index[stuck]] = middle[stuck]
        width = np.linalg.norm(hi - lo, axis=1)
    return 0.5 * (lo + hi), width


def bisect_fate_switch(
    problem: SliceProblem, starts: np.ndarray, ends: np.ndarray, direction: int, settings: RefinementSettings,
    cost: Cost | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """Bisect each segment [start, end] to the point where the fate in ``direction`` switches.

    All segments are bisected together (one batch of trajectories per halving): :func:`bisect_task`
    run alone.

    Parameters
    ----------
    starts, ends : ndarray, shape (m, 2)

    Returns
    -------
    points : ndarray, shape (m, 2)
        Midpoints of the final brackets.
    widths : ndarray, shape (m,)
        Final bracket lengths (<= ``bisection_precision``, or 0 where a midpoint never left).

    Raises
    ------
    RefinementFailed
        If a segment's ends have the same fate (or none): the segment does not bracket the manifold.
    """
    directions = np.full(len(starts), direction)
    (result,) = run_tasks([bisect_task(problem, starts, ends, directions, settings)], settings, cost)
    return result
