"""A C-grid's metrics read from the model's file, and the flux through slanted faces, against closed forms.

The C-grid interpolant in a cell (local coordinates a, b in 0 .. 1 between its faces) is
dI/dt = F_u(a) / A, dJ/dt = F_v(b) / A: the fluxes F through the faces (u times the face's
length) linear across the cell, A the cell's area (ldpipe.systems.velocity_data.grid_metrics).
Given a streamfunction psi at the cells' corners and fluxes from its differences, F_u = -(psi_NW
- psi_SW) on the west face and -(psi_NE - psi_SE) on the east, F_v = psi_SE - psi_SW on the south
and psi_NE - psi_NW on the north (zero divergence in every cell, exactly), the bilinear Psi of
the corners has Psi_b = -F_u(a) and Psi_a = F_v(b), so along the interpolant's exact trajectories
dPsi/dt = (Psi_a F_u(a) + Psi_b F_v(b)) / A = (F_v F_u - F_u F_v) / A = 0. Psi is therefore
conserved to the integrator's tolerance when the faces' lengths are the ones the velocities were
written with (the file's), and drifts when another length is used for any face.

The grid is ROMS's: stretched along x and y, x = L (s + sigma sin 2 pi s), s = i / (n - 1), with
the analytic metric pm = 1 / (dx/di) at the centres (pn likewise), which differs from the distances
between neighbouring centres by up to 8 % (the stretch's second derivative over a cell).
"""

import math

import numpy as np
import pytest
import xarray as xr

import ldpipe
from ldpipe.config import validate_config
from ldpipe.config.parameters import parameters_from_config
from ldpipe.core.maps.assembly import compute_ld_map
from ldpipe.core.trajectories import FlowSettings, flow_map
from ldpipe.data.curvilinear import c_grid_dataset, curvilinear_dataset, write_dataset
from ldpipe.engine import LDSettings, compute_ld
from ldpipe.errors import ConfigError
from ldpipe.systems import make_system

pytestmark = [pytest.mark.compiles, pytest.mark.xdist_group("c_grid_engine")]  # test_c_grid.py's engine
NX, NY, LX, LY, SIGMA_X, SIGMA_Y = 24, 20, 23000.0, 19000.0, 0.08, 0.06
PSI0 = 700.0  # m^2/s: velocities of about 0.1 m/s
ENTRY = {"x": "x_rho", "y": "y_rho", "components": "grid"}
TIGHT = {"rtol": 1e-10, "atol": 1e-10}


def stretch(n, length, sigma, s):
    """x(s) = L (s + sigma sin 2 pi s) and its derivative in the index, dx/di = L (1 + 2 pi sigma cos 2 pi s) / (n - 1)."""
    return (length * (s + sigma * np.sin(2 * np.pi * s)),
            length * (1 + 2 * np.pi * sigma * np.cos(2 * np.pi * s)) / (n - 1))


def stretched_grid():
    """Centres x, y (NY, NX), the analytic pm, pn (1/m) and the corners' x, y at half indices -1/2 .. n - 1/2."""
    x, dx = stretch(NX, LX, SIGMA_X, np.arange(NX) / (NX - 1))
    y, dy = stretch(NY, LY, SIGMA_Y, np.arange(NY) / (NY - 1))
    xc, _ = stretch(NX, LX, SIGMA_X, (np.arange(NX + 1) - 0.5) / (NX - 1))
    yc, _ = stretch(NY, LY, SIGMA_Y, (np.arange(NY + 1) - 0.5) / (NY - 1))
    X, Y = np.meshgrid(x, y)
    pm, pn = np.meshgrid(1 / dx, 1 / dy)
    return X, Y, pm, pn, np.meshgrid(xc, yc)


def grid_file(path, u, v, pm, pn, X, Y, times=np.arange(0.0, 4e5 + 1, 1e5), **variables):
    """A ROMS-like C-grid file of steady face velocities u (NY, NX - 1), v (NY - 1, NX) in m/s, with pm, pn."""

    def steady(values):
        return lambda xm, ym, t: np.broadcast_to(values, np.broadcast_shapes(xm.shape, t.shape))

    dataset = c_grid_dataset(steady(u), steady(v), X, Y, times)
    metric = {"units": "meter-1"}
    dataset = dataset.assign(pm=(("eta", "xi"), pm, dict(metric, long_name="curvilinear coordinate metric in XI")),
                             pn=(("eta", "xi"), pn, dict(metric, long_name="curvilinear coordinate metric in ETA")),
                             **variables)
    return write_dataset(dataset, path)


