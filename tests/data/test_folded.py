"""Velocity data on a tripolar global grid (ldpipe.data.tripolar), joined across its seam, its north
fold and the south pole, against closed forms.

- Solid-body rotations (test_poles.py's fields: about the axis through (lon 0, lat 0), through
  (lon 0, lat 30) and about the polar axis), sampled at the nodes of tripolar grids of 5 degrees
  whose regular part reaches the south pole (a row at it, or half a spacing from it) and whose cap
  (a Murray bipolar cap north of 60 or 62.5 N) ends on the north fold: a point is after t the start
  rotated by omega t about the axis (closed form, Rodrigues' formula), having run
  omega R sin(angle to the axis) t (its arc length, closed form); M_1 along the circles through
  the poles is quad's integral of the closed form. The starts' circles cross both poles and the
  fold, or go round the North Pole inside the cap, or along the rows across the seam; they keep
  10 degrees or more from the cap's own poles (lon 0 and 180 on the fold latitude), where the
  grid's cells shrink to nothing. The rotation is an isometry: its FTLE is 0 (closed form).
- A differential rotation (each circle about the equatorial axis at its own rate, quadratic in
  the position: a solid-body rotation is linear, which the interpolation of positions and
  velocities from the same nodes reproduces whichever nodes they are) on every layout.
- The tilted differential rotation's error falls as the grid refines (36, 72, 144 columns) at
  second order or better (the cubics' third, less where the cap meets the regular part with a
  kink in the rows' spacing).
- Land round the cap's own poles stops a circle that runs into it, on its circle; a grid whose
  first row is not at the south pole is an edge there (the stop time in closed form).
- The guide's ORCA block, as written, on such a file with NEMO's names and grid components.
- Refused by name: a fold whose mirrored nodes do not match, halo columns, uneven times, a grid of 2-D coordinates that is a
  regular grid reaching the north pole, a grid starting near the south pole but not at it or half a
  spacing from it.
"""

import math

import numpy as np
import pytest
import yaml
from scipy.integrate import quad
from support.workflow import documented_yaml

from ldpipe.config import validate_config
from ldpipe.config.parameters import parameters_from_config
from ldpipe.core.maps.assembly import compute_ld_map
from ldpipe.data.curvilinear import curvilinear_dataset, write_dataset
from ldpipe.data.tripolar import tripolar_dataset, tripolar_grid
from ldpipe.engine import LDSettings, compute_ld
from ldpipe.errors import ConfigError
from ldpipe.systems import make_system
from ldpipe.systems.velocity_data.folded import folded_grid

pytestmark = pytest.mark.compiles  # the folded grid's engine, loaded by this file's tests alone
TIGHT = {"rtol": 1e-10, "atol": 1e-10}
RADIUS, OMEGA, DAY = 6.371e6, 2 * math.pi / (4 * 86400.0), 86400.0  # a turn in 4 days
#: Tripolar grids of 5 degrees: the regular part from the south pole (a row at it) to the cap at
#: 60 N, or from half a spacing from it to the cap at 62.5 N, the last row on the fold; or from
#: the pole to 60 N, the fold half a row above the last row but one, which the last mirrors
#: (NEMO's F-point pivot).
GRIDS = {"pole_row": {"fold_latitude": 60.0, "south": -90.0}, "half_spacing": {"fold_latitude": 62.5, "south": -87.5},
         "mirrored_row": {"fold_latitude": 60.0, "south": -90.0, "last_row": "mirror"},
         "t_pivot": {"fold_latitude": 60.0, "south": -90.0, "pivot": "T"},
         "t_pivot_mirrored": {"fold_latitude": 60.0, "south": -90.0, "pivot": "T", "last_row": "mirror"}}


def grid_options(columns=72, fold_latitude=60.0, south=-90.0, last_row="fold", pivot="F"):
    spacing = 360.0 / columns
    return {"columns": columns, "spacing": spacing, "fold_latitude": fold_latitude,
            "cap_rows": round((90.0 - fold_latitude) / spacing), "south": south, "last_row": last_row, "pivot": pivot}


