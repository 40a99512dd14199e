"""
A model's C-grid by a coast: the FTLE of a curved, rotated grid's currents
==========================================================================

Ocean models such as ROMS write their currents on curvilinear grids (2-D
coordinates, turned and bent against the map) as an Arakawa C-grid: the
velocity through each face of each cell, a land mask at the cells' centres.
Here ``ldpipe.data.curvilinear`` makes such a dataset, laid out as a ROMS
file (``x_rho``, ``y_rho``, u on ``xi_u``, v on ``eta_v``, ``mask_rho``;
``"path":`` reads the file it writes the same way): the double gyre of
Shadden et al. (2005) in a basin, [0, 2] x [0, 1], on a grid turned by 30
degrees and bent by a conformal map. Every cell whose centre is outside the
basin is land, so its coast is a staircase of the grid's cells, as a
model's is. ldpipe reads it as a C-grid: the faces by land are closed,
the coast is a wall no trajectory crosses. The forward FTLE marks
the repelling material lines; points on land have none and are grey.
"""

import os
import textwrap

import matplotlib.pyplot as plt

import numpy as np

import ldpipe
from ldpipe.data.curvilinear import double_gyre_c_grid_dataset, plane_grid

# grid points along x (the tests build the gallery smaller)
POINTS = int(os.environ.get("LDPIPE_EXAMPLE_POINTS", "200"))
SPACING = 0.04  # the grid's spacing, in its own frame
x, y = plane_grid("conformal", SPACING)  # the cells' centres


def land(i, j):
    """Land at the cells' centres (i, j) outside the basin."""
    xc, yc = x[j, i], y[j, i]
    return (xc < 0.0) | (xc > 2.0) | (yc < 0.0) | (yc > 1.0)


times = np.arange(0.0, 16.01, 0.25)
roms = double_gyre_c_grid_dataset("conformal", SPACING, times, land=land)
gyre = ldpipe.system(name="gyre", velocity_data={
    "dataset": roms, "x": "x_rho", "y": "y_rho",
    "components": "grid", "mask": "mask_rho"})
print(textwrap.fill(gyre.description, 72))

section = ldpipe.section(x_rho=(-0.1, 2.1, POINTS),
                         y_rho=(-0.1, 1.1, POINTS * 6 // 11))
ftle = ldpipe.ld_map(gyre, section=section, t0=0.0, tau=15.0,
                     ftle=True, ld=False, directions="forward")
print("starts on land:", int(ftle.start_on_land.sum()),
      "of", ftle.start_on_land.size)

fig, ax = plt.subplots(figsize=(8, 4.4), layout="constrained")
ftle.ldpipe.plot("ftle_forward", ax=ax, cmap="magma")
# every fourth grid line of the file, i and j
ax.plot(x[::4].T, y[::4].T, color="white", lw=0.4, alpha=0.6)
ax.plot(x[:, ::4], y[:, ::4], color="white", lw=0.4, alpha=0.6)
ax.set(xlim=(-0.1, 2.1), ylim=(-0.1, 1.1), aspect="equal", xlabel="x",
       ylabel="y", title="forward FTLE, the grid's lines in white")
plt.show()