def faces_from_psi(psi, pm, pn):
    """u, v on the faces whose fluxes are psi's differences, with ROMS's face lengths (module docstring):
    on_u = 2 / (pn_i + pn_i+1), om_v = 2 / (pm_j + pm_j+1)."""
    on_u = 2 / (pn[:, :-1] + pn[:, 1:])
    om_v = 2 / (pm[:-1] + pm[1:])
    u = -(psi[1:, 1:-1] - psi[:-1, 1:-1]) / on_u
    v = (psi[1:-1, 1:] - psi[1:-1, :-1]) / om_v
    return u, v


def bilinear(psi, indices):
    """The bilinear interpolant of the corners' psi (corner (jc, ic) at indices (ic - 1/2, jc - 1/2))."""
    p, q = indices[:, 0] + 0.5, indices[:, 1] + 0.5
    ic, jc = np.floor(p).astype(int), np.floor(q).astype(int)
    a, b = p - ic, q - jc
    return ((1 - a) * (1 - b) * psi[jc, ic] + a * (1 - b) * psi[jc, ic + 1] + (1 - a) * b * psi[jc + 1, ic]
            + a * b * psi[jc + 1, ic + 1])


@pytest.fixture(scope="module")
def gyre_file(tmp_path_factory):
    X, Y, pm, pn, (XC, YC) = stretched_grid()
    psi = PSI0 * np.sin(np.pi * XC / LX) * np.sin(np.pi * YC / LY)
    u, v = faces_from_psi(psi, pm, pn)
    return grid_file(tmp_path_factory.mktemp("metrics") / "gyre.nc", u, v, pm, pn, X, Y), psi


def test_the_files_metrics_differ_from_the_distances_between_centres():
    # the premise of the tests below: a cell's length 1 / pm is not the distance from its centre to
    # its neighbours' (measured 8.1 % in x, 6.8 % in y)
    X, Y, pm, pn, _ = stretched_grid()
    assert np.abs(1 / pm[:, 1:] / np.diff(X, axis=1) - 1).max() > 0.05
    assert np.abs(1 / pn[1:] / np.diff(Y, axis=0) - 1).max() > 0.05


def test_psi_is_conserved_with_the_files_metrics_and_not_without(gyre_file):
    path, psi = gyre_file
    read = make_system("read", {"velocity_data": {"path": str(path), **ENTRY}})
    ignored = make_system("ignored", {"velocity_data": {"path": str(path), **ENTRY, "metrics": "coordinates"}})
    assert read.grid_attributes() == {"grid_metrics": "dx: pm, dy: pn", "metric_tolerance": 0.1}
    starts = np.array([[6.3, 10.2], [12.7, 5.4], [17.2, 14.6]])  # indices, well inside the gyre
    settings = LDSettings(tau=3e5, p=0.5, **TIGHT)  # about a turn round the gyre's centre
    drift = {}
    for name, system in (("read", read), ("ignored", ignored)):
        result = compute_ld(system, system.states_from_engine(starts), 1, settings, t0=0.5e5)
        end = system.engine_states(result.end_state)
        assert np.abs(end - starts).max() > 3.0  # they moved several cells
        drift[name] = np.abs(bilinear(psi, end) - bilinear(psi, starts)).max() / PSI0
    # measured: read 2.4e-8 of PSI0, the integrator's error (1.7e-6 at tolerance 1e-8, 2.0e-10 at 1e-12);
    # ignored 8.8e-4 at every tolerance
    assert drift["read"] < 1e-7
    assert drift["ignored"] > 3e-4


