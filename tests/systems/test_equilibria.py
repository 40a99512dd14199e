"""Equilibria and linear analysis against the paper's closed forms, with its errata derived."""

import numpy as np
import pytest

from ldpipe.core.equilibria.potential import equilibrium_table, linear_analysis, locate_equilibria, numeric_equilibria
from ldpipe.systems import make_system

WX, WY, DELTA = 1.0, 1.1, -0.11
BOX_2DOF = {"x": [-20.0, 20.0], "y": [-20.0, 20.0]}
BOX_3DOF = {"x": [-20.0, 20.0], "y": [-20.0, 20.0], "z": [-20.0, 20.0]}


def barbanis_saddle(wx, wy, delta):
    # Paper sec. model_prob_2dof: (-wy^2/(2 delta), +-wx wy/(sqrt(2) delta)), E_c = wx^2 wy^4/(8 delta^2).
    return -wy**2 / (2 * delta), abs(wx * wy / (np.sqrt(2) * delta)), wx**2 * wy**4 / (8 * delta**2)


def barbanis_rates(wx, wy):
    """lambda, omega at the 2 DoF saddle from p(beta) = beta^4 + wx^2 beta^2 - 2 wx^2 wy^2 (derived)."""
    root = np.sqrt(wx**4 + 8 * wx**2 * wy**2)
    return np.sqrt((-(wx**2) + root) / 2), np.sqrt((wx**2 + root) / 2)


def test_barbanis_equilibria_match_closed_form_and_paper(barbanis):
    positions, details = locate_equilibria(barbanis, BOX_2DOF)
    x_e, y_e, e_c = barbanis_saddle(WX, WY, DELTA)
    expected = np.array([[0.0, 0.0], [x_e, y_e], [x_e, -y_e]])
    order = np.lexsort(positions.T[::-1])
    np.testing.assert_allclose(positions[order], expected[np.lexsort(expected.T[::-1])], rtol=0, atol=1e-12)
    # The paper's printed values: (5.5, +-7.071), E_c = 15.125.
    np.testing.assert_allclose([x_e, y_e, e_c], [5.5, 7.071, 15.125], atol=5e-4)
    # The numeric multi-start search found the same three points (an independent method).
    assert details["numeric_found"] == 3
    assert details["max_distance_closed_form_to_numeric"] < 1e-12
    energies = [barbanis.potential(q) for q in positions]
    assert sorted(energies)[1:] == pytest.approx([15.125, 15.125], abs=1e-12)


def test_barbanis_contopoulos_equilibria_match_paper(barbanis_contopoulos):
    wx2, wy2, wz2, eps, eta = 0.9, 1.6, 0.4, 0.08, 0.01
    coupling = eps**2 * wz2 + eta**2 * wy2
    # Paper eq. eq_pt_BC_3dof and its E_c formula.
    x_e = np.sqrt(wx2 * wy2 * wz2 / (2 * coupling))
    y_e = eps * wx2 * wz2 / (2 * coupling)
    z_e = eta * wx2 * wy2 / (2 * coupling)
    e_c = wx2 * wx2 * wy2 * wz2 / (8 * coupling)
    positions, details = locate_equilibria(barbanis_contopoulos, BOX_3DOF)
    saddles = positions[np.abs(positions[:, 0]) > 1]
    np.testing.assert_allclose(np.sort(saddles[:, 0]), [-x_e, x_e], rtol=0, atol=1e-12)
    np.testing.assert_allclose(saddles[:, 1:], [[y_e, z_e]] * 2, rtol=0, atol=1e-12)
    for q in saddles:
        assert barbanis_contopoulos.potential(q) == pytest.approx(e_c, abs=1e-12)
    # The paper's rounded values: (+-10.290, 5.294, 2.647), E_c ~ 23.824.
    np.testing.assert_allclose([x_e, y_e, z_e], [10.290, 5.294, 2.647], atol=5e-4)
    assert e_c == pytest.approx(23.824, abs=5e-4)
    assert details["numeric_found"] == 3


def test_types_and_critical_energy_in_dataset(barbanis):
    dataset = equilibrium_table(barbanis, BOX_2DOF)
    kinds = dict(zip(map(tuple, np.round(dataset.position.values, 6)), dataset.type.values))
    assert kinds[(0.0, 0.0)] == "minimum"
    assert kinds[(5.5, 7.071068)] == kinds[(5.5, -7.071068)] == "index-1 saddle"
    np.testing.assert_allclose(dataset.critical_energy.values, [15.125, 15.125], atol=1e-12)


