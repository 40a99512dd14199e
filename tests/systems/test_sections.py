"""Isoenergetic sections: allowed regions and solved momenta against closed forms; specs resolved into sections."""

import numpy as np
import pytest

from ldpipe.core.equilibria.potential import equilibrium_table, select_saddle
from ldpipe.errors import ConfigError
from ldpipe.core.sections import Section, section_states
from ldpipe.systems import make_system


def test_uxpx_allowed_disc_and_solved_momentum(barbanis):
    # On y = 0 the Barbanis potential is x^2/2 (wx = 1), so p_y^2 = 2E - x^2 - p_x^2: the
    # allowed region is the disc x^2 + p_x^2 <= 2E (closed form).
    energy = 15.0
    section = Section(axes=("x", "px"), ranges=((-6, 6), (-6, 6)), shape=(61, 41), fixed={"y": 0.0}, solve="py")
    states, allowed, solved = section_states(barbanis, section, energy)
    x, px = np.meshgrid(*section.axis_values(), indexing="ij")
    radicand = 2 * energy - x**2 - px**2
    np.testing.assert_array_equal(allowed, radicand >= 0)
    np.testing.assert_allclose(solved[allowed], np.sqrt(radicand[allowed]), rtol=1e-14)
    assert np.all(solved[~allowed] == 0)
    assert len(states) == allowed.sum()
    # Every state lies on the energy surface (invariant), with y = 0 and p_y > 0.
    energies = np.array([barbanis.energy(s) for s in states])
    np.testing.assert_allclose(energies, energy, rtol=0, atol=1e-12)
    assert np.all(states[:, 1] == 0) and np.all(states[:, 3] >= 0)


def test_negative_sign_and_rows(barbanis):
    section = Section(axes=("x", "px"), ranges=((-1, 1), (-1, 1)), shape=(10, 5), fixed={"y": -7.0}, solve="py", sign=-1)
    full_states, full_allowed, _ = section_states(barbanis, section, 15.25)
    top_states, top_allowed, _ = section_states(barbanis, section, 15.25, rows=slice(0, 4))
    bottom_states, bottom_allowed, _ = section_states(barbanis, section, 15.25, rows=slice(4, 10))
    np.testing.assert_array_equal(np.vstack([top_allowed, bottom_allowed]), full_allowed)
    np.testing.assert_array_equal(np.vstack([top_states, bottom_states]), full_states)
    assert np.all(full_states[:, 3] <= 0)


def test_3dof_uxpx_band(barbanis_contopoulos):
    """With y, z at the saddle's values the 3 DoF potential does not depend on x
    (eps y_e + eta z_e = wx2/2 makes the x^2 terms cancel), so U_xpx^+ (p_y = 0) is allowed
    exactly where p_x^2 <= 2 (E - E_c): a band (closed form)."""
    x_squared = 0.9 * 1.6 * 0.4 / (2 * (0.08**2 * 0.4 + 0.01**2 * 1.6))
    y_e, z_e = 0.08 * x_squared / 1.6, 0.01 * x_squared / 0.4
    e_c = 0.9 * 0.9 * 1.6 * 0.4 / (8 * (0.08**2 * 0.4 + 0.01**2 * 1.6))
    energy = 24.0
    section = Section(
        axes=("x", "px"), ranges=((9, 12), (-0.7, 0.7)), shape=(31, 141),
        fixed={"y": y_e, "z": z_e, "py": 0.0}, solve="pz",
    )
    _, allowed, solved = section_states(barbanis_contopoulos, section, energy)
    px = section.axis_values()[1]
    band = px**2 <= 2 * (energy - e_c) * (1 + 1e-12)
    assert np.all(allowed == band[None, :])
    np.testing.assert_allclose(solved[:, band], np.sqrt(np.maximum(2 * (energy - e_c) - px[band] ** 2, 0))[None, :] * np.ones((31, 1)), atol=1e-6)