def test_a_window_keeps_the_whole_grids_trajectories_with_the_files_metrics_at_uneven_times(tmp_path):
    # identity: a window's box reads the faces, the land and the cells' scales (1 / area, from pm,
    # pn) of its nodes only, so for trajectories inside it the map is the whole grid's bit for bit;
    # and psi stays conserved (the invariant of test_psi_is_conserved_...) with the file's metrics
    # read over the box, at uneven output times (a steady flow: their cubic is the flow itself)
    X, Y, pm, pn, (XC, YC) = stretched_grid()
    psi = PSI0 * np.sin(np.pi * XC / LX) * np.sin(np.pi * YC / LY)
    u, v = faces_from_psi(psi, pm, pn)
    times = np.array([0.0, 0.6e5, 1.5e5, 1.9e5, 2.8e5, 3.3e5, 4.4e5])
    path = grid_file(tmp_path / "uneven.nc", u, v, pm, pn, X, Y, times=times)
    # the centres' columns 6 .. 17 and rows 5 .. 14: the box one more each side, its geometry (three
    # more) inside the grid, so nothing of the window's starts at the grid's first node
    window = {"x_rho": [X[0, 6], X[0, 17]], "y_rho": [Y[5, 0], Y[14, 0]]}
    whole = make_system("whole", {"velocity_data": {"path": str(path), **ENTRY}})
    boxed = make_system("boxed", {"velocity_data": {"path": str(path), **ENTRY, "window": window}})
    assert boxed.box == ((5, 18), (4, 15)) and boxed.geometry.offset == (2, 1)
    assert boxed.grid_attributes() == whole.grid_attributes() == {"grid_metrics": "dx: pm, dy: pn",
                                                                  "metric_tolerance": 0.1}
    starts = np.array([[10.3, 8.2], [13.1, 10.6], [11.0, 11.4]])  # indices: round the gyre's centre, in the box
    settings = LDSettings(tau=3e5, p=0.5, **TIGHT)
    wanted = compute_ld(whole, whole.states_from_engine(starts), 1, settings, t0=0.5e5)
    result = compute_ld(boxed, boxed.states_from_engine(starts), 1, settings, t0=0.5e5)
    np.testing.assert_array_equal(result.end_state, wanted.end_state)
    np.testing.assert_array_equal(result.ld, wanted.ld)
    end = boxed.engine_states(result.end_state)
    assert np.abs(end - starts).max() > 2.0  # they moved (measured 2.9 cells)
    assert (end[:, 0] > 5.5).all() and (end[:, 0] < 17.5).all() and (end[:, 1] > 4.5).all() and (end[:, 1] < 14.5).all()
    # measured 8.8e-10 of PSI0, the integrator's error; with metrics: coordinates 2.2e-4
    assert np.abs(bilinear(psi, end) - bilinear(psi, starts)).max() / PSI0 < 5e-9


def test_a_uniform_flux_crosses_each_cell_in_its_area_over_the_flux(tmp_path):
    # u on every u face such that its flux u on_u is F0 (v = 0): in cell i the index velocity is
    # F0 pm pn, so from the west face of cell 5 (index 4.5) a trajectory reaches the east face of
    # cell k after sum_{c = 5..k} dx_c dy_j / F0 (closed form, ROMS's cell area 1 / (pm pn))
    X, Y, pm, pn, _ = stretched_grid()
    flux = 500.0  # m^2/s
    u = flux * (pn[:, :-1] + pn[:, 1:]) / 2
    path = grid_file(tmp_path / "uniform.nc", u, np.zeros((NY - 1, NX)), pm, pn, X, Y)
    system = make_system("uniform", {"velocity_data": {"path": str(path), **ENTRY}})
    j = 9
    cell_times = 1 / (pm[j] * pn[j] * flux)  # seconds to cross cell i
    tau = cell_times[5:11].sum() + 0.3 * cell_times[11]  # to index 10.5 + 0.3
    start = system.states_from_engine(np.array([[4.5, float(j)]]))
    result = compute_ld(system, start, 1, LDSettings(tau=tau, p=0.5, **TIGHT), t0=0.5e5)
    # measured 5.5e-8 index: the index velocity jumps at each face (F0 over each cell's own area),
    # which the step control passes at its tolerance
    np.testing.assert_allclose(system.engine_states(result.end_state), [[10.8, j]], rtol=0, atol=2e-7)
    # the exact cell crossing reads the same cells' scales and passes the faces exactly
    crossed = flow_map(system, start, tau, FlowSettings(method="cell_crossing"), t0=0.5e5)
    # measured: 1.4e-14 (rounding of the cells' times and of the coordinates' round trip)
    np.testing.assert_allclose(system.engine_states(crossed.end_state), [[10.8, j]], rtol=0, atol=1e-10)