def axis(tilt):
    return np.array([math.cos(math.radians(tilt)), 0.0, math.sin(math.radians(tilt))])


def unit(points):
    lam, phi = np.radians(points[..., 0]), np.radians(points[..., 1])
    return np.stack([np.cos(phi) * np.cos(lam), np.cos(phi) * np.sin(lam), np.sin(phi)], axis=-1)


def rotation(tilt):
    """omega a x X about ``axis(tilt)`` as (u, v), east and north (test_poles.py's)."""
    sin_a, cos_a = math.sin(math.radians(tilt)), math.cos(math.radians(tilt))

    def field(lon, lat, t):
        lam, phi = np.radians(lon), np.radians(lat)
        return (OMEGA * RADIUS * (sin_a * np.cos(phi) - cos_a * np.sin(phi) * np.cos(lam)) + 0 * t,
                OMEGA * RADIUS * cos_a * np.sin(lam) + 0 * lat + 0 * t)
    return field


def rotated(starts, days, tilt):
    """The starts rotated by OMEGA * days about ``axis(tilt)`` (Rodrigues' formula)."""
    angle, a, r = OMEGA * days * DAY, axis(tilt), unit(starts)
    r = r * math.cos(angle) + np.cross(a, r) * math.sin(angle) + np.outer(r @ a, a) * (1 - math.cos(angle))
    return np.column_stack([np.degrees(np.arctan2(r[:, 1], r[:, 0])),
                            np.degrees(np.arctan2(r[:, 2], np.hypot(r[:, 0], r[:, 1])))])


def great_circle_degrees(a, b):
    return np.degrees(2 * np.arcsin(0.5 * np.linalg.norm(unit(a) - unit(b), axis=1)))


#: Starts of each rotation. 0: circles x = const: through both poles and the fold (x = 0, and
#: 0.017), through the cap beside the pole (x = -0.15, 0.17), south of the cap (x = -0.72), round
#: the axis (x = 0.98). 90: along rows (the equator across the seam, 45 S), round the pole inside
#: the cap across the fold (75, 80, 88 N), round the south pole (89 S). 30: through the North Pole
#: (60 degrees from the axis), the South Pole (120), and the cap beside them (50, 70 degrees).
STARTS = {0.0: np.array([[90.0, 0.0], [89.0, 0.0], [100.0, -30.0], [200.0, 40.0], [10.0, 5.0], [0.0, 80.0],
                         [-90.0, 70.0]]),
          90.0: np.array([[178.0, 0.0], [-150.0, -45.0], [30.0, 75.0], [100.0, 80.0], [-10.0, 88.0], [45.0, -89.0]]),
          30.0: np.array([[0.0, -30.0], [180.0, 30.0], [0.0, -20.0], [0.0, -40.0], [90.0, 60.0]])}


def m_1(start, days, tilt):
    """M_1 along the closed-form circle: the integral of |u| + |v| (m/s times days), by quad."""
    field = rotation(tilt)

    def integrand(t):
        lon, lat = rotated(start[None], t, tilt)[0]
        u, v = field(lon, lat, 0.0)
        return abs(u) + abs(v)
    return quad(integrand, 0.0, days, limit=400, epsabs=1e-10, epsrel=1e-12)[0]


def write(path, tilt, **options):
    write_dataset(tripolar_dataset(rotation(tilt), np.arange(0.0, 4.01, 0.5), **grid_options(**options)), path)
    return path


def folded_system(path, name="globe"):
    return make_system(name, {"velocity_data": {"path": str(path), "coordinates": "sphere"}})


#: Each grid with each rotation of the two that cross its fold and seam.
CASES = [(grid, tilt) for grid in sorted(GRIDS) for tilt in (0.0, 90.0)]


@pytest.fixture(scope="module")
def grids(tmp_path_factory):
    folder = tmp_path_factory.mktemp("tripolar")
    return {(name, tilt): write(folder / f"{name}_{tilt:g}.nc", tilt, **GRIDS[name])
            for name, tilt in CASES}


