"""Backward LD fields from the forward ones by a reversing symmetry (ldpipe.core.maps.symmetry).

The identity phi_-t(z) = S phi_t(S z) is checked against the direct backward integration (an
independent computation of the same fields); detection against the symmetries read off the
potentials by hand.
"""

import numpy as np
import pytest
import xarray as xr

from ldpipe.config import validate_config
from ldpipe.core.equilibria.potential import equilibrium_table
from ldpipe.engine import LDSettings
from ldpipe.errors import ConfigError
from ldpipe.core.maps.grid import ld_grid_dataset
from ldpipe.core.maps.symmetry import ReversingSymmetry, map_mirror, mirror_mismatch, reversing_symmetries
from ldpipe.core.sections import Section
from ldpipe.core.maps.assembly import compute_ld_map, note_mirrored_tiles
from ldpipe.stages.ld import run_ld_gather, write_ld_map
from ldpipe.config.parameters import parameters_from_config
from ldpipe.systems import make_system
from support.barbanis import E_C
from support.henon_heiles import HENON_HEILES

BOX = {"x": [-20.0, 20.0], "y": [-20.0, 20.0]}
#: Fig. 3's section U_xpx (y = 0, p_y > 0 solved) on a small grid: 40 x values, and 49 p_x values
#: whose linspace is mirror-symmetric bit for bit (step 0.25, exact); 40 p_x values miss their
#: images by 2 ulp (1.8e-15, as Fig. 3's 1500), within the default tolerance.
FIG3_AXES = ({"name": "x", "range": [-6.0, 6.0], "points": 40}, {"name": "px", "range": [-6.0, 6.0], "points": 49})
#: Relative difference allowed between the mirrored and the directly integrated backward LD (and
#: energy error). The forward integration of S z is, operation for operation, the backward
#: integration of z with signs flipped, so they agree to the bit but for the last bit of a rare LD
#: that depends on the other trajectories of its engine block (ldpipe.core.maps.grid's docstring): measured
#: 0 on this grid, and 1 ulp (2.2e-16 relative) at 9 of 514,750 pixels of a Fig. 3 tile at tau 50
#: (benchmarks/ld_symmetry.md). About 4 ulp:
LD_RTOL = 1e-15
#: The default tolerance of a mirrored axis on [-6, 6]: 4 machine epsilons of its scale 6
#: (closed form, ldpipe.core.maps.symmetry's docstring).
TOLERANCE = 4 * np.finfo(float).eps * 6.0
#: A p_x grid that misses its mirror image by 1e-9 (its sum v[::-1] + v is -1e-9: negative, so a
#: comparison without abs would take it), far beyond the tolerance.
SKEWED = (-6.0 - 1e-9, 6.0)


def fig3_section(points=49, y=0.0, px=(-6.0, 6.0)):
    return Section(axes=("x", "px"), ranges=((-6.0, 6.0), px), shape=(40, points), fixed={"y": y},
                   solve="py", sign=1)


def test_barbanis_symmetries_are_time_reversal_and_y_reflection(barbanis):
    # V = x^2/2 + wy^2 y^2/2 + delta x y^2 is even in y and (delta != 0) not in x: s = (1, 1)
    # (time reversal, every natural Hamiltonian) and s = (1, -1); x -> -x flips delta x y^2.
    assert reversing_symmetries(barbanis) == [ReversingSymmetry((1, 1)), ReversingSymmetry((1, -1))]
    mirror, reason = map_mirror(barbanis, fig3_section())
    # On y = 0 with p_y > 0 solved, time reversal flips p_y's sign; S = (x, -y, -px, py) keeps it.
    assert reason == "" and mirror.symmetry.signs == (1, -1) and mirror.mirrored == (False, True)
    assert mirror.description == "(x, y, px, py) -> (x, -y, -px, py)"