def test_forbidden_everywhere_gives_no_states(barbanis):
    section = Section(axes=("x", "px"), ranges=((-1, 1), (-1, 1)), shape=(5, 5), fixed={"y": 0.0}, solve="py")
    states, allowed, solved = section_states(barbanis, section, -1.0)  # below the minimum V = 0
    assert states.shape == (0, 4) and not allowed.any() and np.all(solved == 0)


@pytest.mark.parametrize(
    "kwargs, words",
    [
        ({"fixed": {"y": 0.0}, "solve": "x"}, ["'section.root'", "solving the position 'x'"]),
        ({"fixed": {}, "solve": "py"}, ["exactly once", "missing ['y']"]),
        ({"fixed": {"y": 0.0, "z": 1.0}, "solve": "py"}, ["not phase coordinates", "z"]),
        ({"fixed": {"px": 0.0}, "solve": "py"}, ["exactly once"]),
    ],
)
def test_bad_sections_rejected(barbanis, kwargs, words):
    section = Section(axes=("x", "px"), ranges=((0, 1), (0, 1)), shape=(2, 2), **kwargs)
    with pytest.raises(ConfigError) as info:
        section.check(barbanis)
    for word in words:
        assert word in str(info.value)


# ----------------------------------------------------------------------------------------------
# Section.from_spec: a configuration spec resolved once into a Section

WX, WY, DELTA = 1.0, 1.1, -0.11  # the built-in Barbanis 2 DoF parameters
# Closed form (paper sec. model_prob_2dof): saddles at (-wy^2/(2 delta), +-wx wy/(sqrt(2) |delta|)) = (5.5, +-7.0711),
# E_c = wx^2 wy^4/(8 delta^2) = 15.125.
X_SADDLE, Y_SADDLE, E_C = -WY**2 / (2 * DELTA), abs(WX * WY / (np.sqrt(2) * DELTA)), WX**2 * WY**4 / (8 * DELTA**2)


def spec(fixed, *, solve="py", sign=1, axes=(("x", (4.5, 6.5), 21), ("px", (-1.0, 1.0), 17))):
    return {"axes": [{"name": n, "range": list(r), "points": p} for n, r, p in axes], "fixed": fixed,
            "solve": solve, "sign": sign}


@pytest.fixture(scope="module")
def barbanis_equilibria(barbanis):
    return equilibrium_table(barbanis, {"x": [-20.0, 20.0], "y": [-20.0, 20.0]})


@pytest.mark.parametrize("near, y_sign", [([5.5, 7.0], 1), ([5.0, -6.0], -1)])
def test_from_spec_saddle_is_the_closed_form_saddle_and_states_lie_on_the_energy_surface(
        barbanis, barbanis_equilibria, near, y_sign):
    saddle, critical_energy = select_saddle(barbanis_equilibria, near)
    section = Section.from_spec(spec({"y": "saddle"}, sign=-1), barbanis, saddle, key="ld_maps.m.section")
    # The 'saddle' value is the closed-form saddle's y (the nearest of the two to `near`).
    assert section.fixed["y"] == pytest.approx(y_sign * Y_SADDLE, rel=0, abs=1e-12)
    assert critical_energy == pytest.approx(E_C, rel=0, abs=1e-12)
    assert (section.axes, section.shape, section.ranges, section.solve, section.sign) == (
        ("x", "px"), (21, 17), ((4.5, 6.5), (-1.0, 1.0)), "py", -1)
    # Invariant: every allowed state has H = E to round-off, with the solved momentum of the asked sign.
    energy = critical_energy + 0.5
    states, allowed, _ = section_states(barbanis, section, energy)
    assert allowed.sum() > 100
    np.testing.assert_allclose([barbanis.energy(s) for s in states], energy, rtol=0, atol=1e-12)
    assert np.all(states[:, 1] == section.fixed["y"]) and np.all(states[:, 3] <= 0)


