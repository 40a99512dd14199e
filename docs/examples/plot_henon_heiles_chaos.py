"""
Hénon–Heiles: chaos told by the LD
===================================

On the section x = 0 of the Hénon–Heiles system at E = 1/8 (p_x > 0 solved from the
energy), regular orbits lie on invariant tori and chaotic ones fill a sea between
them. The LD of a regular start changes smoothly with the start; that of a chaotic
one as fast as neighbouring orbits part. ``ldpipe.chaos_indicators`` computes the
indicators of the LD at every start: D_L and S_L from the LDs of its four neighbours
(Hillebrand et al. 2022), the Laplacian (Daquin et al. 2022), and the exact gradient
of the LD carried along the variational equations, which needs no neighbours; beside
them the SALI over a ten times longer time, the reference.
"""

import os

import matplotlib.pyplot as plt
import numpy as np

import ldpipe

POINTS = int(os.environ.get("LDPIPE_EXAMPLE_POINTS", "120")) // 2  # per axis

henon_heiles = ldpipe.system(name="henon_heiles",
                             formula="(x**2 + y**2)/2 + x**2*y - y**3/3",
                             coordinates=["x", "y"])
section = ldpipe.section(y=(-0.45, 0.65, POINTS), py=(-0.5, 0.5, POINTS),
                         fixed={"x": 0.0}, solve="px")
found = ldpipe.chaos_indicators(henon_heiles, section=section, energy=0.125,
                                tau=200.0, sigma=1e-5, reference_tau=2000.0,
                                dt=0.02)

# %%
# Each panel is log10 of a field over the section; grey where a start is outside the
# energy surface or one of its neighbours is. Chaotic starts are bright in all five:
# the SALI small (its scale reversed), every LD indicator large.

names = {"sali": "SALI (reference)", "ld_difference": "D_L",
         "ld_second_difference": "S_L", "ld_laplacian": "Laplacian of L",
         "ld_gradient": "|grad L| (exact)"}
fig, axes = plt.subplots(1, 5, figsize=(16, 3.6), layout="constrained",
                         sharey=True)
defined = found.defined.values
for ax, (name, title) in zip(axes, names.items()):
    values = found[name].values
    if name == "sali":  # below rounding it is 0: drawn at 1e-16
        values = np.maximum(values, 1e-16)
    shown = defined & (values > 0)
    field = np.log10(values, where=shown, out=np.full(values.shape, np.nan))
    ax.set_facecolor("0.85")
    cmap = "viridis_r" if name == "sali" else "viridis"
    ax.pcolormesh(found.y, found.py, field.T, shading="nearest", cmap=cmap)
    agreement = found.attrs.get(f"agreement_{name}")
    label = title if agreement is None else f"{title}: {agreement:.0%} agree"
    ax.set_title(label, fontsize=10)
    ax.set_xlabel("y")
axes[0].set_ylabel("p_y")
plt.show()

# %%
# Each indicator's threshold is taken from its own values (Otsu's, and for the
# gradient the minimum-error threshold, as its chaotic values spread over many
# decades); the agreement is the share of starts it classifies as the SALI does.

for name in names:
    if name != "sali":
        print(f"{name:22s} agreement {found.attrs[f'agreement_{name}']:.3f}")
print(f"chaotic by the SALI: {found.attrs['chaotic_fraction_sali']:.0%}",
      f"of {found.attrs['defined_starts']} starts")