def test_henon_heiles_symmetries_and_masses():
    # V = (x^2 + y^2)/2 + x^2 y - y^3/3 is even in x alone: s = (1, 1) and (-1, 1).
    hh = make_system("henon_heiles", dict(HENON_HEILES))
    assert reversing_symmetries(hh) == [ReversingSymmetry((1, 1)), ReversingSymmetry((-1, 1))]
    # Diagonal masses keep both; a kinetic matrix coupling x and y breaks x -> -x (M^-1_xy s_x s_y != M^-1_xy).
    diagonal = make_system("hh_masses", {**HENON_HEILES, "masses": {"x": 2.0, "y": 3.0}})
    assert reversing_symmetries(diagonal) == [ReversingSymmetry((1, 1)), ReversingSymmetry((-1, 1))]
    coupled = make_system("hh_coupled", {**HENON_HEILES, "mass_matrix": [[2.0, 0.5], [0.5, 3.0]]})
    assert reversing_symmetries(coupled) == [ReversingSymmetry((1, 1))]
    # ldds' slice (axes y, p_y; p_x = 0; x solved, the largest root): x -> -x would take the other
    # root, so only time reversal maps it onto itself, mirroring p_y (a grid of step 0.125, exact).
    section = Section(axes=("y", "py"), ranges=((-0.45, 0.8), (-0.5, 0.5)), shape=(11, 9), fixed={"px": 0.0},
                      solve="x", root="largest")
    mirror, _ = map_mirror(hh, section)
    assert mirror.symmetry.signs == (1, 1) and mirror.mirrored == (False, True)


def test_sections_the_symmetry_does_not_map_onto_themselves(barbanis):
    # y = 0.5 is not mapped onto itself by y -> -y; a p_x grid 1e-9 off its image is not mirror-symmetric.
    for section, words in ((fig3_section(y=0.5), "fixed at 0.5"), (fig3_section(px=SKEWED), "not mirror-symmetric")):
        mirror, reason = map_mirror(barbanis, section)
        assert mirror is None and words in reason, reason
    # A mirror along the first axis (tiles split it) is not taken.
    swapped = Section(axes=("px", "x"), ranges=((-6.0, 6.0), (-6.0, 6.0)), shape=(49, 40), fixed={"y": 0.0},
                      solve="py", sign=1)
    mirror, reason = map_mirror(barbanis, swapped)
    assert mirror is None and "first axis" in reason


def test_mirrored_backward_equals_the_integrated_backward(barbanis):
    """Identity phi_-t(z) = S phi_t(S z): the backward fields taken from the forward ones at the
    mirrored pixel against the same fields integrated backward (the independent computation)."""
    section = fig3_section()
    mirror, _ = map_mirror(barbanis, section)
    settings = LDSettings(tau=5.0)
    direct = ld_grid_dataset(barbanis, section, E_C, settings)
    mirrored = ld_grid_dataset(barbanis, section, E_C, settings, mirror=mirror)
    assert mirrored.attrs["reversing_symmetry"] == "(x, y, px, py) -> (x, -y, -px, py)"
    # the tolerance used (closed form) and the mismatch found: 0, a step of 0.25 is exact
    assert mirrored.attrs["reversing_symmetry_tolerance"] == TOLERANCE
    assert mirrored.attrs["reversing_symmetry_mismatch"] == 0.0
    assert "reversing_symmetry" not in direct.attrs
    allowed = direct.allowed.values
    assert 0 < allowed.sum() < allowed.size
    for name in direct.data_vars:
        if not name.endswith("_backward") and name != "energy_error":  # the forward integration is the same
            np.testing.assert_array_equal(mirrored[name].values, direct[name].values, err_msg=name)
    np.testing.assert_allclose(mirrored.ld_backward.values, direct.ld_backward.values, rtol=LD_RTOL, atol=0)
    for name in ("exit_time", "escaped", "left_region", "failed", "steps"):
        np.testing.assert_array_equal(mirrored[f"{name}_backward"].values, direct[f"{name}_backward"].values,
                                      err_msg=name)
    # |H(end) - H(start)| of both directions: the same, since H(S z) = H(z) and the integrations agree
    np.testing.assert_allclose(mirrored.energy_error.values, direct.energy_error.values, rtol=LD_RTOL, atol=0)


