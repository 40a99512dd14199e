"""The LD's singular curves on a paper section against the manifold stage's manifolds cut by it.

Barbanis 2 DoF at excess energy 0.125, the section y = 0, p_y > 0 of the paper's Fig. 3, in the
window x in [-2.3, 1.3], p_x in [-4.3, 4.3]. The reference is computed independently of any LD:
the manifold stage globalises the stable and unstable manifolds of the bottom saddle's Lyapunov
orbit (at the settings of tests/test_api.py, whose engines it compiles) and cuts them with the
section; the first cut of each inward branch is a closed curve. The top saddle's orbit is the
bottom one's image under the reversing symmetry (x, y, p_x, p_y) -> (x, -y, -p_x, p_y), which
maps the section to itself and stable to unstable: its stable cut is the bottom unstable cut
with p_x -> -p_x, and the other way round.

With tau = 12 a forward trajectory from the section reaches the orbits' neighbourhood only from
their first cut (the second lies further out in time), so the forward LD's singular curves in
the window are the two stable first cuts, the backward LD's the two unstable ones: the distance
both ways must be small, and shrink as the grid refines.
"""

import numpy as np
import pytest

import ldpipe
from ldpipe.core.structures import curve_distances, curves_of

# tests/test_api.py's family and manifolds (the same compiled engines)
FAMILY = {"saddle_near": [5.5, -7.0711], "energies": {"excess": [0.125]}, "tolerance": 1e-10, "energy_tolerance": 1e-12}
MANIFOLD = {"energy": {"excess": 0.125}, "points": 40, "samples": 150, "displacement": 1e-6, "time": 30,
            "section": {"coordinate": "y", "value": 0.0, "direction": 1}, "crossings": 2,
            "integrator": {"rtol": 1e-10, "atol": 1e-10, "escape_radius": 30}}
WINDOW = (-2.3, 1.3, -4.3, 4.3)


@pytest.fixture(scope="module")
def barbanis():
    return ldpipe.system(builtin="barbanis_2dof")


@pytest.fixture(scope="module")
def references(barbanis):
    orbits = ldpipe.periodic_orbits(barbanis, name="bottom", **FAMILY)
    cuts = ldpipe.manifolds(orbits, name="m", **MANIFOLD)

    def first_cut(manifold):
        where = {"manifold": manifold, "branch": "inward", "crossing": 0}
        assert cuts.section_valid.sel(**where).values.all()
        state = cuts.section_state.sel(**where).sel(phase=["x", "px"]).values
        return np.vstack([state, state[:1]])  # the cut of a tube: a closed curve

    mirror = np.array([1.0, -1.0])
    return {"stable": [first_cut("stable"), first_cut("unstable") * mirror],
            "unstable": [first_cut("unstable"), first_cut("stable") * mirror]}


def test_ld_singular_curves_converge_to_the_manifold_cuts(barbanis, references):
    x0, x1, p0, p1 = WINDOW
    medians = {"stable": [], "unstable": []}
    for n in (37, 73):  # square cells of 0.1 and 0.05
        section = ldpipe.section(x=(x0, x1, n), px=(p0, p1, (n - 1) * 43 // 18 + 1), fixed={"y": 0.0},
                                 solve="py", sign=1)
        ld_map = ldpipe.ld_map(barbanis, name="window", section=section, energy={"excess": 0.125}, tau=12.0, p=0.5,
                               integrator={"rtol": 1e-8, "atol": 1e-8}, saddle_near=[5.5, -7.0711])
        cell = float(ld_map.x[1] - ld_map.x[0])
        found = ldpipe.structures(ld_map, fields=["ld_forward", "ld_backward"])
        for manifold in ("stable", "unstable"):
            curves = curves_of(found, manifold=manifold)
            d = curve_distances(curves, references[manifold])
            # measured (stable and unstable alike, by the symmetry): at 37 (cells 0.1) median 0.097,
            # worst 0.19 to the cuts and 0.14 from them; at 73 (cells 0.05) median 0.040, worst
            # 0.093 and 0.082: about a cell, falling with it
            assert d["to_reference"]["median"] < 1.5 * cell and d["to_reference"]["worst"] < 3 * cell, (n, d)
            assert d["from_reference"]["worst"] < 3 * cell, (n, d)
            medians[manifold].append((d["to_reference"]["median"], d["from_reference"]["median"]))
    for manifold, (coarse, fine) in medians.items():
        assert fine[0] < coarse[0] / 1.5 and fine[1] < coarse[1] / 1.5, (manifold, medians)