def test_the_metrics_tolerance_is_recorded_in_the_maps_file(gyre_file):
    path, _ = gyre_file
    X, Y, *_ = stretched_grid()
    spec = {"system": "gyre", "t0": 1e5, "tau": 1e4, "p": 0.5,
            "section": {"axes": [{"name": "x_rho", "range": [8000.0, 12000.0], "points": 2},
                                 {"name": "y_rho", "range": [8000.0, 10000.0], "points": 2}]}}
    entry = {"path": str(path), **ENTRY, "metric_tolerance": 0.05}
    config = validate_config({"systems": {"gyre": {"velocity_data": entry}}, "ld_maps": {"m": spec}})
    dataset = compute_ld_map(parameters_from_config(config, "ld", "m"), None, show_progress=False)
    assert dataset.attrs["grid_metrics"] == "dx: pm, dy: pn"
    assert dataset.attrs["metric_tolerance"] == 0.05


def test_bad_metrics_are_refused_naming_the_variable(gyre_file, tmp_path):
    path, _ = gyre_file
    with xr.open_dataset(path) as dataset:
        good = dataset.load()

    def refused(dataset, match, **entry):
        bad = write_dataset(dataset, tmp_path / "bad.nc")
        with pytest.raises(ConfigError, match=match):
            make_system("bad", {"velocity_data": {"path": str(bad), **ENTRY, **entry}})

    # pm in 1/km, still labelled meter-1: the cells 1000 times too long
    refused(good.assign(pm=good.pm * 1000.0), r"metric 'pm' \(dx\) gives a length of .* \(ratio 0\.000999\d*, beyond "
                                              r"metric_tolerance 0\.1\): is it in other units")
    # another grid's (a grid twice as coarse): beyond the tolerance
    refused(good.assign(pn=good.pn / 2), r"metric 'pn' \(dy\) .* \(ratio 2\.0")
    holes = good.copy()
    holes["pm"] = holes.pm.where(holes.xi != 3)
    refused(holes, r"metric 'pm' \(dx\) has 20 missing or non-positive values \(the first nan at index \(0, 3\)\)")
    refused(good.assign(pn=-good.pn), r"metric 'pn' \(dy\) has 480 missing or non-positive values")
    unitless = good.copy()
    unitless.pm.attrs.pop("units")
    refused(unitless, r"velocity_data\.metrics': metric 'pm' \(dx\) has units None; expected a length .* or its "
                      r"inverse")
    refused(good, r"velocity_data\.metrics\.u_face': metric 'pm' \(u_face\) is 2-D float64 of shape \(20, 24\); "
                  r"expected numbers of shape \(20, 23\)", metrics={"dx": "pm", "dy": "pn", "u_face": "pm"})
    # on a collocated grid (u, v at the centres) the coordinates' metric maps the trajectories back
    X, Y, pm, pn, _ = stretched_grid()
    collocated = curvilinear_dataset(lambda x, y, t: (0 * x + 0.1 + 0 * t, 0 * y + 0 * t), X, Y, np.arange(4.0),
                                     components="grid").assign(pm=good.pm, pn=good.pn)
    refused(collocated, r"velocity_data\.metrics': a model's metrics are read on a C-grid",
            metrics={"dx": "pm", "dy": "pn"})
    # a tighter tolerance refuses the analytic metric (measured: it differs from the coordinates' 5.5e-4)
    refused(good, r"metric 'pm' \(dx\) .* beyond metric_tolerance 1e-05", metric_tolerance=1e-5)


def sheared_grid(h, shear, n):
    """Centres of a sheared grid: x = h i + shear h j, y = h j, (n, n) each."""
    J, I = np.meshgrid(np.arange(n, dtype=float), np.arange(n, dtype=float), indexing="ij")
    return h * I + shear * h * J, h * J


