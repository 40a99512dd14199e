"""Adaptive LD maps (ldpipe.core.maps.adaptive): where they integrate, how far they are from the full map,
what narrow features they find, determinism, tiles, the NHIM detection, the CLI."""

from __future__ import annotations

import numpy as np
import pytest

from ldpipe.core import nhim
from ldpipe.cli import main
from ldpipe.config import validate_config
from ldpipe.engine import LDSettings
from ldpipe.core.equilibria.potential import equilibrium_table
from ldpipe.io.datafile import open_stage_file
from ldpipe.core.maps.adaptive import RefineSettings, adaptive_ld_dataset, refine_band
from ldpipe.core.maps.grid import ld_grid_dataset
from ldpipe.core.sections import Section
from ldpipe.core.maps.assembly import compute_ld_map
from ldpipe.stages.ld import run_ld_gather, write_ld_map
from ldpipe.config.parameters import parameters_from_config
from ldpipe.systems import make_system
from support.closed_forms import WX, WY, harmonic_ld

# The linear saddle of tests/stages/test_nhim_orbits.py (its engine module is compiled there).
LAM, OMEGA = 1.5, 1.0
BOX = {"x": [-20.0, 20.0], "y": [-20.0, 20.0]}


def within_tolerance(adaptive, full, name: str, tolerance: float) -> np.ndarray:
    """|adaptive - full| / (the full map's value range over the allowed pixels), on the allowed pixels."""
    allowed = full.allowed.values
    values = full[name].values[allowed]
    return np.abs(adaptive[name].values[allowed] - values) / (values.max() - values.min()) <= tolerance


# --------------------------------------------------------------------------------------------
# Closed forms: the linear saddle's manifolds are lines; the oscillators' map is smooth.

@pytest.fixture(scope="module")
def linear_saddle():
    return make_system("linear_saddle", {
        "formula": "-lam**2*x**2/2 + w**2*y**2/2", "coordinates": ["x", "y"],
        "parameters": {"lam": LAM, "w": OMEGA},
    })


def test_refinement_hugs_the_linear_saddles_manifold_lines(linear_saddle):
    # Closed form: u = x + p_x / lam grows as e^{lam t}, s = x - p_x / lam decays, so forward
    # trajectories leave the region box by the face of sign(u) (W^s is the line p_x = -lam x) and
    # backward ones by sign(s) (W^u: p_x = lam x). The forward fate switches across W^s and nowhere
    # else, the backward fate across W^u and nowhere else; each direction is refined on its own, so
    # each mask must hug its own line.
    n, spacing = 129, 16
    section = Section(axes=("x", "px"), ranges=((-0.3, 0.3), (-0.3, 0.3)), shape=(n, n), fixed={"y": 0.2},
                      solve="py")
    settings = LDSettings(rtol=1e-8, atol=1e-8, tau=20.0, region_lower=(-1.0, -2.0), region_upper=(1.0, 2.0))
    refine = RefineSettings(tolerance=2e-3, coarse_spacing=spacing)
    full = ld_grid_dataset(linear_saddle, section, 0.5, settings)
    adaptive = adaptive_ld_dataset(linear_saddle, section, 0.5, settings, refine)
    x, px = np.meshgrid(full.x.values, full.px.values, indexing="ij")
    pixel = 0.6 / (n - 1)
    # Distance in pixels from each direction's switch line (|p_x -+ lam x| / sqrt(1 + lam^2)):
    # forward W^s (p_x = -lam x), backward W^u (p_x = lam x).
    lines = {"forward": np.abs(px + LAM * x) / np.hypot(1.0, LAM) / pixel,
             "backward": np.abs(px - LAM * x) / np.hypot(1.0, LAM) / pixel}
    for label, distance in lines.items():
        computed = adaptive[f"computed_{label}"].values
        # The fate switch is resolved to the pixel: every pixel within two pixels of the line is integrated.
        assert computed[distance < 2].all(), label
        # Away from the line the integrated pixels thin out: the LD's logarithmic cusp (the time to
        # leave the box grows as -ln|u| / lam) asks for smaller cells the closer they are. Measured
        # densities per band of distance (in pixels) 2-4, 4-8, 8-16, 16-32, beyond 2 s: forward
        # 0.997, 0.43, 0.19, 0.060, 0.021; backward 0.85, 0.37, 0.20, 0.058, 0.020; the first samples
        # alone being 1/64 (spacing s/2).
        bands = [(2, 4), (4, 8), (8, 16), (16, 2 * spacing), (2 * spacing, np.inf)]
        density = [computed[(distance >= lo) & (distance < hi)].mean() for lo, hi in bands]
        assert all(a >= b for a, b in zip(density, density[1:])), (label, density)
        assert density[-1] < 1 / 16, label  # at most one level below the first samples, far from the line
        # Every pixel not integrated is within the tolerance of the full map (accepted cells), and the
        # integrated ones are the full map's trajectories.
        name = f"ld_{label}"
        assert within_tolerance(adaptive, full, name, refine.tolerance).all(), name
        np.testing.assert_allclose(adaptive[name].values[computed], full[name].values[computed], rtol=1e-14)
        np.testing.assert_array_equal(adaptive[f"left_region_{label}"].values, full[f"left_region_{label}"].values)
    trajectories = {label: adaptive.attrs[f"refine_trajectories_{label}"] for label in lines}
    assert adaptive.attrs["refine_trajectories"] == sum(trajectories.values())
    assert adaptive.attrs["refine_trajectories"] < 2 * n * n / 2  # measured: 0.16 of the full map's


