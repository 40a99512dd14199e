"""The saddle's normal form: cost by order, and the flux's accuracy against independent values.

Cases: Barbanis 2 DoF over the bottom saddle, against the Lyapunov orbit's action (ldpipe's
differential corrector, 129 samples, spectral ∮ p·dq); Barbanis–Contopoulos 3 DoF at the x > 0
saddle, against the harmonic estimate and the saddle-flux Monte Carlo (40 000 samples at ΔE = 0.5),
with the smallest divisors met at each degree (ω₃/ω₂ ≈ 2.52, near 5 : 2). Times are wall times in
one process on a shared machine (the load average is recorded); the Taylor expansion (sympy, once)
is included, JIT compiles are not involved (the normal form is numpy).

    .venv/bin/python benchmarks/normal_form.py            # writes benchmarks/normal_form.md
"""

from __future__ import annotations

import math
import os
import time
from pathlib import Path

import numpy as np

from ldpipe.core.trajectories import FlowSettings
from ldpipe.core.normal_form import flux, system_normal_form
from ldpipe.core.orbits.periodic import CorrectorSettings, LyapunovFamily, linearize_saddle, sample_orbit
from ldpipe.systems import make_system
from ldpipe.core.transport import DividingPlane, orbit_action, reactive_flux_monte_carlo

OUTPUT = Path(__file__).parent / "normal_form.md"


def timed(function, *args, **kwargs):
    start = time.perf_counter()
    value = function(*args, **kwargs)
    return value, time.perf_counter() - start


