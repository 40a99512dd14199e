"""
The forced Duffing oscillator: a time-dependent flow
=====================================================

A system need not be a Hamiltonian: ``vector_field`` gives a general flow dx/dt = f(x, t), one
formula per state variable, in the coordinates, the parameters and the time ``t``. The forced,
damped Duffing oscillator x' = y, y' = x − x³ − δy + F cos(ωt) has a hyperbolic trajectory near
the origin; its stable and unstable manifolds at the start time t0 show as the thin curves of low
LD on the (x, y) plane.
"""

import os

import matplotlib.pyplot as plt

import ldpipe

POINTS = int(os.environ.get("LDPIPE_EXAMPLE_POINTS", "200"))  # grid points per axis

duffing = ldpipe.system(
    name="forced_duffing",
    vector_field={"x": "y", "y": "x - x**3 - delta*y + F*cos(omega*t)"},
    coordinates=["x", "y"], parameters={"delta": 0.25, "F": 0.3, "omega": 1.2})

# %%
# A vector field's map has no energy: two state variables on the grid, nothing solved, and a
# start time ``t0`` (forward to t0 + τ, backward to t0 − τ). Two start times show the
# manifolds moving with the forcing.

fig, axes = plt.subplots(1, 2, figsize=(10, 4), layout="constrained")
for ax, t0 in zip(axes, (0.0, 1.5)):
    section = ldpipe.section(x=(-1.6, 1.6, POINTS), y=(-1.2, 1.2, POINTS))
    ld = ldpipe.ld_map(duffing, section=section, t0=t0, tau=10, p=0.5)
    ld.ldpipe.plot(ax=ax)  # its title names t0
plt.show()
