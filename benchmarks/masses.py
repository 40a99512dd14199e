"""What a kinetic matrix costs the LD engine: the same trajectories with and without masses.

H = |p|^2 / (2 m) + V with equal masses m is the unit-mass system slowed down by sqrt(m): the
state (q, sqrt(m) p) integrated for sqrt(m) tau traces the orbit of (q, p) over tau. So the
Barbanis grid of ``engine_throughput.py`` (200 x 200 on y = 0, p_y > 0 at E = E_c - 0.125, p = 1/2)
is integrated twice: unit masses over tau, and m_x = m_y = 8 from the mapped states over
sqrt(8) tau (fixed steps scaled by sqrt(8) too, so both take the same number of steps). The
difference in wall time per step attempt is the kinetic section's (engine/kinetic.py: M^-1 on
every acceleration, M on the step's momentum-rate polynomials). Printed: wall and CPU seconds,
step attempts, and seconds per million attempts. (The LDs differ: with masses dq/dt is the
unit-mass one over sqrt(m), dp/dt the same, over sqrt(m) times the time; the LDs with masses are
checked in tests/engine/test_masses.py.)

Run: ``.venv/bin/python benchmarks/masses.py [--grid 200] [--tau 50] [--repeat 3]``
"""

from __future__ import annotations

import argparse
import math
import time

import numba

from engine_throughput import E_SADDLE, section_grid
from ldpipe.engine import LDSettings, compute_ld
from ldpipe.systems import make_system

MASS = 8.0


def timed(system, states, settings, repeat: int) -> tuple[float, float, int]:
    wall = cpu = math.inf
    for _ in range(repeat):
        start, start_cpu = time.perf_counter(), time.process_time()
        result = compute_ld(system, states, +1, settings)
        wall = min(wall, time.perf_counter() - start)
        cpu = min(cpu, time.process_time() - start_cpu)
    return wall, cpu, int(result.steps.sum())


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--grid", type=int, default=200)
    parser.add_argument("--tau", type=float, default=50.0)
    parser.add_argument("--repeat", type=int, default=3, help="runs per setting; the fastest is reported")
    args = parser.parse_args()

    unit = make_system("barbanis_2dof", {"builtin": "barbanis_2dof"})
    heavy = make_system("barbanis_m8", {"builtin": "barbanis_2dof", "masses": {"x": MASS, "y": MASS}})
    states = section_grid(unit, args.grid, E_SADDLE - 0.125)
    scale = math.sqrt(MASS)
    mapped = states.copy()
    mapped[:, 2:] *= scale
    print(f"{len(states)} initial conditions, tau = {args.tau} (x sqrt(8) with masses), p = 1/2, "
          f"{numba.get_num_threads()} threads")
    cases = {
        "dop853 rtol=1e-8": (LDSettings(scheme="dop853", rtol=1e-8, atol=1e-8, tau=args.tau),
                             LDSettings(scheme="dop853", rtol=1e-8, atol=1e-8, tau=scale * args.tau)),
        "sym6 dt=0.05": (LDSettings(scheme="sym6", dt=0.05, tau=args.tau),
                         LDSettings(scheme="sym6", dt=0.05 * scale, tau=scale * args.tau)),
    }
    for name, (plain, massive) in cases.items():
        compute_ld(unit, states[:8], +1, plain)  # JIT or cache load, not timed
        compute_ld(heavy, mapped[:8], +1, massive)
        print(f"{name}:")
        for label, system, start, settings in (("unit masses", unit, states, plain), ("m = 8", heavy, mapped, massive)):
            wall, cpu, steps = timed(system, start, settings, args.repeat)
            print(f"  {label:>12}: wall {wall:6.2f} s, CPU {cpu:6.2f} s, {steps:.3g} attempts, "
                  f"{1e6 * wall / steps:.3f} s per 1e6 attempts (wall), {1e6 * cpu / steps:.3f} (CPU)")


if __name__ == "__main__":
    main()
