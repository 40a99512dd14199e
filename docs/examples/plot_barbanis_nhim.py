"""
Barbanis 2 DoF: the NHIM refined and validated
===============================================

On a variable-time LD map (trajectories stop when they leave the saddle region) the stable and
unstable manifolds of the NHIM are the ridges of the forward and the backward LD, and the NHIM's
point on the section is where they cross: in 2 DoF, where the Lyapunov periodic orbit of the same
energy pierces the section. This is the paper's Fig. 4(a) slice y = −7 at ΔE = 0.125.
"""

import os

import matplotlib.pyplot as plt

import ldpipe

POINTS = int(os.environ.get("LDPIPE_EXAMPLE_POINTS", "200"))  # grid points per axis

barbanis = ldpipe.system(builtin="barbanis_2dof")
equilibria = ldpipe.equilibria(barbanis)
section = ldpipe.section(x=(4.8, 6.0, POINTS), px=(-0.6, 0.6, POINTS),
                         fixed={"y": -7.0}, solve="py", sign=1)
ld = ldpipe.ld_map(barbanis, name="fig4_k-7.0", equilibria=equilibria,
                   saddle_near=[5.5, -7.0], section=section,
                   energy={"excess": 0.125}, tau=50, p=0.5, time="variable",
                   region={"x": [4.5, 6.5], "y": [-8.5, -5.5]})

# %%
# The Lyapunov orbit of the bottom saddle at the map's energy, the reference.

orbits = ldpipe.periodic_orbits(barbanis, name="barbanis_2dof_bottom",
                                equilibria=equilibria, saddle_near=[5.5, -7.0711],
                                center_mode=0, energies={"excess": [0.125]})

# %%
# Detection on the map, then refinement by bisection on the fates of trajectories (which side of
# the saddle they leave by) to 1e-8, and validation against the orbit's crossing of the section.

points = ldpipe.nhim([ld], references=[orbits], tolerance=1e-8)
refined = points.refined_point.isel(slice=0).values
print("detected on the grid:", points.detected_point.isel(slice=0).values)
uncertainty = float(points.refined_uncertainty[0])
print("refined:             ", refined, f"(uncertainty {uncertainty:.1e})")
print("the orbit's crossing:", points.reference_point.isel(slice=0).values)
print(f"distance to it: {float(points.distance_refined[0]):.1e} after refinement, "
      f"{float(points.distance_detected[0]):.1e} on the grid")

# %%
# The forward and backward maps with the refined point: it sits where the two ridges cross.

fig, axes = plt.subplots(1, 2, figsize=(10, 4), layout="constrained")
for ax, descriptor in zip(axes, ("forward", "backward")):
    # x across, as the point (x, p_x) drawn on it
    ld.ldpipe.plot(ax=ax, descriptor=descriptor)
    ax.plot(*refined, "r+", markersize=14, markeredgewidth=2,
            label="refined NHIM point")
    ax.legend(loc="lower right")
plt.show()
