"""
The flux over the saddle, three ways
=====================================

Reactive-island theory says three numbers are equal (MacKay 1990), each computed from different
data: the action ∮ p·dq of the Lyapunov orbit over the saddle; the area of the reactive islands,
the cuts of the orbit's stable and unstable tubes with a surface of section; and the reactive
flux through a dividing line by Monte Carlo, each sample integrated both ways and counted once
however often it recrosses. The transport stage computes all three for Barbanis 2 DoF's bottom
saddle, with the harmonic estimate 2πΔE/ω beside them.
"""

import os

import matplotlib.pyplot as plt
import numpy as np

import ldpipe

# sets the sample counts below
POINTS = int(os.environ.get("LDPIPE_EXAMPLE_POINTS", "200"))
SAMPLES = 25 * POINTS

barbanis = ldpipe.system(builtin="barbanis_2dof")
equilibria = ldpipe.equilibria(barbanis)
energies = [0.125, 0.5, 2.25]
orbits = ldpipe.periodic_orbits(barbanis, name="barbanis_2dof_bottom",
                                equilibria=equilibria, saddle_near=[5.5, -7.0711],
                                center_mode=0, energies={"excess": energies})
flux = ldpipe.transport(
    orbits, equilibria=equilibria, energies={"excess": energies},
    island={"points": 32},
    monte_carlo={"batch": SAMPLES, "max_samples": SAMPLES},
    survival={"initial_count": SAMPLES, "count": POINTS * 10, "duration": 1.0,
              "decay_window": [0.3, 1.0]},
    gap_times={"count": POINTS * 10})

# %%
# The action is the reference: the island areas agree with it to ~1e-11 (spectral quadrature of
# the cut curves), the Monte Carlo flux within its standard error, and the harmonic estimate
# drifts away as ΔE grows.

action = flux.flux_action.values
islands = flux.flux_island_area  # the stable and the unstable tube's island
fluxes = ["flux_action", "flux_monte_carlo", "flux_monte_carlo_stderr",
          "flux_harmonic"]
print(f"{'excess energy':24}", np.array2string(flux.excess_energy.values, precision=7))
for name in fluxes:
    print(f"{name:24}", np.array2string(flux[name].values, precision=7))
print("island area / action - 1 (an energy a row; the stable, the unstable tube):")
print(np.array2string((islands / flux.flux_action - 1).values, precision=2))

fig, (left, right) = plt.subplots(1, 2, figsize=(11, 4), layout="constrained")
excess = flux.excess_energy.values
for tube, marker in (("stable", "s-"), ("unstable", "d--")):
    area = islands.sel(manifold=tube).values
    left.plot(excess, np.maximum(np.abs(area / action - 1), 1e-16), marker,
              label=f"island area, {tube} tube")
left.plot(excess, np.abs(flux.flux_harmonic.values / action - 1), "^-",
          label="harmonic 2πΔE/ω")
left.set(yscale="log", xticks=energies, xticklabels=[str(e) for e in energies],
         xlabel="ΔE", ylabel="|flux / action − 1|",
         title="island areas and the harmonic estimate")
left.legend()
stderr = flux.flux_monte_carlo_stderr.values
deviation = (flux.flux_monte_carlo.values - action) / stderr
right.axhspan(-2, 2, color="0.9", label="±2 standard errors")
right.plot(excess, deviation, "o", label="Monte Carlo")
right.set(xticks=energies, xticklabels=[str(e) for e in energies], xlabel="ΔE",
          ylabel="(Monte Carlo − action) / its standard error",
          title="the Monte Carlo flux", ylim=(-4, 4))
right.legend()
plt.show()