def test_from_spec_momentum_at_the_saddle_is_zero_and_numbers_pass_through(barbanis):
    # Equilibria have p = 0 (closed form), so a momentum fixed at 'saddle' is 0; numbers are kept as floats.
    saddle = np.array([X_SADDLE, -Y_SADDLE])
    section = Section.from_spec(spec({"px": "saddle"}, axes=(("x", (4, 7), 5), ("y", (-8, -6), 5))), barbanis, saddle)
    assert section.fixed == {"px": 0.0}
    plain = Section.from_spec(spec({"y": 0}), barbanis)
    # Round trip: the spec of a plain section gives the Section built directly.
    assert plain == Section(axes=("x", "px"), ranges=((4.5, 6.5), (-1.0, 1.0)), shape=(21, 17), fixed={"y": 0.0},
                            solve="py", sign=1)
    assert type(plain.fixed["y"]) is float
    # A spec without 'fixed' or 'sign' takes no fixed coordinates and sign +1 (the schema's defaults).
    minimal = {"axes": spec({})["axes"], "solve": "py"}
    with pytest.raises(ConfigError, match="missing \\['y'\\]"):
        Section.from_spec(minimal, barbanis)
    assert Section.from_spec({**minimal, "fixed": {"y": 1.5}}, barbanis).sign == 1


@pytest.mark.parametrize(
    "bad, saddle, words",
    [
        (spec({"y": "sadle"}), None, ["'ld_maps.m.section.fixed.y'", "a number or 'saddle'", "'sadle'"]),
        (spec({"y": "saddle"}), None, ["'ld_maps.m.section.fixed.y'", "needs a selected index-1 saddle"]),
        (spec({"w": "saddle"}), [5.5, 7.0], ["'ld_maps.m.section.fixed.w'", "not a phase coordinate"]),
        (spec({"y": [1.0]}), None, ["'ld_maps.m.section.fixed.y'", "a number or 'saddle'"]),
        ({"axes": spec({})["axes"], "fixed": {"y": 0.0}}, None, ["'ld_maps.m.section'", "lacks ['solve']"]),
        ({**spec({"y": 0.0}), "axes": spec({})["axes"][:1]}, None, ["'ld_maps.m.section.axes'", "two axes"]),
        ({**spec({"y": 0.0}), "axes": [spec({})["axes"][0], {"name": "px", "range": [0, 1]}]}, None,
         ["'ld_maps.m.section.axes.1'", "lacks ['points']"]),
        (spec({"y": 0.0}, sign=2), None, ["'ld_maps.m.section.sign'"]),
        (spec({"y": 0.0}, axes=(("x", (1, 0), 3), ("px", (0, 1), 3))), None, ["'ld_maps.m.section.axes.x'", "low < high"]),
        (spec({"y": 0.0}, solve="x", axes=(("y", (0, 1), 3), ("px", (0, 1), 3))), None,
         ["'ld_maps.m.section.root'", "largest, smallest or {nearest: VALUE}"]),
    ],
)
def test_from_spec_names_the_offending_key(barbanis, bad, saddle, words):
    with pytest.raises(ConfigError) as info:
        Section.from_spec(bad, barbanis, None if saddle is None else np.asarray(saddle), key="ld_maps.m.section")
    for word in words:
        assert word in str(info.value)


# ----------------------------------------------------------------------------------------------
# A position solved from the energy (``solve: x``, ``root``)
HENON_HEILES = {"formula": "(x**2 + y**2)/2 + x**2*y - y**3/3", "coordinates": ["x", "y"]}
HH_ENERGY = 0.125


@pytest.fixture(scope="module")
def henon_heiles():
    return make_system("henon_heiles", HENON_HEILES)


