"""FTLE ridges of the time-periodic double gyre against its manifolds computed by a direct method.

The double gyre of Shadden, Lekien & Marsden (2005) (support.double_gyre: A = 0.1, eps = 0.25,
omega = 2 pi / 10) keeps its walls y = 0 and y = 1 invariant; on each a hyperbolic trajectory near
x = 1 is the periodic orbit of the wall's 1-D flow, found by Newton on the period map. The
manifold that leaves the wall (stable for the bottom trajectory, unstable for the top one) is
grown by the direct method, with scipy alone: a short segment along the eigenvector off the wall
advected to t0 from periods later (stable) or earlier (unstable), refined by arc length.

The forward FTLE's ridges at t0 mark the stable manifold, the backward FTLE's the unstable one.
Compared, both ways, at t0 = 0 with FTLE time 15 (one and a half periods):

- every ridge point's distance to the manifold grown over two periods (an arc of length 17,
  folded around both gyres): a ridge lies on the manifold;
- the distance to the ridges from each point of the manifold grown over one period (the first
  1.85 of its arc, from the trajectory out, less its points within 0.04 of the wall, where the
  ridge extractor's stencils do not reach): the manifold is found.

Distances in cells, and in length to show them falling as the grid refines.
"""

import copy

import numpy as np
import pytest
from support.double_gyre import (
    DOUBLE_GYRE,
    PERIOD,
    hyperbolic_trajectory,
    wall_manifold,
)

from ldpipe.config import validate_config
from ldpipe.config.parameters import parameters_from_config
from ldpipe.core.maps.assembly import ld_map_dataset
from ldpipe.core.structures import curve_distances, curves_of, structures_dataset

T0, TAU = 0.0, 15.0
# the wall each manifold leaves, and the map field whose ridges trace it
MANIFOLDS = {"stable": 0, "unstable": 1}


def gyre_map(n: int):
    """The forward and backward FTLE of the double gyre over [0, 2] x [0, 1], cells of 1/n (the
    double gyre's LD engine of tests/data/test_ftle.py, p = 0.5: compiled once)."""
    spec = {"system": "double_gyre", "t0": T0, "tau": TAU, "p": 0.5, "ftle": True,
            "integrator": {"rtol": 1e-10, "atol": 1e-10},
            "section": {"axes": [{"name": "x", "range": [0.0, 2.0], "points": 2 * n + 1},
                                 {"name": "y", "range": [0.0, 1.0], "points": n + 1}]}}
    config = validate_config({"systems": {"double_gyre": copy.deepcopy(DOUBLE_GYRE)}, "ld_maps": {"m": spec}})
    return ld_map_dataset(parameters_from_config(config, "ld", "m"), None, show_progress=False)


def test_hyperbolic_trajectories_are_periodic_and_mirror_each_other():
    # the flow is unchanged by (x, y, t) -> (2 - x, 1 - y, -t) (f(2 - x, -a) = 2 - f(x, a)), which
    # takes the bottom wall's trajectory at t = 0 to the top's: x_top(0) = 2 - x_bottom(0)
    bottom, multiplier_bottom = hyperbolic_trajectory(0, 0.0)
    top, multiplier_top = hyperbolic_trajectory(1, 0.0)
    assert 1.0 < bottom < 1.2 and top == pytest.approx(2.0 - bottom, abs=1e-11)
    # strongly hyperbolic: the contracting period map shrinks by some e^(-pi^2 A T) (5e-5 measured)
    assert 0 < multiplier_bottom < 1e-3 and multiplier_top == pytest.approx(multiplier_bottom, rel=1e-6)
    # and the trajectory is periodic: one period later it is where it started
    assert hyperbolic_trajectory(0, PERIOD)[0] == pytest.approx(bottom, abs=1e-11)


def test_ftle_ridges_lie_on_the_manifolds_of_the_wall_trajectories():
    references = {}
    for manifold, wall in MANIFOLDS.items():
        first = wall_manifold(wall, T0, periods=1, spacing=0.005)
        off_wall = np.abs(first[:, 1] - wall) > 0.04
        references[manifold] = (wall_manifold(wall, T0, periods=2, spacing=0.005), first[off_wall])
    found = {}
    for n in (50, 100):
        structures = structures_dataset({"fields": ["ftle_forward", "ftle_backward"]}, gyre_map(n))
        for manifold, (long, first) in references.items():
            d = curve_distances(curves_of(structures, manifold=manifold), [long], scale=(1 / n, 1 / n),
                                reference_samples=[first])
            found[manifold, n] = d
            to, back = d["to_reference"], d["from_reference"]
            # measured at 50 and 100 (stable and unstable alike: the mirror symmetry above):
            # ridges to the manifold median 0.19, 0.18 cells, 95 % within 3.7, 4.8, worst 6.3, 8.2
            # (shorter ridges beside the main ones: folds of the manifold beyond two periods);
            # the manifold to the ridges median 0.45, 0.21, 95 % within 1.5, 3.4, worst 1.7, 7.6
            # (gaps where the ridge is thinner than a cell: next to the trajectory and where
            # the ridge doubles along the top)
            assert to["median"] < 0.6 and to["p95"] < 12 and to["worst"] < 20, (manifold, n, d)
            assert back["median"] < 1.2 and back["p95"] < 8 and back["worst"] < 20, (manifold, n, d)
    for manifold in MANIFOLDS:
        coarse, fine = found[manifold, 50], found[manifold, 100]
        # in length (cells of 1/50, then 1/100), closer as the grid refines: the medians both
        # ways and the ridges' 95 % and worst (the manifold's are held by the gaps, above)
        assert fine["to_reference"]["median"] / 100 < 0.75 * coarse["to_reference"]["median"] / 50
        assert fine["from_reference"]["median"] / 100 < 0.75 * coarse["from_reference"]["median"] / 50
        assert fine["to_reference"]["p95"] / 100 < coarse["to_reference"]["p95"] / 50
        assert fine["to_reference"]["worst"] / 100 < coarse["to_reference"]["worst"] / 50