def run(system, tilt, direction=1, t0=0.4, days=3.2):
    starts = STARTS[tilt]
    arc = compute_ld(system, starts, direction, LDSettings(tau=days, p="arclength", **TIGHT), t0=t0)
    speed = OMEGA * RADIUS * np.sqrt(np.clip(1.0 - (unit(starts) @ axis(tilt)) ** 2, 0.0, None))
    errors = great_circle_degrees(arc.end_state, rotated(starts, direction * days, tilt))
    return arc, errors, arc.ld / (speed * days * DAY / 1000.0) - 1.0


@pytest.mark.parametrize(("grid", "tilt"), CASES)
def test_rotations_cross_the_poles_the_fold_and_the_seam(grids, grid, tilt):
    system = folded_system(grids[grid, tilt])
    assert system.engine_name == "velocity_data_folded" and system.grid.south == (1 if grid == "half_spacing" else 0)
    rows = len(tripolar_grid(**grid_options(**GRIDS[grid]))[0])  # a mirrored row is not read
    fold = {"mirrored_row": rows - 1.5, "t_pivot_mirrored": rows - 2.0}.get(grid, rows - 1.0)
    assert system.grid.fold == fold and system.grid.pivot == (72 if grid.startswith("t_pivot") else 71)
    for direction, t0 in ((1, 0.4), (-1, 3.6)):
        arc, errors, arc_error = run(system, tilt, direction, t0)
        assert not arc.failed.any() and (arc.time == 3.2).all()
        flags = system.stop_flags(arc.end_state, t0, t0 + direction * 3.2)
        assert not flags["left_data"].any() and not flags["on_land"].any()
        # measured: <= 3.1e-3 degrees (cubic convolution on the 5 degree grid; largest 1 degree from
        # the South Pole and where the circles run through the cap)
        assert errors.max() < 1e-2, errors
        # measured: relative error <= 1.2e-5 about the equatorial axis, 6.1e-4 about the polar one (its
        # circle of radius 1 degree round the South Pole, 5 degree cells)
        assert np.abs(arc_error).max() < (2e-5 if tilt == 0.0 else 2e-3), arc_error
        assert (arc.end_state[:, 0] >= -180.0).all() and (arc.end_state[:, 0] < 180.0).all()  # the grid's convention
    if tilt == 0.0:
        starts = STARTS[tilt][:3]
        m1 = compute_ld(system, starts, 1, LDSettings(tau=3.2, p=1.0, **TIGHT), t0=0.4)
        # M_1 from u and v in the local basis, which turns fast at the pole (quad of the closed
        # form along the circle): measured relative error <= 1.7e-5
        np.testing.assert_allclose(m1.ld, [m_1(start, 3.2, tilt) for start in starts], rtol=4e-5)


def differential(lon, lat, t):
    """omega (1 + a.X) a x X about the equatorial axis a: each circle x = c turns at its own rate
    omega (1 + c), quadratic in X (a solid-body rotation, linear in X, is interpolated exactly from
    any nodes as long as the positions come from the same ones: this one is not)."""
    u, v = rotation(0.0)(lon, lat, t)
    factor = 1.0 + np.cos(np.radians(lat)) * np.cos(np.radians(lon))
    return u * factor, v * factor


@pytest.mark.parametrize("grid", sorted(GRIDS))
def test_a_differential_rotation_across_the_fold(tmp_path, grid):
    # Each start turns by omega (1 + c) t about the axis, c = a.X its circle's (closed form), and
    # runs omega (1 + c) R sqrt(1 - c^2) t.
    path = tmp_path / f"{grid}.nc"
    write_dataset(tripolar_dataset(differential, np.arange(0.0, 4.01, 0.5), **grid_options(**GRIDS[grid])), path)
    system = folded_system(path)
    starts = STARTS[0.0]
    c = unit(starts) @ axis(0.0)
    arc = compute_ld(system, starts, 1, LDSettings(tau=3.2, p="arclength", **TIGHT), t0=0.4)
    assert not arc.failed.any() and (arc.time == 3.2).all()
    expected = np.vstack([rotated(start[None], 3.2 * (1.0 + k), 0.0) for start, k in zip(starts, c)])
    speed = OMEGA * RADIUS * (1.0 + c) * np.sqrt(1.0 - c ** 2)
    # measured: <= 6.6e-3 degrees and 3.8e-5 relative (the T pivots, whose columns collapse onto the
    # cap's poles; 3.5e-3 to 5.0e-3 degrees on the others)
    assert great_circle_degrees(arc.end_state, expected).max() < 2e-2
    np.testing.assert_allclose(arc.ld, speed * 3.2 * DAY / 1000.0, rtol=1e-4)