@pytest.mark.parametrize("wx, wy, delta", [(1.0, 1.1, -0.11), (1.3, 0.8, -0.2)])
def test_saddle_eigenvalues_match_appendix_closed_form(wx, wy, delta):
    system = make_system("b", {"builtin": "barbanis_2dof", "parameters": {"omega_x": wx, "omega_y": wy, "delta": delta}})
    x_e, y_e, _ = barbanis_saddle(wx, wy, delta)
    analysis = linear_analysis(system, np.array([x_e, -y_e]))
    rate, frequency = barbanis_rates(wx, wy)
    expected = np.array([rate, -rate, 1j * frequency, -1j * frequency])
    np.testing.assert_allclose(analysis.eigenvalues, expected, rtol=1e-12, atol=1e-14)
    assert analysis.kind == "index-1 saddle"
    # Each stored pair (value, vector) satisfies J v = beta v (an invariant, not a re-derivation).
    jacobian = system.jacobian(np.array([x_e, -y_e, 0, 0]))
    for beta, vector in zip(analysis.eigenvalues, analysis.eigenvectors):
        np.testing.assert_allclose(jacobian @ vector, beta * vector, atol=1e-12)
    # numpy's general eigensolver on the Jacobian agrees (an independent method).
    np.testing.assert_allclose(
        np.sort_complex(np.linalg.eigvals(jacobian)), np.sort_complex(expected), rtol=1e-10, atol=1e-12
    )


def test_paper_eigenvalue_formula_holds_only_for_unit_omega_x():
    """Erratum: the paper prints sqrt(wx^2 + 8 wx^2 wy^2); the derivation gives sqrt(wx^4 + ...).
    They agree for the paper's wx = 1 and differ otherwise; the Jacobian decides."""
    for wx, agrees in ((1.0, True), (1.3, False)):
        wy, delta = 1.1, -0.11
        printed = np.sqrt((-(wx**2) + np.sqrt(wx**2 + 8 * wx**2 * wy**2)) / 2)
        derived, _ = barbanis_rates(wx, wy)
        system = make_system("b", {"builtin": "barbanis_2dof", "parameters": {"omega_x": wx, "omega_y": wy, "delta": delta}})
        x_e, y_e, _ = barbanis_saddle(wx, wy, delta)
        true_rate = np.max(np.linalg.eigvals(system.jacobian(np.array([x_e, y_e, 0, 0]))).real)
        assert true_rate == pytest.approx(derived, rel=1e-12)
        assert (abs(printed - true_rate) < 1e-12) == agrees


def test_saddle_eigenvectors_parallel_to_appendix(barbanis):
    x_e, y_e, _ = barbanis_saddle(WX, WY, DELTA)
    rate, frequency = barbanis_rates(WX, WY)
    s = np.sqrt(2) * WX * WY
    # Paper sect. eigvec_lin_saddle, written for the saddle whose Jacobian has +sqrt(2) wx wy
    # off the diagonal of -Hess V, i.e. -2 delta y_e = -sqrt(2) wx wy: y_e < 0 for delta < 0.
    k_saddle = -(rate**2 + WX**2) / s
    k_centre = (frequency**2 - WX**2) / s
    paper = {
        0: np.array([1, k_saddle, rate, rate * k_saddle]),
        1: np.array([1, k_saddle, -rate, -rate * k_saddle]),
        2: np.array([1, k_centre, 1j * frequency, 1j * frequency * k_centre]),
    }
    analysis = linear_analysis(barbanis, np.array([x_e, -y_e]))
    for mode, vector in paper.items():
        computed = analysis.eigenvectors[mode]
        # Parallel: |<a, b>| = |a| |b| for complex vectors.
        overlap = abs(np.vdot(vector, computed)) / (np.linalg.norm(vector) * np.linalg.norm(computed))
        assert overlap == pytest.approx(1.0, abs=1e-12)