@pytest.mark.parametrize("metrics", ["", "NEMO", "MITgcm"])
def test_a_uniform_flow_through_slanted_faces_moves_in_straight_lines(tmp_path, metrics):
    # On the sheared grid x = h i + s h j, y = h j the u faces run along e_j = h (s, 1) and the v
    # faces along e_i = h (1, 0): a uniform flow (U, V) writes u = (U - s V) / sqrt(1 + s^2) on every
    # u face (its component along the face's normal (1, -s) / sqrt(1 + s^2)) and v = V on every v
    # face. Its trajectories are x0 + (U, V) t, the arc length |(U, V)| t (closed forms); the grid is
    # affine, so every interpolant is exact and only the integrator's tolerance is left. (Taking u as
    # the velocity along the line between centres, u / h, moves them sin theta = 0.89 as fast.) With
    # the file's metrics, exact, the flux over the area is the same index velocity: NEMO's e1t = e1v
    # = h, e2t = e2u = h sqrt(1 + s^2), the area e1t e2t sin theta = h^2; MITgcm's the same lengths
    # (dxF, dxG; dyG) and its area rA = h^2 read as given, with dyF 4 % long (within the tolerance;
    # used only where rA or dyG is missing, so rA must be read for the closed form to hold).
    h, shear, n, flow = 1000.0, 0.5, 20, np.array([0.05, 0.03])
    x, y = sheared_grid(h, shear, n)
    u_normal = (flow[0] - shear * flow[1]) / math.sqrt(1 + shear**2)
    dataset = c_grid_dataset(lambda X, Y, T: u_normal + 0 * X + 0 * T, lambda X, Y, T: flow[1] + 0 * X + 0 * T,
                             x, y, np.arange(0.0, 4e5 + 1, 1e5))
    if metrics:
        names = {"NEMO": ("e1t", "e2t", "e2u", "e1v"), "MITgcm": ("dxF", "dyF", "dyG", "dxG")}[metrics]
        metres = {"units": "m"}
        slanted = h * math.sqrt(1 + shear**2)
        dataset = dataset.assign({names[0]: (("eta", "xi"), np.full((n, n), h), metres),
                                  names[1]: (("eta", "xi"), np.full((n, n), slanted), metres),
                                  names[2]: (("eta", "xi_u"), np.full((n, n - 1), slanted), metres),
                                  names[3]: (("eta_v", "xi"), np.full((n - 1, n), h), metres)})
        if metrics == "MITgcm":
            dataset["rA"] = (("eta", "xi"), np.full((n, n), h * h), {"units": "m^2"})
            dataset["dyF"] = dataset.dyF * 1.04
    path = write_dataset(dataset, tmp_path / "sheared.nc")
    system = make_system("sheared", {"velocity_data": {"path": str(path), **ENTRY}})
    assert ("rA" in system.faces.metrics) == (metrics == "MITgcm") and bool(system.faces.metrics) == bool(metrics)
    starts = system.states_from_engine(np.array([[3.0, 4.0], [5.5, 2.2], [2.1, 7.7]]))
    tau = 1e5  # about 6 cells
    result = compute_ld(system, starts, 1, LDSettings(tau=tau, p="arclength", **TIGHT), t0=1e5)
    # measured 3.6e-12 m of 5.8 km (rounding: the index velocity is constant), the arc length 1.1e-13 relative
    np.testing.assert_allclose(result.end_state, starts + flow * tau, rtol=0, atol=2e-11)
    np.testing.assert_allclose(result.ld, np.hypot(*flow) * tau, rtol=1e-12)


def test_a_dataset_in_memory_keeps_its_metrics(gyre_file):
    # the same data from memory and from the file: the metrics found by name in both, so the same
    # numbers reach the kernel and the end points agree bit for bit (an invariant)
    path, _ = gyre_file
    with xr.open_dataset(path) as dataset:
        memory = ldpipe.system(name="memory", velocity_data={"dataset": dataset.load(), **ENTRY})
    from_file = make_system("file", {"velocity_data": {"path": str(path), **ENTRY}})
    assert memory.grid_attributes() == from_file.grid_attributes()
    starts = from_file.states_from_engine(np.array([[6.3, 10.2]]))
    settings = LDSettings(tau=5e4, p=0.5, **TIGHT)
    np.testing.assert_array_equal(compute_ld(memory, starts, 1, settings, t0=1e5).end_state,
                                  compute_ld(from_file, starts, 1, settings, t0=1e5).end_state)
