"""
An LD map in blocks on a Dask cluster
=====================================

``chunks=`` cuts a map into blocks of start points (bands of rows of the section's first axis)
and hands them to a Dask cluster: here a ``LocalCluster`` in this process, on a real machine
one of worker processes or dask-jobqueue's ``SLURMCluster`` (see the guide's page on Dask). The
map returns at once as dask arrays; computed, it equals the map of one process bit for bit.
This is the Hénon–Heiles map of the formula example, E = 0.16, τ = 15.
"""

import os

import matplotlib.pyplot as plt
import numpy as np
from distributed import Client, LocalCluster

import ldpipe

POINTS = int(os.environ.get("LDPIPE_EXAMPLE_POINTS", "200"))  # grid points per axis

henon_heiles = ldpipe.system(name="henon_heiles",
                             formula="(x**2 + y**2)/2 + x**2*y - y**3/3",
                             coordinates=["x", "y"])
section = ldpipe.section(y=(-0.45, 0.8, POINTS), py=(-0.5, 0.5, POINTS),
                         fixed={"px": 0.0}, solve="x", root="largest")
settings = {"section": section, "energy": 0.16, "tau": 15, "p": 0.5}

# Two workers as threads of this process keep the example light; leave processes
# out (its default, one process a worker) for a real map, and give each task's
# engine its cores (threads=).
with LocalCluster(n_workers=2, threads_per_worker=1, processes=False,
                  dashboard_address=":0") as cluster, Client(cluster) as client:
    lazy = ldpipe.ld_map(henon_heiles, chunks=POINTS * POINTS // 8, client=client,
                         **settings)
    print(f"{lazy.ld_forward.data.numblocks[0]} blocks of "
          f"{lazy.ld_forward.data.chunks[0][0]} rows; "
          f"the dashboard: {client.dashboard_link}")
    ld = lazy.compute()

# %%
# The same map in one process: every variable equal, bit for bit (``equals``
# counts the points off the energy surface, missing in both, as equal).

single = ldpipe.ld_map(henon_heiles, **settings)
print("equal bit for bit:", all(ld[name].equals(single[name])
                                for name in single.data_vars))

# %%
# The total LD, with the blocks' edges: each band of rows was one task.

fig, ax = plt.subplots(figsize=(6, 4.5), layout="constrained")
ld.ldpipe.plot(ax=ax, descriptor="total")
edges = np.cumsum(lazy.ld_forward.data.chunks[0])[:-1]
for edge in edges:
    ax.axvline(float(ld.y[edge - 1] + ld.y[edge]) / 2, color="white", linewidth=0.8,
               linestyle="--")
plt.show()
