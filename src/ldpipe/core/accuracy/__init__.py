"""Accuracy against cost: work–precision measurements of the LD engine and the orbit corrector.

Two ladders of numerical settings, each measured against a tight reference computed in the
same run:

* **LD ladder.** A sample of the allowed points of one LD map (a seeded random subset of the
  map's own grid points) is integrated forward and backward with every setting of the ladder
  (integrator scheme and tolerance or step). Per setting: the wall time and CPU time (the
  smallest of up to ``repeats`` runs, the usual guard against a busy machine; fewer runs once
  they total ``repeat_budget`` seconds, see :mod:`~ldpipe.core.accuracy.timing`), the trajectory time
  integrated per wall second, the relative LD error against the reference per trajectory and
  its quantiles, the energy drift |H(end) - H(0)| the engine reports, and how many
  trajectories stopped for another reason than the reference's (reached tau, left the saddle
  region, escaped, failed). The reference is itself checked against a second setting (by
  default the same scheme at half the step), and that agreement is stored: it bounds how small
  an error the ladder can resolve.
* **Orbit ladder.** The Lyapunov orbit at one energy is computed from scratch (continuation
  from the saddle, bracketing, correction, one period with the monodromy matrix: what the
  ``upo`` stage does per orbit) with every pair (correction tolerance, integrator rtol). Per
  pair: wall time, the closure error ||x(T) - x(0)|| re-measured with a separate tight
  integration, the energy error |E - E_target|, and the period and initial-state differences
  to a tight reference orbit.
* **NHIM ladders** (2 DoF, where the periodic orbit's crossing of a variable-time slice is the
  exact NHIM point). Grid resolution: the LD map at n x n points and the detected cell
  (:func:`ldpipe.core.nhim.detect_nhim_cell`, and the plain LD maximum for comparison); per n the
  wall time and the distance from the crossing. Refinement depth: from one detected cell, both
  refinements of :mod:`ldpipe.core.nhim` (bisection on fates, zoomed LD grids) at each tolerance;
  per tolerance the wall time, trajectories integrated and the distance from the crossing.

Timing is wall clock by design: it is the measurement. Everything else is deterministic (the
engine integrates every trajectory independently, with the same steps on every run); the
machine and its load average go into the file with the times.

Modules, one job each (every public name is importable from this package, as before):

- :mod:`~ldpipe.core.accuracy.machine` — the machine, its load and the library versions;
- :mod:`~ldpipe.core.accuracy.timing` — how a setting is timed (repeated runs within a budget);
- :mod:`~ldpipe.core.accuracy.ld_ladder` — the LD ladder (integrator settings, timing, errors);
- :mod:`~ldpipe.core.accuracy.orbit_ladder` — the periodic-orbit ladder;
- :mod:`~ldpipe.core.accuracy.nhim_ladder` — the NHIM ladders;
- :mod:`~ldpipe.core.accuracy.measurement` — every ladder of a configuration, as the stage's file
  holds them (:func:`~ldpipe.core.accuracy.measurement.accuracy_cost_dataset`).
"""

from ...engine.settings import integrator_ladder
from .ld_ladder import (
    QUANTILES, STOP_REASONS, IntegratorStep, TimedLD, finite_quantiles, ld_ladder_dataset, relative_error,
    same_number, sample_indices, stop_reason, timed_ld, warm_up,
)
from .machine import cpu_model, load_average, machine_attributes
from .measurement import accuracy_cost_dataset
from .nhim_ladder import REFINEMENT_METHODS, nhim_grid_dataset, nhim_refinement_dataset
from .orbit_ladder import CorrectorStep, closure_error, compute_orbit, corrector_ladder, orbit_ladder_dataset, timed_orbit
from .timing import RepeatRule, Timed, repeat_timed

__all__ = [
    "QUANTILES", "REFINEMENT_METHODS", "STOP_REASONS", "CorrectorStep", "IntegratorStep", "RepeatRule", "Timed",
    "TimedLD", "accuracy_cost_dataset", "closure_error",
    "compute_orbit", "corrector_ladder", "cpu_model", "finite_quantiles", "integrator_ladder", "ld_ladder_dataset",
    "load_average", "machine_attributes", "nhim_grid_dataset", "nhim_refinement_dataset", "orbit_ladder_dataset",
    "relative_error", "repeat_timed", "same_number", "sample_indices", "stop_reason", "timed_ld", "timed_orbit",
    "warm_up",
]