def test_a_rotation_speeding_up_in_time(tmp_path):
    # omega (1 + t / 4) (t in days) about the equatorial axis: a point turns by omega (t + t^2 / 8)
    # days (closed form); the time interpolant, cubic, is exact for the linear growth.
    steady = rotation(0.0)

    def field(lon, lat, t):
        u, v = steady(lon, lat, t)
        return u * (1.0 + t / 4.0), v * (1.0 + t / 4.0)
    path = tmp_path / "speeding.nc"
    write_dataset(tripolar_dataset(field, np.arange(0.0, 4.01, 0.5), **grid_options()), path)
    system = folded_system(path)
    starts = STARTS[0.0]
    for direction, t0, t1 in ((1, 0.4, 3.6), (-1, 3.6, 0.4)):
        arc = compute_ld(system, starts, direction, LDSettings(tau=3.2, p="arclength", **TIGHT), t0=t0)
        turned = (t1 + t1 ** 2 / 8.0) - (t0 + t0 ** 2 / 8.0)  # days of the steady rotation
        errors = great_circle_degrees(arc.end_state, rotated(starts, turned, 0.0))
        assert errors.max() < 1e-2, errors  # measured 3.1e-3 degrees (the steady rotation's 1.8e-3, sped up)


def test_a_tilted_differential_rotation_converges_in_the_cap(tmp_path):
    # omega (1 + a.X) a x X about the tilted axis: each circle c = a.X turns by omega (1 + c) t
    # (closed form), through the cap and across the fold and the poles; quadratic in X, so the
    # interpolation's error shows (a rigid rotation's would not, but for the positions' projection).
    a = axis(30.0)

    def field(lon, lat, t):
        u, v = rotation(30.0)(lon, lat, t)
        lam, phi = np.radians(lon), np.radians(lat)
        factor = 1.0 + a[0] * np.cos(phi) * np.cos(lam) + a[2] * np.sin(phi)
        return u * factor, v * factor
    starts = STARTS[30.0]
    c = unit(starts) @ a
    expected = np.vstack([rotated(start[None], 3.2 * (1.0 + k), 30.0) for start, k in zip(starts, c)])
    speed = OMEGA * RADIUS * (1.0 + c) * np.sqrt(1.0 - c ** 2)
    errors = {}
    for columns in (36, 72, 144):
        path = tmp_path / f"tilted_{columns}.nc"
        write_dataset(tripolar_dataset(field, np.arange(0.0, 4.01, 0.5), **grid_options(columns)), path)
        arc = compute_ld(folded_system(path), starts, 1, LDSettings(tau=3.2, p="arclength", **TIGHT), t0=0.4)
        assert not arc.failed.any() and (arc.time == 3.2).all()
        errors[columns] = np.array([great_circle_degrees(arc.end_state, expected).max(),
                                    np.abs(arc.ld / (speed * 3.2 * DAY / 1000.0) - 1.0).max()])
    # measured: positions 5.0e-2, 7.1e-3, 1.8e-3 degrees, arc lengths 2.2e-4, 1.7e-5, 3.2e-6
    # relative: each halving of the spacing divides them by 3.9 to 12.7, second order or better (the
    # cubics' third, less where the cap meets the regular part with a kink in the rows' spacing);
    # a first-order error (e.g. the velocity's grid angle off by a cell) would divide them by 2
    assert np.all(errors[36] / errors[72] > 3.0) and np.all(errors[72] / errors[144] > 3.0), errors
    assert errors[144][0] < 5e-3


