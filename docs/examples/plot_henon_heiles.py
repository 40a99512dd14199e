"""
Hénon–Heiles: an LD map from a formula
=======================================

A potential is a formula, not code: sympy derives its gradient, and ldpipe compiles the
equations of motion (numba) once per system. This is ldds' Hénon–Heiles slice, x ≥ 0 and
p_x = 0, at the energy E = 0.16 just below the escape energy 1/6: x is solved from the energy
(its largest root), and the map is drawn forward, backward and in total.
"""

import os

import matplotlib.pyplot as plt

import ldpipe

POINTS = int(os.environ.get("LDPIPE_EXAMPLE_POINTS", "200"))  # grid points per axis

henon_heiles = ldpipe.system(name="henon_heiles",
                             formula="(x**2 + y**2)/2 + x**2*y - y**3/3",
                             coordinates=["x", "y"])
section = ldpipe.section(y=(-0.45, 0.8, POINTS), py=(-0.5, 0.5, POINTS),
                         fixed={"px": 0.0}, solve="x", root="largest")
ld = ldpipe.ld_map(henon_heiles, section=section, energy=0.16, tau=15, p=0.5)

# %%
# The forward LD is sharp along the stable manifolds, the backward one along the unstable
# manifolds; their sum shows both. Points outside the energetically allowed region are grey.

fig, axes = plt.subplots(1, 3, figsize=(13, 3.8), layout="constrained")
for ax, descriptor in zip(axes, ("forward", "backward", "total")):
    ld.ldpipe.plot(ax=ax, descriptor=descriptor)
    ax.text(0.03, 0.95, descriptor, transform=ax.transAxes, va="top",
            bbox={"facecolor": "white", "alpha": 0.8, "edgecolor": "none"})
plt.show()

# %%
# The Dataset is the file the pipeline writes for the same ``ld_maps:`` entry: its attributes
# record the system, the section, the energy and every integrator setting.

print(ld.attrs["title"])
print(f"{int(ld.allowed.sum())} allowed points;",
      f"largest energy error {float(ld.energy_error.max()):.1e}")
