"""How every ladder times a setting: repeated runs, the smallest time kept, repeats within a budget."""

from __future__ import annotations

import math
import time
from dataclasses import dataclass
from typing import Callable, Generic, TypeVar

T = TypeVar("T")


@dataclass(frozen=True)
class RepeatRule:
    """At most ``repeats`` timed runs of a setting, fewer once their wall times total ``budget`` seconds.

    The smallest time of the runs is kept, the usual guard against a busy machine. A setting
    whose runs already fill the budget gains little from more of them (their relative timing
    noise is small against a long run), so, as timeit's autorange and pyperf do, the number of
    runs follows the time spent: every setting is timed at least once, short settings
    ``repeats`` times. ``budget`` inf repeats every setting.
    """

    repeats: int = 1
    budget: float = math.inf

    def __post_init__(self):
        if isinstance(self.repeats, bool) or not isinstance(self.repeats, int) or self.repeats < 1:
            raise ValueError(f"repeats: expected an integer >= 1, got {self.repeats!r}")
        if not self.budget > 0:
            raise ValueError(f"repeat budget: expected seconds > 0, got {self.budget!r}")

    def done(self, runs: int, total_wall: float) -> bool:
        """Whether ``runs`` runs totalling ``total_wall`` seconds are enough."""
        return runs >= self.repeats or total_wall >= self.budget

    def description(self) -> str:
        """What the stored time is, for a variable's long_name."""
        if self.repeats == 1:
            return "time of one run"
        if math.isinf(self.budget):
            return f"smallest of {self.repeats} runs"
        return f"smallest of up to {self.repeats} runs, fewer once the runs total {self.budget:g} s"

    @staticmethod
    def runs_attributes(timed_variable: str) -> dict:
        """Attributes of the variable that stores how many runs each setting's ``timed_variable`` is the smallest of."""
        return {"long_name": f"runs timed for {timed_variable} (fewer than repeats once they total repeat_budget)"}


@dataclass(frozen=True)
class Timed(Generic[T]):
    """The last run's result, the smallest wall and CPU time of the runs, and how many runs were timed."""

    result: T
    wall_time: float
    cpu_time: float
    runs: int


def repeat_timed(run: Callable[[], T], rule: RepeatRule) -> Timed[T]:
    """Call ``run`` as ``rule`` says, timing each call (wall clock and the process's CPU, all threads).

    The ladders measure deterministic computations, so every run returns the same numbers; an
    exception of ``run`` propagates (a deterministic failure fails on the first run).
    """
    best_wall = best_cpu = math.inf
    total, runs = 0.0, 0
    while True:
        wall, cpu = time.perf_counter(), time.process_time()
        result = run()
        wall, cpu = time.perf_counter() - wall, time.process_time() - cpu
        best_wall, best_cpu = min(best_wall, wall), min(best_cpu, cpu)
        total += wall
        runs += 1
        if rule.done(runs, total):
            return Timed(result, float(best_wall), float(best_cpu), runs)
