"""
Barbanis–Contopoulos 3 DoF: the NHIM sampled over slices
========================================================

In 3 DoF the NHIM of the index-1 saddle is a 3-sphere in the 5-dimensional energy surface, and
a two-dimensional slice (x and p_x on the grid; y, z and p_y fixed; p_z solved from the energy)
meets it in isolated points. Each variable-time LD map of a family of slices gives one point,
detected where the forward and backward ridges cross and refined by bisection on fates; together
they sample the NHIM. This is the paper's Fig. 5 section at E = 24, slid along z.
"""

import os

import matplotlib.pyplot as plt
import numpy as np

import ldpipe

POINTS = int(os.environ.get("LDPIPE_EXAMPLE_POINTS", "200"))  # grid points per axis

system = ldpipe.system(builtin="barbanis_contopoulos_3dof")
equilibria = ldpipe.equilibria(system)
slices = np.linspace(2.45, 2.85, 3)  # values of z, around the saddle's z = 2.647


def slice_map(z):
    """The variable-time LD map of the x–p_x slice at z (y at the saddle's, p_y = 0)."""
    section = ldpipe.section(x=(9.0, 12.0, POINTS), px=(-0.6, 0.6, POINTS),
                             fixed={"y": "saddle", "z": float(z), "py": 0.0},
                             solve="pz")
    return ldpipe.ld_map(system, name=f"z{z:.2f}", equilibria=equilibria,
                         saddle_near=[10.29, 5.29, 2.65], section=section,
                         energy=24.0, tau=50, p=0.5, time="variable",
                         region={"x": [9.0, 12.0], "y": [2.5, 7.5], "z": [1.0, 4.0]})


maps = [slice_map(z) for z in slices]
points = ldpipe.nhim(maps, tolerance=1e-8)

# %%
# Each refined point is a full phase-space state on the energy surface, with the bound of its
# refinement's uncertainty.

states = points.refined_state.values
for z, state, bound in zip(slices, states, points.refined_uncertainty.values):
    print(f"z = {z:.2f}: (x, p_x) = ({state[0]:.8f}, {state[3]:.8f}) ± {bound:.0e}")

# %%
# The maps with their points, and the points in (x, z): as the slice moves, its NHIM point
# moves along the 3-sphere.

fig, axes = plt.subplots(1, len(maps) + 1, figsize=(4 * len(maps) + 4, 3.6),
                         layout="constrained")
for ax, ld, state, z in zip(axes, maps, states, slices):
    ld.ldpipe.plot(ax=ax)  # x across: the section's first axis, as the point (x, p_x)
    ax.text(0.03, 0.95, f"z = {z:.2f}", transform=ax.transAxes, va="top",
            bbox={"facecolor": "white", "alpha": 0.8, "edgecolor": "none"})
    ax.plot(state[0], state[3], "r+", markersize=14, markeredgewidth=2)
axes[-1].plot(states[:, 0], states[:, 2], "o-")
axes[-1].set(xlabel="x", ylabel="z", title="the refined points")
plt.show()
