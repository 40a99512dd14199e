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
# (crossed upwards): the cuts are closed curves in (x, p_x), the tubes' cross sections.

cuts = ldpipe.manifolds(orbits, name="deleon_berne_tubes", energy={"excess": 0.5},
                        points=POINTS, time=15, samples=300, crossings=1,
                        section={"coordinate": "y", "value": 0.3, "direction": 1})

fig, (left, right) = plt.subplots(1, 2, figsize=(11, 4.2), layout="constrained")
equilibria.ldpipe.plot(ax=left)  # the wells and the saddle
orbits.ldpipe.plot(ax=left)  # the orbits, across the saddle along x
cuts.ldpipe.plot(ax=right)
plt.show()
