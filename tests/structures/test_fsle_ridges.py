"""FSLE ridges against FTLE ridges where both are defined, and both against a closed form.

The steady double gyre u = -pi A sin(pi x) cos(pi y), v = pi A cos(pi x) sin(pi y) (A = 0.1), as
velocity data on a grid with a node on x = 1: u is odd and v even about x = 1, in the flow and in
its interpolant, so the separatrix x = 1 is invariant in both, the stable manifold of the saddle
(1, 0) and the unstable one of (1, 1). A neighbour across it is split from its point at the saddle,
so the forward FSLE and FTLE have their ridges on x = 1, and the backward ones too.

The FTLE over 8 time units; the FSLE with its neighbours at 0.005, the final separation 0.05, over
at most 15 (reached on a band some 15 cells wide about x = 1: where the FSLE is defined). Over
longer times the FTLE's ridge splits in two either side of x = 1 (measured at 15: 1.5 cells
each side): the separatrix's own trajectory only approaches the saddle, its neighbours pass it and
are sheared along the walls. The map's grid is offset from x = 1 by 0.3 cells.
"""

import numpy as np
import pytest
from support.gridded import write_velocity_file

import ldpipe
from ldpipe.core.structures import curve_distances, curves_of

A = 0.1
N = 40  # cells per unit of the maps
CELL = 1.0 / N
SECTION = ldpipe.section(x=(0.5 + 0.3 * CELL, 1.5 + 0.3 * CELL, N + 1), y=(0.1 + 0.2 * CELL, 0.9 + 0.2 * CELL, 33))
INTEGRATOR = {"rtol": 1e-9, "atol": 1e-9}


def steady_gyre(x, y, t):
    return -np.pi * A * np.sin(np.pi * x) * np.cos(np.pi * y) + 0 * t, np.pi * A * np.cos(np.pi * x) * np.sin(np.pi * y)


@pytest.fixture(scope="module")
def fields(tmp_path_factory):
    step = 1.0 / 32
    path = write_velocity_file(tmp_path_factory.mktemp("gyre") / "steady_gyre.nc", steady_gyre,
                               np.arange(0, 2 + step / 2, step), np.arange(0, 1 + step / 2, step),
                               np.arange(-20.0, 21.0, 10.0))
    system = ldpipe.system(name="steady_gyre_data", velocity_data={"path": str(path)})
    ftle = ldpipe.ld_map(system, section=SECTION, tau=8.0, p=0.5, ftle=True, integrator=INTEGRATOR)
    fsle = ldpipe.fsle(system, section=SECTION, max_time=15.0, initial_separation=0.005, final_separation=0.05,
                       interval=0.25, integrator=INTEGRATOR)
    return ldpipe.structures(ftle, fields=["ftle_forward", "ftle_backward"]), ldpipe.structures(fsle), fsle


@pytest.mark.parametrize("direction, manifold", [("forward", "stable"), ("backward", "unstable")])
def test_fsle_ridges_agree_with_ftle_ridges_on_the_separatrix(fields, direction, manifold):
    ftle_structures, fsle_structures, fsle = fields
    ftle_curves = curves_of(ftle_structures, manifold=manifold)
    fsle_curves = curves_of(fsle_structures, manifold=manifold)
    # one ridge each, along the whole map (its rows 1 to 31: the stencils reach no further)
    assert len(ftle_curves) == 1 and len(fsle_curves) == 1, ([len(c) for c in ftle_curves], len(fsle_curves))
    y = SECTION["axes"][1]["range"]
    for curve in ftle_curves + fsle_curves:
        assert curve[:, 1].min() < y[0] + 1.5 * CELL and curve[:, 1].max() > y[1] - 1.5 * CELL
    # on x = 1: measured worst 0.21 cells (FTLE), 0.15 (FSLE)
    assert np.abs(ftle_curves[0][:, 0] - 1.0).max() < 0.6 * CELL
    assert np.abs(fsle_curves[0][:, 0] - 1.0).max() < 0.5 * CELL
    # the FTLE's ridge where the FSLE is defined (every pixel of its stencil reached the final
    # separation): all of it, here; and the two ridges within 0.35 cells of each other (measured)
    reached = fsle[f"fsle_reached_{direction}"].values.astype(bool)
    defined = np.zeros_like(reached)
    defined[1:-1, 1:-1] = np.all([reached[1 + a:reached.shape[0] - 1 + a, 1 + b:reached.shape[1] - 1 + b]
                                  for a in (-1, 0, 1) for b in (-1, 0, 1)], axis=0)
    points = ftle_curves[0]
    i = np.rint((points[:, 0] - SECTION["axes"][0]["range"][0]) / CELL).astype(int)
    j = np.rint((points[:, 1] - SECTION["axes"][1]["range"][0]) / CELL).astype(int)
    assert defined[i, j].all()
    d = curve_distances(fsle_curves, ftle_curves, scale=(CELL, CELL))
    assert d["to_reference"]["worst"] < 1.0 and d["from_reference"]["worst"] < 1.0, d
