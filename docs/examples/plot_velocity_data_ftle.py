"""
Ocean currents from Python: where a meandering jet pulls water apart
=====================================================================

Gridded currents need not be a file: ``ldpipe.system(velocity_data=...)`` takes the
``xarray.Dataset`` a notebook already holds (here ldpipe's example of a meandering jet with a
coast, decoded as ``xr.open_dataset`` would give it; lazy, dask-backed data work the same way).
With the data's calendar, the start is a date and the integration time a duration. The forward
finite-time Lyapunov exponent (FTLE) marks the repelling material lines, so only forward
trajectories are integrated (``directions="forward"``), and only their end points are kept
(``ld=False``: no Lagrangian descriptor). Points on land, and points whose trajectory leaves
the data within the 8 days (or the neighbours its differences need do), have no FTLE: they are
missing in the Dataset and drawn grey. The FTLE is per day, the data's time unit.
"""

import os

import matplotlib.pyplot as plt
import xarray as xr

import ldpipe
from ldpipe.data.example import example_dataset

# grid points along longitude (the tests build the gallery smaller)
POINTS = int(os.environ.get("LDPIPE_EXAMPLE_POINTS", "200"))

currents_data = xr.decode_cf(example_dataset(days=12.0, resolution=0.5))
currents = ldpipe.system(
    name="currents",
    velocity_data={"dataset": currents_data, "coordinates": "sphere"})
section = ldpipe.section(lon=(-78.0, -42.0, POINTS),
                         lat=(27.0, 48.0, POINTS * 3 // 5))
ftle = ldpipe.ld_map(currents, section=section, t0="2000-01-02", tau="8D",
                     ftle=True, ld=False, directions="forward")
print(ftle.attrs["t0_date"], ftle.attrs["tau_duration"], ftle.attrs["directions"])
defined = int(ftle.ftle_defined_forward.sum())
print("points with an FTLE:", defined, "of", ftle.ftle_forward.size)

fig, ax = plt.subplots(figsize=(8, 4.6), layout="constrained")
# longitude across, as on a chart
ftle.ldpipe.plot("ftle_forward", ax=ax, cmap="magma")
ax.set_title("forward FTLE over 8 days from 2000-01-02")
plt.show()