def test_the_rotation_has_zero_ftle_across_the_pole(grids):
    # A map round the North Pole inside the cap whose circles cross the pole and the fold within the
    # time; the rotation's FTLE is 0 (closed form) but for the differences' error.
    system = folded_system(grids["half_spacing", 0.0])
    section = {"axes": [{"name": "lon", "range": [80.0, 100.0], "points": 5},
                        {"name": "lat", "range": [80.0, 89.5], "points": 4}]}
    entry = {"system": "globe", "t0": 1.0, "tau": 0.5, "p": "arclength", "ftle": True,
             "integrator": {"rtol": 1e-10, "atol": 1e-10}, "section": section}
    config = validate_config({"systems": {"globe": system.spec}, "ld_maps": {"pole": entry}})
    dataset = compute_ld_map(parameters_from_config(config, "ld", "pole"), None, show_progress=False)
    for label in ("forward", "backward"):
        assert dataset[f"ftle_defined_{label}"].values.all()
        # measured: |FTLE| <= 1.04e-3 per day (the differences' error over 2.5 degrees)
        assert np.abs(dataset[f"ftle_{label}"].values).max() < 5e-3, label
        ends = np.column_stack([dataset[f"end_lon_{label}"].values.ravel(), dataset[f"end_lat_{label}"].values.ravel()])
        lon, lat = np.meshgrid(dataset.lon.values, dataset.lat.values, indexing="ij")
        expected = rotated(np.column_stack([lon.ravel(), lat.ravel()]), 0.5 if label == "forward" else -0.5, 0.0)
        assert great_circle_degrees(ends, expected).max() < 2e-3  # measured 5.6e-4
    assert (np.abs(dataset.end_lon_forward.values) > 90.0).any()  # across the pole: on the far side


@pytest.mark.parametrize("grid", ["pole_row", "t_pivot"])
def test_the_rows_beyond_the_fold_continue_the_caps_map(grids, grid):
    # The cap is the bipolar map w = i a cot((sigma + i tau) / 2) of the North Pole's stereographic
    # plane (ldpipe.data.tripolar), its rows sigma = pi/2 .. pi (the fold); continued past pi, its
    # rows beyond the fold are the same map at sigma = pi + d pi / (2 rows) (closed form). The
    # window's nodes there (read in the kernel's buffer, positions after the velocities) must be
    # those points: column i continued as the fold pairs it (n - 1 - i, or n - i for a T pivot).
    system = folded_system(grids[grid, 0.0])
    window = system.data_window(1.0, 2.0)
    header, folded = window.buffer[:24], system.grid
    rows, n = int(header[1]), int(header[2])
    positions = window.buffer[int(header[13]):int(header[14])].reshape(rows + 2, n + 3, 3)
    options = grid_options(**GRIDS[grid])
    lon = folded.lon[0]
    a, cap_rows = math.tan(math.radians(90.0 - options["fold_latitude"]) / 2.0), options["cap_rows"]
    for d in (1, 2, 3):
        sigma = math.pi + d * 0.5 * math.pi / cap_rows
        upper = np.where(lon > 0.0, lon, lon + 180.0)
        poles = np.isclose(np.sin(np.radians(lon)), 0.0, atol=1e-12)
        tau = (2.0 * np.arctan(1j * np.exp(-1j * np.radians(np.where(poles, 90.0, upper))))).imag
        w = np.where(lon > 0.0, 1.0, -1.0) * 1j * a / np.tan((sigma + 1j * tau) / 2.0)
        w[poles] = np.where(np.cos(np.radians(lon[poles])) > 0.0, a, -a)
        expected = unit(np.column_stack([np.degrees(np.angle(w)), 90.0 - 2.0 * np.degrees(np.arctan(np.abs(w)))]))
        row = int(folded.fold) + d + folded.first_row + 1  # the buffer's row: the window's padded
        np.testing.assert_allclose(positions[row, 1:n + 1], expected, atol=1e-12)