def main() -> None:
    lines = ["# Normal form of the saddle: cost and accuracy", "",
             f"Machine: {os.cpu_count()} CPUs, load average {os.getloadavg()[0]:.1f} at the start "
             "(shared with other jobs).", ""]

    lines += ["## Cost", "", "| system | order | form | coordinate changes | wall time (s) |", "|---|---|---|---|---|"]
    barbanis = make_system("barbanis_2dof", {"builtin": "barbanis_2dof"})
    bottom = np.array([5.5, -math.sqrt(50.0)])
    bc = make_system("barbanis_contopoulos_3dof", {"builtin": "barbanis_contopoulos_3dof"})
    saddle = bc.closed_form_equilibria()[1]
    forms = {}
    for label, system, point, order, form, transforms in (
            ("Barbanis 2 DoF", barbanis, bottom, 12, "full", True),
            ("Barbanis 2 DoF", barbanis, bottom, 16, "full", True),
            ("Barbanis–Contopoulos 3 DoF", bc, saddle, 12, "full", False),
            ("Barbanis–Contopoulos 3 DoF", bc, saddle, 12, "partial", False),
            ("Barbanis–Contopoulos 3 DoF", bc, saddle, 12, "full", True)):
        nf, seconds = timed(system_normal_form, system, point, order, form=form, transforms=transforms)
        forms[(label, order, form, transforms)] = nf
        lines.append(f"| {label} | {order} | {form} | {'both' if transforms else 'none'} | {seconds:.1f} |")
    nf3 = forms[("Barbanis–Contopoulos 3 DoF", 12, "full", True)]
    points = np.random.default_rng(0).normal(size=(1000, 6)) * 0.1
    seconds = min(timed(nf3.original_states, points)[1] for _ in range(3))
    lines += ["", f"Evaluating the change to the original coordinates (6 polynomials of degree 11, numpy, each "
              f"monomial its parent times one variable) at 1000 points: {seconds:.2f} s (best of 3).", ""]

    lines += ["## Barbanis 2 DoF: flux against the Lyapunov orbit's action", "",
              "Relative error |flux / action − 1| of the normal form truncated at each order "
              "(the action itself is accurate to about 3e-13).", ""]
    nf2 = forms[("Barbanis 2 DoF", 16, "full", True)]
    orders = list(range(2, 17, 2))
    lines += ["| ΔE | action | " + " | ".join(f"order {o}" for o in orders) + " |",
              "|---|---|" + "---|" * len(orders)]
    settings = CorrectorSettings()
    family = LyapunovFamily(barbanis, linearize_saddle(barbanis, bottom), 0, settings)
    critical = family.saddle.critical_energy
    for excess in (0.125, 0.5, 1.0, 2.25, 5.0):
        family.continue_to(critical + excess, initial_amplitude=1e-4, max_step=0.1, max_members=1000)
        orbit = family.at_energy(critical + excess, energy_tolerance=1e-13)
        action = orbit_action(sample_orbit(barbanis, orbit, 129, settings)[1], 2)
        errors = [abs(flux(nf2, excess, order=o) / action - 1) for o in orders]
        lines.append(f"| {excess} | {action:.13g} | " + " | ".join(f"{e:.1e}" for e in errors) + " |")

    lines += ["", "## Barbanis–Contopoulos 3 DoF", "",
              "Smallest divisor |⟨η, a − b⟩| met at each degree (full form; the partial form's are ≥ λ):", "",
              "| degree | " + " | ".join(str(d) for d in range(3, 13)) + " |", "|---|" + "---|" * 10,
              "| full | " + " | ".join(f"{nf3.normalization.smallest_divisor[d]:.4f}" for d in range(3, 13)) + " |",
              "| partial | " + " | ".join(f"{forms[('Barbanis–Contopoulos 3 DoF', 12, 'partial', False)].normalization.smallest_divisor[d]:.4f}"
                                        for d in range(3, 13)) + " |", ""]
    lines += ["Largest generator coefficient max |W_s| at each degree (full form): the divisor 0.0234 lifts the odd "
              "degrees from 7 on to the level of the even ones, and the series still falls geometrically:", "",
              "| degree | " + " | ".join(str(d) for d in range(3, 13)) + " |", "|---|" + "---|" * 10,
              "| max abs W | " + " | ".join(f"{np.max(np.abs(nf3.normalization.generators[d])):.1e}"
                                         for d in range(3, 13)) + " |", ""]
    om1, om2 = nf3.modes.frequencies
    lines += [f"Centre frequencies {om1:.6f}, {om2:.6f} (ratio {om2 / om1:.4f}; 2 ω₃ − 5 ω₂ = {2 * om2 - 5 * om1:.4f}), "
              f"saddle rate {nf3.modes.saddle_rate:.6f}.", "",
              "Flux by order, relative to the harmonic estimate (2π)²ΔE²/(2ω₂ω₃), full and partial forms:", "",
              "| ΔE | harmonic | full, order 4 | full, order 8 | full, order 12 | partial, order 12 | |full − partial| / flux | truncation error (12 vs 10) |",
              "|---|---|---|---|---|---|---|---|"]
    partial = forms[("Barbanis–Contopoulos 3 DoF", 12, "partial", False)]
    for excess in (0.01, 0.1, 0.5, 1.0, 2.18):
        harmonic = (2 * math.pi * excess) ** 2 / (2 * om1 * om2)
        full = {o: flux(nf3, excess, order=o) for o in (4, 8, 10, 12)}
        part = flux(partial, excess, method="volume")
        lines.append(f"| {excess} | {harmonic:.8g} | " + " | ".join(f"{full[o] / harmonic - 1:+.3e}" for o in (4, 8, 12))
                     + f" | {part / harmonic - 1:+.3e} | {abs(full[12] - part) / full[12]:.1e} | "
                       f"{abs(full[12] - full[10]) / full[12]:.1e} |")
    lines += ["", "How high in energy it stays useful: |flux(order) / flux(top order) − 1| at large ΔE "
              "(2 DoF to order 20, 3 DoF to order 14):", "",
              "| system | ΔE | order 8 | order 12 | order 16 |", "|---|---|---|---|---|"]
    high2 = system_normal_form(barbanis, bottom, 20, transforms=False)
    for excess in (5.0, 10.0, 20.0):
        top = flux(high2, excess)
        lines.append(f"| 2 DoF | {excess} | " + " | ".join(f"{abs(flux(high2, excess, order=o) / top - 1):.1e}"
                                                     for o in (8, 12, 16)) + " |")
    high3 = system_normal_form(bc, saddle, 14, transforms=False)
    for excess in (5.0, 10.0, 20.0):
        top = flux(high3, excess)
        lines.append(f"| 3 DoF | {excess} | " + " | ".join(f"{abs(flux(high3, excess, order=o) / top - 1):.1e}"
                                                     for o in (8, 12)) + " | (top) |")
    energy = bc.potential(saddle) + 0.5
    plane = DividingPlane.at_saddle(bc, saddle, energy)
    result, seconds = timed(reactive_flux_monte_carlo, plane, commit=2.0, duration=20.0, batch=10000, max_samples=40000,
                            target_stderr=0.0, flow=FlowSettings(rtol=1e-9, atol=1e-9, escape_radius=60.0), seed=3)
    value = flux(nf3, 0.5)
    lines += ["", f"Monte Carlo at ΔE = 0.5 (40 000 samples, {seconds:.0f} s): {result.flux:.6f} ± {result.stderr:.6f}; "
              f"normal form {value:.6f}: {(result.flux - value) / result.stderr:+.2f} standard errors.", ""]
    lines.append(f"Load average at the end: {os.getloadavg()[0]:.1f}.")
    OUTPUT.write_text("\n".join(lines) + "\n")
    print("\n".join(lines))


if __name__ == "__main__":
    main()