def test_3dof_jacobian_sign_erratum(barbanis_contopoulos):
    """Erratum: the paper's 3 DoF Jacobian has -2 eta x_e in the pz-dot row; it is +2 eta x_e.
    Finite differences of the equations of motion (which the paper prints correctly) decide,
    and only the corrected matrix is Hamiltonian (J^T Omega + Omega J = 0)."""
    system = barbanis_contopoulos
    wx2, wy2, wz2, eps, eta = 0.9, 1.6, 0.4, 0.08, 0.01
    positions, _ = locate_equilibria(system, BOX_3DOF)
    x_e, y_e, z_e = positions[np.argmax(positions[:, 0])]
    state = np.array([x_e, y_e, z_e, 0, 0, 0])
    step = 1e-6
    finite_difference = np.array(
        [(system.vector_field(state + step * e) - system.vector_field(state - step * e)) / (2 * step) for e in np.eye(6)]
    ).T
    jacobian = system.jacobian(state)
    np.testing.assert_allclose(jacobian, finite_difference, atol=1e-8)
    paper = np.zeros((6, 6))
    paper[:3, 3:] = np.eye(3)
    paper[3, :3] = [-(wx2 - 2 * eps * y_e - 2 * eta * z_e), 2 * eps * x_e, 2 * eta * x_e]
    paper[4, :3] = [2 * eps * x_e, -wy2, 0]
    paper[5, :3] = [-2 * eta * x_e, 0, -wz2]
    corrected = paper.copy()
    corrected[5, 0] = +2 * eta * x_e
    np.testing.assert_allclose(jacobian, corrected, atol=1e-13)
    omega = np.block([[np.zeros((3, 3)), np.eye(3)], [-np.eye(3), np.zeros((3, 3))]])
    assert np.abs(corrected.T @ omega + omega @ corrected).max() < 1e-13
    assert np.abs(paper.T @ omega + omega @ paper).max() > 0.1


def test_3dof_saddle_is_saddle_centre_centre(barbanis_contopoulos):
    dataset = equilibrium_table(barbanis_contopoulos, BOX_3DOF)
    saddle = int(dataset.saddle_equilibrium.values[0])
    real = dataset.eigenvalue_real.values[saddle]
    imag = dataset.eigenvalue_imag.values[saddle]
    # One real pair +-lambda, then two imaginary pairs: index-1 saddle (saddle x centre x centre).
    assert real[0] > 0 and real[1] == -real[0] and np.all(real[2:] == 0)
    assert imag[2] > imag[4] > 0 and imag[3] == -imag[2] and imag[5] == -imag[4]
    # lambda^2 - w1^2 - w2^2 = -trace(Hess V) (the trace of -Hess V is the sum of beta^2).
    hessian = barbanis_contopoulos.hessian(dataset.position.values[saddle])
    assert real[0] ** 2 - imag[2] ** 2 - imag[4] ** 2 == pytest.approx(-np.trace(hessian), rel=1e-12)


def test_formula_system_equilibria_found_numerically():
    # Henon-Heiles: V = (x^2 + y^2)/2 + x^2 y - y^3/3 has a minimum at 0 and three index-1
    # saddles at energy 1/6: (0, 1) and (+-sqrt(3)/2, -1/2) (a classical closed form).
    system = make_system(
        "hh", {"formula": "(x**2 + y**2)/2 + x**2*y - y**3/3", "coordinates": ["x", "y"]}
    )
    dataset = equilibrium_table(system, {"x": [-2, 2], "y": [-2, 2]}, seeds_per_axis=7)
    expected = {(0.0, 0.0), (0.0, 1.0), (0.866025, -0.5), (-0.866025, -0.5)}
    assert set(map(tuple, np.round(dataset.position.values, 6) + 0.0)) == expected
    assert sorted(dataset.type.values) == ["index-1 saddle"] * 3 + ["minimum"]
    np.testing.assert_allclose(dataset.critical_energy.values, [1 / 6] * 3, atol=1e-12)
    assert dataset.attrs["search_method"] == "numeric"


def test_box_excludes_outside_equilibria(barbanis):
    positions, _ = locate_equilibria(barbanis, {"x": [-1.0, 1.0], "y": [-20.0, 20.0]})
    np.testing.assert_array_equal(positions, [[0.0, 0.0]])
    assert len(numeric_equilibria(barbanis, np.array([1.0, 1.0]), np.array([2.0, 2.0]))) == 0