def test_newtons_first_guess_in_the_cap_is_a_node_near_the_point():
    # The lookup table of the cap's stereographic plane gives each point of the cap a node near it
    # (the nearest to its table cell's centre): at most the cell's half-diagonal plus a node's
    # reach, here under 5 degrees (a table of 64 cells across the cap's 30 degrees); a table of the
    # wrong hemisphere would give nodes on the cap's edge, tens of degrees away.
    lon, lat = tripolar_grid(**grid_options())

    class Source:
        grid_coordinates, label = ("nav_lon", "nav_lat"), "tripolar"
    grid = folded_grid(Source(), lon, lat)
    table, half = grid.lookup_table()
    rng = np.random.default_rng(7)
    points = np.column_stack([rng.uniform(-180.0, 180.0, 400), rng.uniform(61.0, 90.0, 400)])
    xyz = unit(points)
    w = xyz[:, :2] / (1.0 + xyz[:, 2:])
    cells = np.clip(((w + half) / (2.0 * half) * table.shape[0]).astype(int), 0, table.shape[0] - 1)
    i, j = table[cells[:, 1], cells[:, 0]].astype(int).T
    guesses = np.column_stack([lon[j, i], lat[j, i]])
    assert great_circle_degrees(points, guesses).max() < 5.0  # measured 3.5 degrees


def refused(path, dataset):
    write_dataset(dataset, path)
    return folded_system(path)


def test_folds_and_poles_the_grid_cannot_join_are_refused(tmp_path):
    field, times = rotation(0.0), np.arange(0.0, 2.01)
    torn = tripolar_dataset(field, times, **grid_options(36))
    lon = torn.nav_lon.values.copy()
    lon[-1, 3] += 0.5  # column 3's fold node moved off column 32's
    torn = torn.assign_coords(nav_lon=(("y", "x"), lon, torn.nav_lon.attrs))
    # the two nodes' distance (degrees of arc): the chord of half a degree of longitude at their latitude
    apart = math.degrees(2 * math.sin(math.radians(0.25)) * math.cos(math.radians(torn.nav_lat.values[-1, 3])))
    with pytest.raises(ConfigError, match=r"\('nav_lon', 'nav_lat'\) goes all round the sphere, but its last row does "
                                          rf"not fold onto itself: its nodes of columns 3 and 32 are {apart:.4g} degrees"):
        refused(tmp_path / "torn.nc", torn)
    halo = torn.isel(x=[35] + list(range(36)) + [0])  # NEMO's halo: the last column first, the first last
    with pytest.raises(ConfigError, match=r"repeats its first two columns as its last two \(a model's halo columns\): "
                                          r"drop its first and last column"):
        refused(tmp_path / "halo.nc", halo)
    lon, lat = np.meshgrid(np.arange(0.0, 359.0, 10.0), np.arange(-90.0, 90.1, 10.0))
    regular = curvilinear_dataset(field, lon, lat, times, sphere=True, time_units="days since 2000-01-01")
    with pytest.raises(ConfigError, match=r"\('lon_rho', 'lat_rho'\) is a regular longitude/latitude grid reaching "
                                          r"the north pole.*give its 1-D longitudes and latitudes"):
        refused(tmp_path / "regular.nc", regular)
    uneven = tripolar_dataset(field, np.array([0.0, 0.5, 1.5, 2.0]), **grid_options(36))
    with pytest.raises(ConfigError, match=r"the times of 'time' are unevenly spaced; a tripolar global grid is read "
                                          r"at evenly spaced times"):
        refused(tmp_path / "uneven.nc", uneven)
    near = tripolar_dataset(field, times, **grid_options(36, fold_latitude=61.0, south=-88.0))
    assert near.nav_lat.values[0, 0] == -89.0  # 15 rows of 10 degrees below 61 N
    with pytest.raises(ConfigError, match=r"starts 1 degrees from the south pole, less than its spacing 10 but neither"):
        refused(tmp_path / "near.nc", near)