def test_a_smooth_map_needs_only_its_first_samples(oscillator):
    # The oscillators' LD is a closed form (support.closed_forms.harmonic_ld), smooth away from
    # x = p_x = 0 (outside this window). Its bilinear interpolant on the coarse cells is within a
    # third of the tolerance at every test point (checked below, on the closed form), so no cell is
    # subdivided: the map integrates exactly the corners and test points, the lattice of spacing s/2.
    n, spacing, tau, energy = 129, 8, 2.0, 1.0
    section = Section(axes=("x", "px"), ranges=((0.4, 0.8), (0.2, 0.6)), shape=(n, n), fixed={"y": 0.3}, solve="py")
    settings = LDSettings(rtol=1e-10, atol=1e-10, tau=tau)
    refine = RefineSettings(tolerance=5e-3, coarse_spacing=spacing)
    adaptive = adaptive_ld_dataset(oscillator, section, energy, settings, refine)
    x, px = np.meshgrid(adaptive.x.values, adaptive.px.values, indexing="ij")
    py = adaptive.py.values
    closed = {direction: np.array([[harmonic_ld(np.array([x[i, j], 0.3, direction * px[i, j], direction * py[i, j]]),
                                                (WX, WY), tau, 0.5) for j in range(n)] for i in range(n)])
              for direction in (1, -1)}  # backward in time: the forward LD of the reversed momenta
    half = spacing // 2
    for values in closed.values():
        spread = values.max() - values.min()
        for i0 in range(0, n - 1, spacing):
            for j0 in range(0, n - 1, spacing):
                c = values[[i0, i0 + spacing, i0, i0 + spacing], [j0, j0, j0 + spacing, j0 + spacing]]
                for a, b in ((0.5, 0), (0.5, 1), (0, 0.5), (1, 0.5), (0.5, 0.5)):
                    guess = (1 - a) * (1 - b) * c[0] + a * (1 - b) * c[1] + (1 - a) * b * c[2] + a * b * c[3]
                    exact = values[i0 + int(a * spacing), j0 + int(b * spacing)]
                    assert abs(exact - guess) < spread * refine.tolerance / 3
    for label in ("forward", "backward"):
        assert adaptive[f"computed_{label}"].values.sum() == ((n - 1) // half + 1) ** 2, label
        assert adaptive.attrs[f"refine_trajectories_{label}"] == ((n - 1) // half + 1) ** 2, label
    assert adaptive.attrs["refine_trajectories"] == 2 * ((n - 1) // half + 1) ** 2
    # The interpolated map is the closed form to the tolerance (the engine's LD is the closed form
    # to ~1e-9 at rtol 1e-10).
    for name, direction in (("ld_forward", 1), ("ld_backward", -1)):
        values = closed[direction]
        assert np.all(np.abs(adaptive[name].values - values) <= refine.tolerance * (values.max() - values.min()))


# --------------------------------------------------------------------------------------------
# A feature narrower than a coarse cell (the criterion alone, on synthetic fields: no engine).

def _band_map(shape, first: int, width: int):
    """A map whose fate is 1 on the columns first .. first + width - 1 and 0 elsewhere (values flat)."""
    def evaluate(i, j):
        inside = (j >= first) & (j < first + width)
        return {"ld_forward": np.ones(len(i)), "ld_backward": np.ones(len(i)), "fate": inside.astype(np.int64)}
    return evaluate


@pytest.mark.parametrize("spacing", [8, 16])
def test_a_fate_band_half_a_coarse_cell_wide_is_always_found(spacing):
    # Geometry: the corners and test points of the coarse cells form a lattice of spacing s/2, so
    # any band of s/2 columns holds a lattice column, at any offset: its cells are subdivided and
    # both edges of the band resolved to the pixel. A band one column narrower fits between two
    # lattice columns at the worst offset and is missed: the bound is sharp (hence the advice to
    # choose coarse_spacing at most twice the narrowest fate feature, in pixels).
    shape = (4 * spacing + 1, 4 * spacing + 1)
    allowed = np.ones(shape, dtype=bool)
    refine = RefineSettings(tolerance=1e-3, coarse_spacing=spacing)
    half = spacing // 2
    for first in range(1, 2 * spacing):
        band = refine_band(allowed, 0, shape, _band_map(shape, first, half), refine)
        edges = [first - 1, first, first + half - 1, first + half]
        assert band.computed[:, edges].all(), first
    missed = refine_band(allowed, 0, shape, _band_map(shape, 1, half - 1), refine)
    assert not missed.computed[:, 1:half].any()
    # With max_level 0 the coarse cells the band crosses are integrated at every pixel, the others
    # only at their corners and test points (the band of columns 3..3+s/2-1 crosses the first
    # column of cells, [0, s]).
    capped = refine_band(allowed, 0, shape, _band_map(shape, 3, half), RefineSettings(1e-3, spacing, max_level=0))
    assert capped.computed[:, : spacing + 1].all()
    assert capped.computed[:, spacing + 1 :].mean() < 0.25
    # An allowed region narrower than a cell (all sampled points forbidden) is found too: it is
    # known at every pixel without integrating.
    narrow = np.zeros(shape, dtype=bool)
    narrow[:, 1] = True
    band = refine_band(narrow, 0, shape, lambda i, j: {"ld_forward": np.ones(len(i)), "ld_backward": np.ones(len(i)),
                                                        "fate": np.zeros(len(i), dtype=np.int64)}, refine)
    assert band.computed[:, 1].all()


def test_small_cells_beside_a_fate_switch_are_accepted_on_their_centre():
    # Closed form: the fate switches between columns 4 and 5 (a straight boundary) and the value
    # i + 2 j is bilinear, so every interpolant is exact. Spacing 8: the coarse cell [0, 8] sees
    # both fates, its child [4, 8] too; of that child's children (2 pixels a side), [4, 6] holds the
    # switch and is integrated at every pixel, [6, 8] has one fate at its corners and is tested at
    # its centre (odd rows of column 7) alone: its edge midpoints (even rows of column 7, odd rows
    # of column 8) are filled, not integrated.
    shape = (33, 33)
    allowed = np.ones(shape, dtype=bool)

    def evaluate(i, j, bump=0.0, speck=0):
        value = i + 2.0 * j + bump * (j == 7) * (i % 2)
        fate = (j >= 5) + speck * (j == 7) * (i % 2)
        return {"ld_forward": value, "ld_backward": value, "flag": j >= 5, "fate": fate.astype(np.int64)}

    band = refine_band(allowed, 0, shape, evaluate, RefineSettings(tolerance=1e-3, coarse_spacing=8))
    i, j = np.indices(shape)
    assert band.computed[:, 4:7].all()
    assert band.computed[1::2, 7].all() and not band.computed[0::2, 7].any()
    assert not band.computed[1::2, 8].any()
    np.testing.assert_array_equal(band.fields["flag"], j >= 5)  # the fate, to the pixel
    np.testing.assert_allclose(band.fields["ld_forward"], i + 2.0 * j, rtol=0, atol=1e-12)
    # A centre off the corners' interpolant by more than the tolerance (a bump on the odd rows of
    # column 7; the value range on the lattice is 96) sends the cell to the full test: every pixel
    # of column 7 is integrated.
    # So does a centre of another fate than its corners (a one-pixel speck on those rows).
    for change in ({"bump": 1.0}, {"speck": 2}):
        changed = refine_band(allowed, 0, shape, lambda a, b: evaluate(a, b, **change),
                              RefineSettings(tolerance=1e-3, coarse_spacing=8))
        assert changed.computed[:, 7].all(), change


def _bumped(height: float, at: tuple[int, int], regressor_slope: float = 0.0, regressor=None):
    """A one-fate map whose value is i (bilinear: every interpolant exact), plus ``regressor_slope``
    times ``regressor`` and ``height`` at the pixel ``at`` alone: a test point off the interpolant
    by exactly ``height`` (closed form)."""
    def evaluate(i, j):
        value = i + height * ((i == at[0]) & (j == at[1]))
        if regressor is not None:
            value = value + regressor_slope * regressor[i, j]
        return {"ld_forward": value, "ld_backward": value, "fate": np.zeros(len(i), dtype=np.int64)}
    return evaluate


@pytest.mark.parametrize("factor, accepted", [(0.9, True), (1.1, False)])
def test_a_cell_is_accepted_just_inside_its_bound_and_split_just_outside(factor, accepted):
    # One coarse cell [0, 16]^2 (spacing 16): its corners hold 0 and 16 (value i), so the value range
    # on the lattice is 16 and the bound tolerance * 16. Its centre, a test point, is off the
    # bilinear interpolant by factor times that bound: at 0.9 the cell is accepted on its corners
    # and five test points (nine trajectories, the rest filled exactly), at 1.1 it is split and its
    # children tested (more trajectories). A bound applied twice as loose accepts both. An accepted
    # cell's four children are filled bilinearly from their corners, the centre among them: i plus
    # the bump times the hat (1 - |i - 8| / 8)(1 - |j - 8| / 8).
    shape, tolerance = (17, 17), 1e-2
    height = factor * tolerance * 16
    band = refine_band(np.ones(shape, dtype=bool), 0, shape, _bumped(height, (8, 8)),
                       RefineSettings(tolerance=tolerance, coarse_spacing=16))
    assert (int(band.computed.sum()) == 9) is accepted, int(band.computed.sum())
    if accepted:
        i, j = np.indices(shape)
        expected = i + height * (1 - np.abs(i - 8) / 8) * (1 - np.abs(j - 8) / 8)
        np.testing.assert_allclose(band.fields["ld_forward"], expected, rtol=0, atol=1e-12)  # measured 1.8e-15


@pytest.mark.parametrize("factor, accepted", [(0.9, True), (1.1, False)])
def test_a_small_cell_is_accepted_on_its_centre_just_inside_its_bound(factor, accepted):
    # One cell [0, 2]^2 (spacing 2), one fate at its corners: tested at its centre alone first. The
    # value range on the lattice is 2 (value i), the bound tolerance * 2; the centre off the
    # interpolant by 0.9 of it accepts the cell on five trajectories, by 1.1 sends it to the full
    # test (its four edge midpoints too: nine).
    shape, tolerance = (3, 3), 1e-2
    band = refine_band(np.ones(shape, dtype=bool), 0, shape, _bumped(factor * tolerance * 2, (1, 1)),
                       RefineSettings(tolerance=tolerance, coarse_spacing=2))
    assert int(band.computed.sum()) == (5 if accepted else 9)


def test_the_interpolant_carries_the_solved_coordinates_departure_from_bilinear():
    # Closed form: the value is i + 0.5 q with q = (i - 8)^2 the regressor (the solved coordinate,
    # known at every pixel): bilinear plus 0.5 times q's own departure from bilinear, which the
    # interpolant reproduces exactly (slope 0.5 fitted by least squares on the test points, where
    # the residuals then vanish). So the one coarse cell is accepted on nine trajectories and every
    # filled pixel is exact; without the slope term its residual at the centre is 32, far above
    # the bound (tolerance 1e-2 of the range 16), and the cell is split.
    shape = (17, 17)
    q = (np.indices(shape)[0] - 8.0) ** 2
    band = refine_band(np.ones(shape, dtype=bool), 0, shape, _bumped(0.0, (0, 0), 0.5, q),
                       RefineSettings(tolerance=1e-2, coarse_spacing=16), regressor=q)
    assert int(band.computed.sum()) == 9
    expected = np.indices(shape)[0] + 0.5 * q
    # measured: exact to 3.6e-15 (the fill's arithmetic)
    np.testing.assert_allclose(band.fields["ld_forward"], expected, rtol=0, atol=1e-12)


@pytest.mark.parametrize("factor, accepted", [(0.9, True), (1.1, False)])
def test_the_slope_is_carried_only_where_the_test_points_saw_the_regressors_bend(factor, accepted):
    # The value i + 0.5 q of the test above, q now (i - 8)^2 plus a spike at the pixel (4, 4), no
    # test point of the coarse cell. The test points saw q depart from bilinear by 64 at most (the
    # centre); the slope is trusted where the cell's largest departure is at most twice that, 128.
    # The spike sets that departure to factor * 128: at 0.9 the cell is accepted on its nine
    # trajectories and filled exactly, the spike's pixel too (the value follows q); at 1.1 it takes
    # no slope, fails its bound (residual 32 at the centre) and is split, the spike then a child's
    # test point (the slope is never carried to a bend sharper than the test points saw).
    shape = (17, 17)
    i = np.indices(shape)[0]
    q = (i - 8.0) ** 2
    q[4, 4] += 48.0 + factor * 128.0  # departure 16 + spike - 64
    band = refine_band(np.ones(shape, dtype=bool), 0, shape, _bumped(0.0, (0, 0), 0.5, q),
                       RefineSettings(tolerance=1e-2, coarse_spacing=16), regressor=q)
    assert (int(band.computed.sum()) == 9) is accepted
    assert band.computed[4, 4] is not accepted
    np.testing.assert_allclose(band.fields["ld_forward"], i + 0.5 * q, rtol=0, atol=1e-12)  # measured 2.8e-14


# --------------------------------------------------------------------------------------------
# The paper's system: error bound, determinism, tiles, NHIM detection, the CLI.

def small_config(points: int = 129, tiles: int = 1, refine: dict | None = None):
    ld_map = {
        "system": "barbanis_2dof", "saddle_near": [5.5, -7.0],
        "section": {"axes": [{"name": "x", "range": [4.8, 6.0], "points": points},
                             {"name": "px", "range": [-0.6, 0.6], "points": points}],
                    "fixed": {"y": -7.0}, "solve": "py"},
        "energy": {"excess": 0.125}, "tau": 20.0, "time": "variable", "region": {"x": [4.5, 6.5], "y": [-8.5, -5.5]},
        "integrator": {"scheme": "dop853", "rtol": 1e-8, "atol": 1e-8}, "tiles": tiles,
        "refine": refine if refine is not None else {"tolerance": 2e-3, "coarse_spacing": 16},
    }
    return validate_config({"systems": {"barbanis_2dof": {"builtin": "barbanis_2dof"}}, "ld_maps": {"m": ld_map}})


@pytest.fixture(scope="module")
def equilibria(barbanis):
    return equilibrium_table(barbanis, BOX)


@pytest.fixture(scope="module")
def panel(equilibria):
    """A Fig. 4-like panel at 129 x 129, adaptive and full (the same parameters without refine)."""
    parameters = parameters_from_config(small_config(), "ld", "m")
    adaptive = compute_ld_map(parameters, equilibria, show_progress=False)
    full = compute_ld_map({k: v for k, v in parameters.items() if k != "refine"}, equilibria, show_progress=False)
    return parameters, adaptive, full


def test_the_adaptive_map_is_the_full_map_within_its_tolerance(panel):
    parameters, adaptive, full = panel
    tolerance = parameters["refine"]["tolerance"]
    # The file: the full map's variables and shape, plus each direction's mask and the settings.
    assert set(adaptive.data_vars) == set(full.data_vars) | {"computed_forward", "computed_backward"}
    assert all(adaptive[name].shape == full[name].shape for name in full.data_vars)
    assert adaptive.attrs["refine_tolerance"] == tolerance and adaptive.attrs["refine_coarse_spacing"] == 16
    for label in ("forward", "backward"):  # each direction's integrations include its computed pixels
        assert adaptive.attrs[f"refine_trajectories_{label}"] >= adaptive[f"computed_{label}"].values.sum(), label
    assert adaptive.attrs["refine_trajectories"] == (adaptive.attrs["refine_trajectories_forward"]
                                                     + adaptive.attrs["refine_trajectories_backward"])
    # The required bound: at least 99.9 % of the pixels within the tolerance of the full map; and no
    # pixel far off (measured: the worst at half the tolerance).
    for name in ("ld_forward", "ld_backward"):
        assert within_tolerance(adaptive, full, name, tolerance).mean() >= 0.999, name
        assert within_tolerance(adaptive, full, name, 2 * tolerance).all(), name
    # Fates are never interpolated across a switch: the flags equal the full map's everywhere.
    for name in ("escaped_forward", "escaped_backward", "left_region_forward", "left_region_backward",
                 "failed_forward", "failed_backward", "allowed"):
        np.testing.assert_array_equal(adaptive[name].values, full[name].values, err_msg=name)
    for label in ("forward", "backward"):  # each direction's integrated pixels are the full map's
        computed = adaptive[f"computed_{label}"].values
        for name in (f"steps_{label}", f"exit_time_{label}"):
            np.testing.assert_array_equal(adaptive[name].values[computed], full[name].values[computed], err_msg=name)


def test_nhim_detection_on_the_adaptive_map_is_the_full_maps(panel):
    # The detection reads the LD ridges, where the map is integrated pixel by pixel, so it picks the
    # same grid point as on the full map; the refinement below the grid starts from that point and
    # is the same computation.
    _, adaptive, full = panel
    axes = (full.x.values, full.px.values)
    found = [nhim.detect_nhim_cell(d.ld_forward.values, d.ld_backward.values, d.allowed.values, axes)
             for d in (full, adaptive)]
    assert found[0].index == found[1].index
    np.testing.assert_array_equal(found[0].point, found[1].point)


def test_reruns_and_tiles_give_the_same_bits(tmp_path, equilibria):
    parameters = parameters_from_config(small_config(points=129), "ld", "m")
    whole = compute_ld_map(parameters, equilibria, show_progress=False)
    again = compute_ld_map(parameters, equilibria, show_progress=False)
    paths = []
    for tile in range(3):
        part = compute_ld_map(parameters, equilibria, tile=tile, tiles=3, show_progress=False)
        paths.append(write_ld_map(part, parameters, tmp_path / f"tile-{tile}.nc", tile_file=True))
    gathered = open_stage_file(run_ld_gather(tiles=paths, output=tmp_path / "m.nc"), stage="ld_grid")
    for name in whole.data_vars:
        np.testing.assert_array_equal(again[name].values, whole[name].values, err_msg=name)
        np.testing.assert_array_equal(gathered[name].values, whole[name].values, err_msg=name)
    # Each tile integrates the whole map's lattice for the value range, and the cells its band reaches.
    for name in ("refine_trajectories", "refine_trajectories_forward", "refine_trajectories_backward"):
        assert gathered.attrs[name] >= whole.attrs[name], name


def test_the_cli_makes_an_adaptive_map(tmp_path):
    output = tmp_path / "slice.nc"
    assert main(["ld", "--system", "barbanis_2dof", "--axis", "x=4.8:6.0:33", "--axis", "px=-0.6:0.6:33",
                 "--fixed", "y=-7.0", "--solve", "py", "--excess-energy", "0.125", "--tau", "5", "--time", "variable",
                 "--region", "x=4.5:6.5", "--region", "y=-8.5:-5.5", "--saddle-near", "5.5,-7",
                 "--refine-tolerance", "0.004", "--coarse-spacing", "8", "--quiet", "-o", str(output)]) == 0
    data = open_stage_file(output, stage="ld_grid")
    assert data.attrs["refine_tolerance"] == 0.004 and data.attrs["refine_coarse_spacing"] == 8
    for label in ("forward", "backward"):
        assert 0 < data[f"computed_{label}"].values.sum() < data.allowed.values.sum(), label
