r"""
A round eddy: M_p depends on the axes, the arc length does not
===============================================================

M_p sums each coordinate's speed on its own, :math:`|\dot x|^p + |\dot y|^p`, so it depends on
the directions of the axes: turning the coordinates turns nothing in the flow but changes the map.
A trajectory moving along a diagonal counts more than one moving as fast along an axis, by
2^(1 - p/2) for p < 1 and by √2 for p = 1. A round eddy, u = −y Ω(r), v = x Ω(r) with
Ω(r) = exp(−r²), whose particles circle at a speed that depends on the radius alone, then shows
four lobes at 45° to the axes. The arc length, the integral of √(u² + v²), is the same in every
direction: on this eddy it is τ r Ω(r) each way of time, a function of the radius alone.
"""

import os

import matplotlib.pyplot as plt
import numpy as np

import ldpipe

POINTS = int(os.environ.get("LDPIPE_EXAMPLE_POINTS", "200"))  # grid points per axis

omega = "exp(-(x**2 + y**2))"  # the rate of turn, a function of the radius alone
eddy = ldpipe.system(name="round_eddy",
                     vector_field={"x": f"-y*{omega}", "y": f"x*{omega}"},
                     coordinates=["x", "y"])
section = ldpipe.section(x=(-2.0, 2.0, POINTS), y=(-2.0, 2.0, POINTS))
TAU = 3.0

# %%
# The same eddy, the same grid, two descriptors: M_p with p = 1/2 (four lobes, the diagonals
# brightest) and the arc length (round, as the eddy is).

fig, axes = plt.subplots(1, 2, figsize=(9, 3.9), layout="constrained")
maps = {}
for ax, p in zip(axes, (0.5, "arclength")):
    maps[p] = ldpipe.ld_map(eddy, name=f"eddy_{p}", section=section,
                            tau=TAU, p=p)
    maps[p].ldpipe.plot(ax=ax)
    ax.set_aspect("equal")
    ax.set_title("$M_{1/2}$" if p == 0.5 else "arc length", loc="left")
plt.show()

# %%
# The arc length against its closed form, forward plus backward: 2 τ r Ω(r).

arc = maps["arclength"]
r = np.hypot(*np.meshgrid(arc.x, arc.y, indexing="ij"))
exact = 2 * TAU * r * np.exp(-r**2)
total = (arc.ld_forward + arc.ld_backward).values
error = np.max(np.abs(total - exact))
print(f"largest |arc length - 2 tau r Omega(r)|: {error:.1e}")