def test_a_grid_a_few_ulp_off_its_image_is_mirrored_and_agrees_with_integration(barbanis):
    """linspace(-6, 6, 40) misses its mirror images by 2 ulp, like Fig. 3's 1500 points: mirrored,
    and its backward fields agree with the direct backward integration (the independent
    computation) far within what the integration achieves; a grid 1e-9 off is integrated both ways."""
    values = np.linspace(-6.0, 6.0, 40)
    assert 0 < mirror_mismatch(values) == np.max(np.abs(values[::-1] + values)) < TOLERANCE
    section = fig3_section(points=40)
    mirror, reason = map_mirror(barbanis, section)
    assert reason == "" and mirror.tolerance == TOLERANCE
    settings = LDSettings(tau=5.0)
    direct = ld_grid_dataset(barbanis, section, E_C, settings)
    mirrored = ld_grid_dataset(barbanis, section, E_C, settings, mirror=mirror)
    assert mirrored.attrs["reversing_symmetry_mismatch"] == mirror_mismatch(values)
    assert mirrored.attrs["reversing_symmetry_tolerance"] == TOLERANCE
    # Starts 2 ulp apart: measured 3.5e-14 relative on the LD, 5.2e-14 on |H(end) - H(start)|; the
    # integration's own error is 6.3e-7 relative (rtol 1e-8 against 1e-10) and energy errors reach 1.5e-7.
    np.testing.assert_allclose(mirrored.ld_backward.values, direct.ld_backward.values, rtol=2e-13, atol=0)
    np.testing.assert_allclose(mirrored.energy_error.values, direct.energy_error.values, rtol=0, atol=3e-13)
    for name in ("exit_time", "escaped", "failed", "steps"):  # measured equal
        np.testing.assert_array_equal(mirrored[f"{name}_backward"].values, direct[f"{name}_backward"].values,
                                      err_msg=name)
    # 1e-9 off: no mirror, unless a tolerance that large is asked for
    assert map_mirror(barbanis, fig3_section(points=40, px=SKEWED))[0] is None
    assert map_mirror(barbanis, fig3_section(points=40, px=SKEWED), tolerance=2e-9)[0].tolerance == 2e-9


def fig3_config(**entries):
    ld_map = {"system": "barbanis_2dof", "section": {"axes": [dict(a) for a in FIG3_AXES], "fixed": {"y": 0.0},
                                                     "solve": "py", "sign": 1},
              "energy": {"excess": 0.0}, "tau": 5.0, "time": "fixed", **entries}
    return validate_config({"systems": {"barbanis_2dof": {"builtin": "barbanis_2dof"}}, "ld_maps": {"m": ld_map}})


@pytest.fixture(scope="module")
def equilibria(barbanis):
    return equilibrium_table(barbanis, BOX)


def test_stage_mirrors_each_tile_and_the_key_turns_it_off(tmp_path, equilibria):
    parameters = parameters_from_config(fig3_config(tiles=2), "ld", "m")
    paths = [write_ld_map(compute_ld_map(parameters, equilibria, tile=t, tiles=2, show_progress=False), parameters,
                          tmp_path / f"tile-{t}.nc", tile_file=True) for t in range(2)]
    gathered = xr.load_dataset(run_ld_gather(tiles=paths, output=tmp_path / "m.nc"))
    assert gathered.attrs["reversing_symmetry"] == "(x, y, px, py) -> (x, -y, -px, py)"
    np.testing.assert_array_equal(gathered.ld_backward.values, gathered.ld_forward.values[:, ::-1])
    off = compute_ld_map(parameters_from_config(fig3_config(backward_by_symmetry=False), "ld", "m"), equilibria,
                         show_progress=False)
    assert "reversing_symmetry" not in off.attrs
    np.testing.assert_array_equal(off.ld_forward.values, gathered.ld_forward.values)
    np.testing.assert_allclose(gathered.ld_backward.values, off.ld_backward.values, rtol=LD_RTOL, atol=0)


