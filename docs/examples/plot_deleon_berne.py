"""
De Leon–Berne with masses: its periodic orbit and manifolds
============================================================

The Hamiltonian is H = ½ pᵀM⁻¹p + V(q) with a constant kinetic matrix M: here UPOsHam's De
Leon–Berne system, an isomerization model with masses m_x = m_y = 8. Every stage integrates
this H itself (dq/dt = M⁻¹p), not a rescaled copy. Its index-1 saddle at the origin separates
two wells at y = ±1/√2; the Lyapunov orbit over the saddle and the tubes of its stable and
unstable manifolds carry every trajectory that crosses from one well to the other.
"""

import os

import matplotlib.pyplot as plt
import numpy as np

import ldpipe

# trajectories per manifold branch
POINTS = int(os.environ.get("LDPIPE_EXAMPLE_POINTS", "200"))

deleon_berne = ldpipe.system(
    name="deleon_berne",
    formula="d_x*(1 - exp(-lam*x))**2 + 4*y**2*(y**2 - 1)*exp(-alpha*lam*x) + eps_s",
    coordinates=["x", "y"],
    parameters={"d_x": 10.0, "lam": 1.5, "alpha": 1.0, "eps_s": 1.0},
    masses={"x": 8.0, "y": 8.0})
equilibria = ldpipe.equilibria(deleon_berne,
                               box={"x": [-1.0, 1.0], "y": [-1.0, 1.0]})
print(equilibria[["energy", "type"]].to_dataframe())

# %%
# The Lyapunov family of the saddle's centre mode, at two excess energies over E_c = 1.

orbits = ldpipe.periodic_orbits(deleon_berne, name="deleon_berne_saddle",
                                equilibria=equilibria, saddle_near=[0.0, 0.0],
                                center_mode=0, energies={"excess": [0.1, 0.5]})
print(orbits[["excess_energy", "period"]].to_dataframe())

# %%
# The stable and unstable manifolds of the orbit at ΔE = 0.5, cut by the section y = 0.3
# (crossed upwards): a cut is a closed curve in (x, p_x), a tube's cross section. Within the
# 15 time units integrated, the unstable tube's outward branch reaches the section.

cuts = ldpipe.manifolds(orbits, name="deleon_berne_tubes", energy={"excess": 0.5},
                        points=POINTS, time=15, samples=300, crossings=1,
                        section={"coordinate": "y", "value": 0.3, "direction": 1})

# %%
# (a) The wells and the saddle in the configuration plane; the Lyapunov orbits run along
# y = 0 across the saddle, the larger one over the smaller. (b) The same orbits in the (x, p_x)
# plane, where each is a closed curve around the saddle. (c) The cut of the tube.

fig, (wells, phase, tube) = plt.subplots(1, 3, figsize=(13, 4.2),
                                         layout="constrained")
equilibria.ldpipe.plot(ax=wells)
# the larger orbit first and wider: the smaller one shows on top of it in (a)
for orbit, colour, width in ((1, "tab:orange", 6), (0, "tab:blue", 2)):
    path = orbits.trajectory.isel(orbit=orbit)
    label = f"ΔE = {float(orbits.excess_energy[orbit]):g}"
    x, y, px = (path.sel(phase=name) for name in ("x", "y", "px"))
    wells.plot(x, y, color=colour, lw=width, label=label)
    phase.plot(x, px, color=colour, lw=2, label=label)
wells.legend(loc="upper right")
wells.set(title="(a) wells, saddle and orbits", xlabel="x", ylabel="y")
phase.plot([0.0], [0.0], "rx", label="saddle")
phase.legend(loc="upper right")
phase.set(title="(b) Lyapunov orbits in (x, p_x)", xlabel="x", ylabel="p_x")
for manifold in cuts.manifold.values:
    for branch in cuts.branch.values:
        where = {"manifold": manifold, "branch": branch, "crossing": 0}
        valid = cuts.section_valid.sel(where).values
        if valid.any():
            state = cuts.section_state.sel(where).values[valid]
            closed = np.vstack([state, state[:1]])
            tube.plot(closed[:, 0], closed[:, 2], "o-", ms=3,
                      label=f"{manifold} tube, {branch} branch")
tube.legend(loc="center")
tube.set(title="(c) tube cut at y = 0.3, ΔE = 0.5", xlabel="x", ylabel="p_x")
plt.show()