def test_the_orca_entry_reads_a_tripolar_file_with_nemos_names(tmp_path, monkeypatch):
    # The guide's NEMO ORCA block, as written: u, v along the grid's i and j at the T points (turned
    # by the generator's own angle, from its cap's map; the system turns them back by the nodes'),
    # NEMO's names and its F-point pivot (the last row mirroring the one below). The equatorial rotation's circles through the poles and the fold end where the
    # closed form puts them.
    monkeypatch.chdir(tmp_path)
    dataset = tripolar_dataset(rotation(0.0), np.arange(0.0, 4.01, 0.5), components="grid",
                               **grid_options(last_row="mirror"))
    write_dataset(dataset.rename(u="uo", v="vo", time="time_counter"), "orca_1d_0001.nc")
    entry = yaml.safe_load(documented_yaml("path: orca_1d_*.nc"))["systems"]["orca"]["velocity_data"]
    system = make_system("orca", {"velocity_data": entry})
    arc, errors, arc_error = run(system, 0.0)
    assert not arc.failed.any() and (arc.time == 3.2).all()
    # measured: as with east and north components (<= 2.7e-3 degrees, 9.5e-6 relative)
    assert errors.max() < 6e-3 and np.abs(arc_error).max() < 2e-5, (errors, arc_error)


def test_land_at_the_caps_poles_and_the_southern_edge_stop_trajectories(tmp_path):
    # Land on the nodes within 10 degrees of the cap's poles (lon 0 and 180 on 60 N, where models
    # put it) and the grid's first row at 75 S (an edge, no pole). About the equatorial axis the
    # circle x = 0.5 (from lon 60 on the equator) runs north into the cap's pole at lon 0 after a
    # quarter turn: it stops entering a cell with a land corner, 10 degrees from that pole or up to a
    # cell's diagonal (7.1 degrees at 50 N) more, on its circle. The circle through both poles (from
    # lon 90) crosses the North Pole, runs down the meridian -90 and leaves the data at 75 S, 255
    # degrees on (closed form); the circle x = 0.98 runs on, unflagged.
    dataset = tripolar_dataset(rotation(0.0), np.arange(0.0, 4.01, 0.5), **grid_options(south=-75.0))
    poles = unit(np.array([[0.0, 60.0], [180.0, 60.0]]))
    nodes = unit(np.stack([dataset.nav_lon.values, dataset.nav_lat.values], axis=-1))
    land = (np.degrees(np.arccos(np.clip(nodes @ poles.T, -1.0, 1.0))) < 10.0).any(axis=-1)
    dataset = dataset.assign(u=dataset.u.where(~land), v=dataset.v.where(~land))
    write_dataset(dataset, tmp_path / "land.nc")
    system = folded_system(tmp_path / "land.nc")
    starts = np.array([[60.0, 0.0], [90.0, 0.0], [10.0, 5.0]])
    arc = compute_ld(system, starts, 1, LDSettings(tau=3.2, p="arclength", **TIGHT), t0=0.4)
    flags = system.stop_flags(arc.end_state, 0.4, 3.6)
    assert flags["on_land"].tolist() == [True, False, False] and flags["left_data"].tolist() == [False, True, False]
    # each stopped where its circle is at the time it moved (closed form), the arc length that time's
    errors = great_circle_degrees(arc.end_state, np.vstack([rotated(start[None], time, 0.0)
                                                            for start, time in zip(starts, arc.time)]))
    assert errors.max() < 1e-2, errors  # measured 3.7e-3 degrees, as the circles' own errors
    distance = great_circle_degrees(arc.end_state[:1], np.array([[0.0, 60.0]]))[0]
    assert 10.0 <= distance <= 17.1, distance  # measured 12.0 degrees
    # measured: on 75 S within 5e-8 degrees (the kernel stops it just past the row), on the meridian
    # -90 to rounding; the time 2e-5 days late (the interpolation's 1.8e-3 degrees along the circle)
    np.testing.assert_allclose(arc.end_state[1], [-90.0, -75.0], atol=1e-6)
    np.testing.assert_allclose(arc.time[1:], [255.0 / 90.0, 3.2], rtol=5e-5)