def test_required_symmetry_that_does_not_hold_names_the_key(equilibria):
    config = fig3_config(backward_by_symmetry=True)
    config["ld_maps"]["m"]["section"]["fixed"]["y"] = 0.5
    with pytest.raises(ConfigError, match=r"ld_maps\.m\.backward_by_symmetry.*fixed at 0\.5"):
        compute_ld_map(parameters_from_config(config, "ld", "m"), equilibria, show_progress=False)
    # auto: the same map is integrated both ways
    config["ld_maps"]["m"]["backward_by_symmetry"] = "auto"
    dataset = compute_ld_map(parameters_from_config(config, "ld", "m"), equilibria, show_progress=False)
    assert "reversing_symmetry" not in dataset.attrs and dataset.ld_backward.values.any()


def test_a_variable_time_map_is_not_mirrored(equilibria):
    # The region box decides where a variable-time trajectory stops; only fixed-time maps are mirrored,
    # even where the section alone (y = 0, a symmetric p_x grid) would allow it.
    config = fig3_config(backward_by_symmetry=True, time="variable", region={"x": [-6.0, 6.0], "y": [-6.0, 6.0]})
    with pytest.raises(ConfigError, match=r"ld_maps\.m\.backward_by_symmetry.*variable-time"):
        compute_ld_map(parameters_from_config(config, "ld", "m"), equilibria, show_progress=False)


def test_grid_states_off_their_image_beyond_the_tolerance_are_not_mirrored(barbanis):
    # The mirror is used only where the image pixel holds S of the state to the tolerance (the
    # solved coordinate's rounding included): one p_y moved by 1 ulp keeps it, by 1e-9 refuses it;
    # -0 and 0 count as equal.
    section = fig3_section()
    mirror, _ = map_mirror(barbanis, section)
    x, px = np.meshgrid(*section.axis_values(), indexing="ij")
    py = np.sqrt(np.maximum(2 * E_C - px**2 - x**2, 0.0))  # a symmetric stand-in for the solved p_y
    allowed = py > 0
    states = np.stack([x, np.zeros_like(x), px, py], axis=-1)
    assert mirror.maps_grid(states, allowed)
    i, j = np.argwhere(allowed)[0]
    exact = states[i, j, 3]
    states[i, j, 3] = np.nextafter(exact, np.inf)
    assert mirror.maps_grid(states, allowed)
    for moved in (exact + 1e-9, exact - 1e-9):  # either way: |difference| against the tolerance
        states[i, j, 3] = moved
        assert not mirror.maps_grid(states, allowed)
    states[i, j, 3] = exact
    states[i, j, 2] -= 1e-12  # an axis coordinate: the tolerance itself (5.3e-15), not the solved one's
    assert not mirror.maps_grid(states, allowed)


def test_gathered_map_says_which_tiles_were_mirrored():
    attrs = {"reversing_symmetry": "(x, y, px, py) -> (x, -y, -px, py)", "backward_fields": "mirrored"}
    tiles = [xr.Dataset(attrs=dict(attrs)), xr.Dataset(), xr.Dataset(attrs=dict(attrs))]
    joined = xr.Dataset(attrs=dict(attrs))  # the first tile's attributes, as the gather copies them
    note_mirrored_tiles(joined, tiles)
    note = joined.attrs["backward_fields"]
    assert note.startswith("tiles [0, 2] of 3") and "integrated backward" in note
    whole = xr.Dataset(attrs=dict(attrs))
    note_mirrored_tiles(whole, [xr.Dataset(attrs=dict(attrs))] * 2)
    assert whole.attrs == attrs