def henon_heiles_slice(**extra):
    """ldds' tutorial slice: axes y, p_y, p_x = 0, x solved from the energy."""
    axes = [{"name": "y", "range": [-0.7, 0.9], "points": 81}, {"name": "py", "range": [-0.6, 0.6], "points": 61}]
    return {"axes": axes, "fixed": {"px": 0.0}, "solve": "x", **extra}


def henon_heiles_x_squared(y, py, energy):
    """Closed form: with p_x = 0, H = E is quadratic in x, x^2 (1 + 2 y) = 2 E - p_y^2 - y^2 + 2 y^3 / 3."""
    return (2.0 * energy - py**2 - y**2 + 2.0 * y**3 / 3.0) / (1.0 + 2.0 * y)


def henon_heiles_energy(states):
    x, y, px, py = states.T
    return 0.5 * (px**2 + py**2) + 0.5 * (x**2 + y**2) + x**2 * y - y**3 / 3.0


@pytest.mark.parametrize("root, sign", [("largest", 1.0), ("smallest", -1.0), ({"nearest": -5.0}, -1.0)])
def test_solved_position_meets_the_closed_form(henon_heiles, root, sign):
    # Closed form (henon_heiles_x_squared): the roots are +-sqrt(x^2); largest takes +, smallest
    # and the one nearest -5 take -. Points with x^2 < 0 have no root: not allowed, solved 0.
    # Invariant: H(state) = E. (Points with |x^2| < 1e-12 sit on the boundary: rounding decides.)
    section = Section.from_spec(henon_heiles_slice(root=root), henon_heiles)
    states, allowed, solved = section_states(henon_heiles, section, HH_ENERGY)
    y, py = np.meshgrid(*section.axis_values(), indexing="ij")
    x_squared = henon_heiles_x_squared(y, py, HH_ENERGY)
    clear = np.abs(x_squared) > 1e-12
    np.testing.assert_array_equal(allowed[clear], x_squared[clear] > 0)
    assert 0 < allowed.sum() < allowed.size
    # compared as x^2 (its square root near the boundary would magnify the rounding of either form)
    np.testing.assert_allclose(solved[allowed] ** 2, x_squared[allowed], rtol=1e-13, atol=1e-15)
    assert np.all(sign * solved[allowed & clear] > 0)
    assert np.all(solved[~allowed] == 0.0)
    np.testing.assert_allclose(henon_heiles_energy(states), HH_ENERGY, rtol=0, atol=1e-12)
    np.testing.assert_array_equal(states[:, 2], 0.0)


def test_solved_position_by_scan_meets_the_closed_form(henon_heiles):
    # The scan (sign changes on 257 samples of search, then bisection) against the closed form,
    # where the largest root lies inside search = [0, 2] and away from its ends.
    section = Section.from_spec(henon_heiles_slice(root="largest", search=[0.0, 2.0]), henon_heiles)
    states, allowed, solved = section_states(henon_heiles, section, HH_ENERGY)
    y, py = np.meshgrid(*section.axis_values(), indexing="ij")
    x_squared = henon_heiles_x_squared(y, py, HH_ENERGY)
    inside = (x_squared > 1e-6) & (x_squared < 1.9**2)
    assert inside.sum() > 1000 and allowed[inside].all()
    np.testing.assert_allclose(solved[inside], np.sqrt(x_squared[inside]), rtol=1e-13)
    np.testing.assert_array_equal(allowed[x_squared < 0], False)
    np.testing.assert_allclose(henon_heiles_energy(states), HH_ENERGY, rtol=0, atol=1e-12)


