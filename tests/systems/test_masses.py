"""Systems with a kinetic matrix (``masses`` / ``mass_matrix``): configuration, linearization,
sections and periodic orbits against closed forms.

Expected values:

- linearization at a quadratic saddle V = q^T K q / 2: the eigenvalues of [[0, M^-1], [-K, 0]]
  are +-sqrt(-h) for the roots h of det(K - h M) = 0, a quadratic in h for 2 DoF written out
  below (det M h^2 - (K11 M22 + K22 M11 - 2 K12 M12) h + det K = 0);
- Lyapunov orbits of a quadratic saddle are its linear normal modes at every amplitude:
  period 2 pi / omega with omega^2 the positive root above, Floquet multipliers exp(+-lambda T);
- equal masses m on every coordinate are a rescaling of time (q(t) of H = |p|^2 / (2m) + V is
  q(sqrt(m) s) of the unit-mass system at the same energy): periods multiply by sqrt(m);
- solved momenta: the energy (invariant) and, for diagonal masses, p_s = sign sqrt(m_s (2 (E - V)
  - sum of the other p_i^2 / m_i)).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from ldpipe.config import validate_config
from ldpipe.core.equilibria.potential import linear_analysis
from ldpipe.errors import ConfigError
from ldpipe.core.orbits.periodic import CorrectorSettings, LyapunovFamily, floquet_multipliers, linearize_saddle
from ldpipe.core.sections import Section, section_states
from ldpipe.systems import make_system
from support.workflow import documented_yaml

# V = -a x^2 / 2 + b y^2 / 2 + c x y, a saddle at the origin (det K < 0), and a coupled M.
A, B, C = 1.0, 2.0, 0.3
K = np.array([[-A, C], [C, B]])
MASS = np.array([[2.0, 0.6], [0.6, 1.0]])
QUADRATIC = {"formula": "-a*x**2/2 + b*y**2/2 + c*x*y", "coordinates": ["x", "y"],
             "parameters": {"a": A, "b": B, "c": C}, "mass_matrix": MASS.tolist()}


def generalized_roots(k: np.ndarray, m: np.ndarray) -> np.ndarray:
    """The roots h of det(K - h M) = 0 for 2 x 2 matrices, ascending (the quadratic formula)."""
    qa = m[0, 0] * m[1, 1] - m[0, 1] ** 2
    qb = -(k[0, 0] * m[1, 1] + k[1, 1] * m[0, 0] - 2.0 * k[0, 1] * m[0, 1])
    qc = k[0, 0] * k[1, 1] - k[0, 1] ** 2
    root = math.sqrt(qb * qb - 4.0 * qa * qc)
    return np.sort([(-qb - root) / (2.0 * qa), (-qb + root) / (2.0 * qa)])


@pytest.fixture(scope="module")
def quadratic():
    return make_system("quadratic_saddle_coupled", QUADRATIC)


@pytest.mark.parametrize("extra,words", [
    ({"masses": {"x": 0.0}}, ["systems.s.masses.x", "> 0"]),
    ({"masses": {"x": -8}}, ["systems.s.masses.x", "> 0"]),
    ({"masses": {"z": 2.0}}, ["systems.s.masses.z", "not a coordinate"]),
    ({"masses": [8, 8]}, ["systems.s.masses", "mapping"]),
    ({"mass_matrix": [[1.0, 2.0], [2.0, 1.0]]}, ["systems.s.mass_matrix", "positive definite"]),
    ({"mass_matrix": [[1.0, 0.1], [0.2, 1.0]]}, ["systems.s.mass_matrix", "symmetric"]),
    ({"mass_matrix": [[1.0, 0.0]]}, ["systems.s.mass_matrix", "2 rows of 2"]),
    ({"masses": {"x": 2.0}, "mass_matrix": [[2.0, 0.0], [0.0, 1.0]]}, ["systems.s", "not both"]),
])
def test_bad_kinetic_matrices_name_the_key(extra, words):
    spec = {"formula": "x**2 + y**2", "coordinates": ["x", "y"], **extra}
    with pytest.raises(ConfigError) as info:
        make_system("s", spec)
    for word in words:
        assert word in str(info.value)


def test_config_validation_checks_the_kinetic_matrix():
    config = {"systems": {"s": {"builtin": "barbanis_2dof", "mass_matrix": [[1.0, 3.0], [3.0, 1.0]]}}}
    with pytest.raises(ConfigError, match="systems.s.mass_matrix.*positive definite"):
        validate_config(config)
    config = {"systems": {"s": {"builtin": "barbanis_2dof", "masses": {"x": -1.0}}}}
    with pytest.raises(ConfigError, match="systems.s.masses.x"):
        validate_config(config)
    valid = validate_config({"systems": {"s": {"builtin": "barbanis_2dof", "masses": {"x": 8.0, "y": 8.0}}}})
    assert valid["systems"]["s"]["masses"] == {"x": 8.0, "y": 8.0}


def test_hamiltonian_of_a_kinetic_matrix(quadratic):
    # H = p^T M^-1 p / 2 + V, dq/dt = M^-1 p: checked against M^-1 from numpy's solve (independent
    # of the system's stored inverse) at a generic state.
    state = np.array([0.3, -0.7, 1.1, 0.4])
    q, p = state[:2], state[2:]
    velocity = np.linalg.solve(MASS, p)
    assert quadratic.energy(state) == pytest.approx(0.5 * p @ velocity + 0.5 * q @ K @ q, rel=1e-15)
    np.testing.assert_allclose(quadratic.vector_field(state), np.concatenate([velocity, -K @ q]), rtol=1e-14)
    assert quadratic.kinetic_attributes()["mass_matrix"] == "[[2.0, 0.6], [0.6, 1.0]]"


def test_linearization_eigenvalues_from_the_generalized_eigenproblem(quadratic):
    h = generalized_roots(K, MASS)
    assert h[0] < 0 < h[1]
    analysis = linear_analysis(quadratic, np.zeros(2))
    assert analysis.kind == "index-1 saddle"
    expected = [math.sqrt(-h[0]), -math.sqrt(-h[0]), 1j * math.sqrt(h[1]), -1j * math.sqrt(h[1])]
    np.testing.assert_allclose(analysis.eigenvalues, expected, rtol=1e-13, atol=1e-15)
    # every eigenvector is one of the Jacobian [[0, M^-1], [-K, 0]] (built here from numpy's inverse)
    jacobian = np.block([[np.zeros((2, 2)), np.linalg.inv(MASS)], [-K, np.zeros((2, 2))]])
    for value, vector in zip(analysis.eigenvalues, analysis.eigenvectors):
        np.testing.assert_allclose(jacobian @ vector, value * vector, atol=1e-13)


def test_lyapunov_orbit_of_a_quadratic_saddle_is_the_normal_mode(quadratic):
    h = generalized_roots(K, MASS)
    omega, rate = math.sqrt(h[1]), math.sqrt(-h[0])
    settings = CorrectorSettings(tolerance=1e-10, rtol=1e-13, atol=1e-13)
    saddle = linearize_saddle(quadratic, np.zeros(2))
    assert saddle.saddle_rate == pytest.approx(rate, rel=1e-13)
    assert saddle.omegas[0] == pytest.approx(omega, rel=1e-13)
    family = LyapunovFamily(quadratic, saddle, 0, settings)
    family.continue_to(0.5, initial_amplitude=1e-3, max_step=0.2, max_members=200)
    orbit = family.at_energy(0.5, energy_tolerance=1e-12)
    # linear dynamics: the period is 2 pi / omega at every amplitude (to the integration's accuracy)
    assert orbit.period == pytest.approx(2.0 * math.pi / omega, rel=1e-12)
    assert quadratic.energy(orbit.initial_state) == pytest.approx(0.5, abs=1e-12)
    assert orbit.closure_error < 1e-10
    multipliers, _ = floquet_multipliers(orbit.monodromy)
    largest = np.max(np.abs(multipliers))
    assert largest == pytest.approx(math.exp(rate * orbit.period), rel=1e-8)


def test_equal_masses_rescale_the_periods(barbanis):
    # H = |p|^2 / (2 m) + V: the unit-mass orbit at the same energy, traversed sqrt(m) times slower.
    m = 8.0
    massive = make_system("barbanis_equal_masses", {"builtin": "barbanis_2dof", "masses": {"x": m, "y": m}})
    settings = CorrectorSettings(tolerance=1e-10, rtol=1e-13, atol=1e-13)
    position = np.array([5.5, -math.sqrt(50.0)])
    periods = []
    for system in (barbanis, massive):
        saddle = linearize_saddle(system, position)
        family = LyapunovFamily(system, saddle, 0, settings)
        ec = saddle.critical_energy
        family.continue_to(ec + 0.125, initial_amplitude=1e-4, max_step=0.1, max_members=500)
        periods.append(family.at_energy(ec + 0.125, energy_tolerance=1e-12).period)
    assert periods[1] == pytest.approx(math.sqrt(m) * periods[0], rel=1e-11)
    unit, heavy = linearize_saddle(barbanis, position), linearize_saddle(massive, position)
    assert heavy.saddle_rate == pytest.approx(unit.saddle_rate / math.sqrt(m), rel=1e-13)


def test_solved_momentum_with_diagonal_masses():
    mx, my = 8.0, 0.5
    system = make_system("oscillators_masses", {"formula": "x**2/2 + y**2", "coordinates": ["x", "y"],
                                                "masses": {"x": mx, "y": my}})
    energy = 3.0
    section = Section(axes=("x", "px"), ranges=((-3, 3), (-6, 6)), shape=(31, 41), fixed={"y": 0.4}, solve="py", sign=-1)
    states, allowed, solved = section_states(system, section, energy)
    x, px = np.meshgrid(*section.axis_values(), indexing="ij")
    radicand = my * (2.0 * (energy - x**2 / 2 - 0.4**2) - px**2 / mx)
    np.testing.assert_array_equal(allowed, radicand >= 0)
    np.testing.assert_allclose(solved[allowed], -np.sqrt(radicand[allowed]), rtol=1e-13, atol=1e-14)
    np.testing.assert_allclose([system.energy(s) for s in states], energy, rtol=0, atol=1e-13)


def test_solved_momentum_with_a_coupled_kinetic_matrix(quadratic):
    # The quadratic in p_s has two roots; the sign chosen is that of the velocity dq_s/dt = (M^-1 p)_s.
    energy = 0.8
    for sign in (+1, -1):
        section = Section(axes=("x", "px"), ranges=((-1, 1), (-2, 2)), shape=(21, 31), fixed={"y": 0.2},
                          solve="py", sign=sign)
        states, allowed, _ = section_states(quadratic, section, energy)
        assert 0 < allowed.sum() < allowed.size
        np.testing.assert_allclose([quadratic.energy(s) for s in states], energy, rtol=0, atol=1e-13)
        velocities = np.linalg.solve(MASS, states[:, 2:].T).T
        assert np.all(sign * velocities[:, 1] >= -1e-13)
    # allowed exactly where V + min over p_y of the kinetic energy <= E; the minimum (at dq_y/dt = 0)
    # is px^2 / (2 M11) (minimizing p^T M^-1 p / 2 over p_y by hand)
    x, px = np.meshgrid(*section.axis_values(), indexing="ij")
    potential = -A * x**2 / 2 + B * 0.2**2 / 2 + C * x * 0.2
    np.testing.assert_array_equal(allowed, potential + px**2 / (2 * MASS[0, 0]) <= energy)


def documented_config(marker: str) -> dict:
    """The documented ```yaml block that contains ``marker``, parsed."""
    import yaml

    return yaml.safe_load(documented_yaml(marker))


@pytest.mark.parametrize("marker,name", [("masses:", "deleon_berne"), ("mass_matrix:", "barbanis_coupled")])
def test_documented_examples_are_valid(marker, name):
    config = validate_config(documented_config(marker))
    system = make_system(name, {k: v for k, v in config["systems"][name].items() if k != "equilibria"})
    assert system.mass_matrix is not None


def test_deleon_berne_linearization():
    # UPOsHam's De Leon–Berne system (documented example, m = 8): at the saddle (0, 0), V = eps_s = 1 and
    # Hess V = diag(2 d_x lam^2, -8) (derivatives by hand), so the saddle rate is sqrt(8 / 8) = 1 and
    # the centre frequency sqrt(2 d_x lam^2 / 8) = lam sqrt(2.5).
    spec = documented_config("masses:")["systems"]["deleon_berne"]
    system = make_system("deleon_berne", spec)
    saddle = linearize_saddle(system, np.zeros(2))
    assert saddle.critical_energy == 1.0
    assert saddle.saddle_rate == pytest.approx(1.0, rel=1e-14)
    assert saddle.omegas[0] == pytest.approx(1.5 * math.sqrt(2.5), rel=1e-14)
    settings = CorrectorSettings(tolerance=1e-10, rtol=1e-13, atol=1e-13)
    family = LyapunovFamily(system, saddle, 0, settings)
    family.continue_to(1.0 + 1e-4, initial_amplitude=1e-4, max_step=0.01, max_members=200)
    orbit = family.at_energy(1.0 + 1e-4, energy_tolerance=1e-12)
    # Lyapunov's theorem: the period tends to 2 pi / omega (here 1e-4 above E_c: within 1e-3)
    assert orbit.period == pytest.approx(2.0 * math.pi / saddle.omegas[0], rel=1e-3)
    assert orbit.closure_error < 1e-10


def test_transport_of_a_system_with_masses_is_refused():
    # The transport stage's well volume and Monte Carlo momenta assume |p|^2/2: refused, naming the key.
    config = {
        "systems": {"heavy": {"builtin": "barbanis_2dof", "masses": {"x": 8.0, "y": 8.0}}},
        "periodic_orbits": {"f": {"system": "heavy", "saddle_near": [5.5, -7.0], "energies": {"excess": [0.125]}}},
        "transport": {"t": {"orbits": "f", "energies": {"excess": [0.125]}}},
    }
    with pytest.raises(ConfigError, match=r"transport\.t\.orbits.*unit masses.*systems\.heavy\.masses"):
        validate_config(config)
    del config["systems"]["heavy"]["masses"]
    validate_config(config)  # the same study without masses is valid


def test_a_momentum_surface_coupled_by_the_kinetic_matrix_is_refused():
    # The flow locates crossings of (M^-1 p)_i; p_i = c is one of them only where M's row i is diagonal.
    def config(kinetic):
        return {
            "systems": {"s": {"builtin": "barbanis_2dof", **kinetic}},
            "poincare_sections": {"p": {
                "system": "s", "energy": {"excess": 0.1}, "section": {"coordinate": "py", "value": 0.0},
                "initial_conditions": {"axes": [{"name": "x", "range": [-5, 5], "points": 4},
                                                {"name": "px", "range": [-5, 5], "points": 4}],
                                       "fixed": {"y": 0.0}, "solve": "py"},
            }},
        }

    with pytest.raises(ConfigError, match=r"poincare_sections\.p\.section\.coordinate.*systems\.s\.mass_matrix"):
        validate_config(config({"mass_matrix": [[1.5, 0.5], [0.5, 1.5]]}))
    validate_config(config({"masses": {"x": 8.0, "y": 2.0}}))  # diagonal: p_y = c is (M^-1 p)_y = c / m_y


def test_a_vector_field_with_masses_is_refused_naming_the_key():
    # A general flow has no kinetic energy: masses would be silently meaningless.
    spec = {"vector_field": {"x": "y", "y": "-x"}, "coordinates": ["x", "y"], "masses": {"x": 2.0}}
    with pytest.raises(ConfigError, match=r"'systems\.osc\.masses': a vector field has no kinetic energy"):
        make_system("osc", spec, key="systems.osc")


def test_saddle_flux_of_a_system_with_masses_is_refused():
    # The saddle-flux stage's one-way flux and sampled momenta assume |p|^2/2, like transport's.
    config = {
        "systems": {"heavy": {"builtin": "barbanis_2dof", "masses": {"x": 8.0}}},
        "saddle_flux": {"s": {"system": "heavy", "saddle_near": [5.5, -7.0], "energies": {"excess": [0.125]}}},
    }
    with pytest.raises(ConfigError, match=r"saddle_flux\.s\.system.*saddle-flux stage is for unit masses"):
        validate_config(config)
    del config["systems"]["heavy"]["masses"]
    validate_config(config)  # the same study without masses is valid
