"""
Noise on the Duffing oscillator: a stochastic LD map
=====================================================

The undamped Duffing oscillator x' = y, y' = x − x³ has a saddle at the origin whose stable and
unstable manifolds close into two homoclinic loops; its LD map shows them as sharp curves. With
noise of diffusivity K on y (``noise:``), every point starts an ensemble of noisy paths, and the
map holds each path's LD of the drift, their mean and their spread (docs/guide/stochastic.md).
"""

import os

import matplotlib.pyplot as plt
import numpy as np

import ldpipe

POINTS = int(os.environ.get("LDPIPE_EXAMPLE_POINTS", "150"))  # grid points per axis

duffing = ldpipe.system(name="duffing", vector_field={"x": "y", "y": "x - x**3"},
                        coordinates=["x", "y"])
section = ldpipe.section(x=(-1.6, 1.6, POINTS), y=(-1.2, 1.2, POINTS))
clean = ldpipe.ld_map(duffing, section=section, tau=5, p=0.5)

# %%
# Sixteen paths a point, Euler-Maruyama steps of 0.01 over τ = 5 each way; the seed and each
# point's place in the grid key its noise, so the map is the same bits however it is tiled.

noisy = ldpipe.ld_map(duffing, section=section, tau=5, p=0.5,
                      noise={"diffusivity": {"x": 0.0, "y": 0.002}, "members": 16,
                             "dt": 0.01, "seed": 1})
print(noisy.ld_forward.sizes)

# %%
# Without noise, the ensemble's mean and its spread (the standard deviation over the members) of
# forward plus backward LD: the noise blurs the manifolds, and the spread is largest along them,
# where nearby paths part.

total = noisy.ld_forward + noisy.ld_backward
panels = (("no noise", (clean.ld_forward + clean.ld_backward).values),
          ("mean of 16 noisy paths", total.mean("member").values),
          ("spread over the paths", total.std("member", ddof=1).values))
fig, axes = plt.subplots(1, 3, figsize=(14, 4), layout="constrained")
for ax, (title, values) in zip(axes, panels):
    mesh = ax.pcolormesh(noisy.x, noisy.y, np.asarray(values).T, shading="auto",
                         cmap="viridis")
    fig.colorbar(mesh, ax=ax)
    ax.set(title=title, xlabel="x", ylabel="y")
plt.show()