@pytest.mark.parametrize("root", ["largest", "smallest", {"nearest": 0.5}])
def test_solved_position_of_a_morse_potential(root):
    # Not a polynomial, so sought on search. Closed form: D (1 - exp(-a x))^2 = W, W = E - |p|^2/2
    # - y^2/2, has the roots x = -ln(1 -+ sqrt(W / D)) / a (only the + one for W >= D).
    system = make_system("morse_section", {"formula": "2*(1 - exp(-0.8*x))**2 + y**2/2", "coordinates": ["x", "y"]})
    spec = {"axes": [{"name": "y", "range": [-1.5, 1.5], "points": 31}, {"name": "px", "range": [-1.5, 1.5], "points": 31}],
            "fixed": {"py": 0.0}, "solve": "x", "root": root, "search": [-3.0, 20.0]}
    section = Section.from_spec(spec, system)
    energy = 1.5
    states, allowed, solved = section_states(system, section, energy)
    y, px = np.meshgrid(*section.axis_values(), indexing="ij")
    w = energy - 0.5 * px**2 - 0.5 * y**2
    r = np.sqrt(np.clip(w / 2.0, 0.0, None))
    with np.errstate(divide="ignore", invalid="ignore"):
        outer, inner = -np.log(1.0 - r) / 0.8, -np.log(1.0 + r) / 0.8
    expected = {"largest": outer, "smallest": inner}.get(root if isinstance(root, str) else "", None)
    if expected is None:  # nearest 0.5: the outer root when it is the nearer one
        expected = np.where(np.abs(outer - 0.5) < np.abs(inner - 0.5), outer, inner)
    clear = w > 1e-6
    np.testing.assert_array_equal(allowed[clear], True)
    np.testing.assert_array_equal(allowed[w < 0], False)
    np.testing.assert_allclose(solved[clear], expected[clear], rtol=1e-12, atol=1e-14)
    x, y_, px_, py_ = states.T
    energies = 0.5 * (px_**2 + py_**2) + 2.0 * (1.0 - np.exp(-0.8 * x)) ** 2 + 0.5 * y_**2
    np.testing.assert_allclose(energies, energy, rtol=0, atol=1e-12)


@pytest.mark.parametrize(
    "extra, words",
    [
        ({}, ["'ld_maps.m.section.root'", "largest, smallest or {nearest: VALUE}"]),
        ({"root": "nearest"}, ["'ld_maps.m.section.root'", "{nearest: VALUE}"]),
        ({"root": {"nearest": "zero"}}, ["'ld_maps.m.section.root'", "expected largest, smallest"]),
        ({"root": "biggest"}, ["'ld_maps.m.section.root'", "'biggest'"]),
        ({"root": "largest", "search": [1.0]}, ["'ld_maps.m.section.search'", "[low, high]"]),
        ({"root": "largest", "search": [1.0, 0.0]}, ["'ld_maps.m.section.search'", "low < high"]),
        ({"root": "largest", "solve": "w"}, ["'ld_maps.m.section'", "not phase coordinates", "'w'"]),
    ],
)
def test_bad_position_specs_name_the_key(henon_heiles, extra, words):
    with pytest.raises(ConfigError) as info:
        Section.from_spec(henon_heiles_slice(**extra), henon_heiles, key="ld_maps.m.section")
    for word in words:
        assert word in str(info.value)


def test_root_for_a_momentum_and_search_for_a_cubic_name_the_key(henon_heiles):
    momentum = {**henon_heiles_slice(root="largest"), "fixed": {"x": 0.0}, "solve": "px"}
    with pytest.raises(ConfigError, match=r"'ld_maps.m.section.root'.*a momentum takes 'sign'"):
        Section.from_spec(momentum, henon_heiles, key="ld_maps.m.section")
    cubic = {"axes": [{"name": "x", "range": [0, 1], "points": 3}, {"name": "py", "range": [0, 1], "points": 3}],
             "fixed": {"px": 0.0}, "solve": "y", "root": "largest"}  # V is cubic in y
    with pytest.raises(ConfigError, match=r"'ld_maps.m.section.search'.*not a quadratic polynomial in 'y'"):
        Section.from_spec(cubic, henon_heiles, key="ld_maps.m.section")
    assert Section.from_spec({**cubic, "search": [-1.0, 2.0]}, henon_heiles).search == (-1.0, 2.0)
