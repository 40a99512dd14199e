"""The Monte Carlo reactive flux where its classification and its standard error matter.

On the quadratic 3 DoF saddle (support.quadratic_saddle) every crossing of the normal-mode plane is
reactive, so there the estimator is exact whatever it does with recrossings. Planes off the normal
modes (support.quadratic_planes) have recrossings by construction, and everything about them is
known in closed form: the weight of each crossing from its conserved saddle energy e_a, the one-way
flux (the volume of the plane's allowed region), the reactive flux (2π)² ΔE²/(2 ω_1 ω_2), which is
the same through every dividing surface, and on the shifted plane the distribution of the weights.
"""

import math

import numpy as np
import pytest
from scipy import stats

from ldpipe.core.trajectories import FlowSettings
from ldpipe.systems import make_system
from ldpipe.core.transport import reactive_flux_monte_carlo
from ldpipe.core.transport.flux import classify
from support import quadratic_planes as planes
from support import quadratic_saddle as quadratic

FLOW = FlowSettings(rtol=1e-9, atol=1e-9, escape_radius=60.0)  # test_flux_3dof's settings
EXCESS = 0.7
TILT = 0.7  # rad: one-way flux 1.61 times the reactive flux; weights +1, 0, −1 in 68 %, 28 %, 4 %
DURATION = 20.0  # e^{λ·20} = 7e7: a sample left undecided would start within 1e-7 of the stable manifold


@pytest.fixture(scope="module")
def system():
    return make_system(planes.NAME, quadratic.spec())


def test_tilted_plane_weights_are_the_mode_energy_classification(system):
    """Crossing by crossing, the classifier's weight is the closed form sign(p_a) θ(e_a), and all three
    weights occur. With a threshold inside the band where s can turn back (0.3; the derived bound is
    1.44, the threshold used twice that) 140 of these 2000 crossings were classified wrong."""
    plane = planes.tilted_plane(system, EXCESS, TILT)
    u, pu = plane.sample(2000, np.random.default_rng(7))
    states = plane.states(u, pu)
    weights, undecided = classify(plane, states, commit=planes.commit_threshold(plane), duration=DURATION,
                                  sample_step=0.1, flow=FLOW)
    exact = planes.exact_weights(states)
    assert not undecided.any()
    np.testing.assert_array_equal(weights, exact)
    assert {-1.0, 0.0, 1.0} <= set(np.unique(exact))


def test_tilted_plane_reactive_flux_is_the_normal_mode_flux(system):
    """Through the tilted plane the one-way flux is 2π²ΔE²/√det K (closed form, 1.61 times the reactive
    flux) and the reactive flux is still (2π)²ΔE²/(2ω_1ω_2). The estimate is within 4 standard errors
    of the latter (measured 0.3) and more than 30 below the former (measured 42), so counting every
    crossing, or the antireactive ones as reactive, cannot pass. The standard error is the sample
    standard deviation of weights in {−1, 0, 1} from their counts: A √((f_± − m²)/(N − 1)) with
    f_± = (n_+ + n_−)/N the mean of w² and m = (n_+ − n_−)/N the mean of w."""
    plane = planes.tilted_plane(system, EXCESS, TILT)
    count = 4000
    result = reactive_flux_monte_carlo(plane, commit=planes.commit_threshold(plane), duration=DURATION, batch=count,
                                       max_samples=count, target_stderr=0.0, flow=FLOW, seed=11)
    exact = planes.reactive_flux(EXCESS)
    one_way = planes.tilted_one_way_flux(EXCESS, TILT)
    assert result.surface_flux == pytest.approx(one_way, rel=1e-12)
    assert (result.samples, result.undecided) == (count, 0)
    assert result.antireactive > 0 and result.nonreactive > 0
    mean = (result.reactive - result.antireactive) / count
    squares = (result.reactive + result.antireactive) / count
    assert result.flux == pytest.approx(one_way * mean, rel=1e-12)
    assert result.stderr == pytest.approx(one_way * math.sqrt((squares - mean**2) / (count - 1)), rel=1e-12)
    assert abs(result.flux - exact) < 4 * result.stderr
    assert one_way - result.flux > 30 * result.stderr


def test_bernoulli_weights_have_the_closed_form_standard_error(system):
    """The weights on the shifted plane are Bernoulli(p), p = (ΔE/ΔE')² = 0.3 (support.quadratic_planes),
    so the estimate's standard error is A √(p(1 − p)/N), A = (2π)² ΔE'²/(2ω_1ω_2). The reported one is the
    sample's, A √(p̂(1 − p̂)/(N − 1)) with p̂ the reactive fraction (checked from the counts). Its square
    differs from the population value by p̂(1 − p̂) − p(1 − p) = (1 − 2p)(p̂ − p) − (p̂ − p)² and the factor
    N/(N − 1); with |p̂ − p| ≤ 4σ, σ = √(p(1 − p)/N), that bounds the relative difference (6 % of the
    variance here; measured 1.6 %). An error formula without the variance of mixed weights, e.g. the
    mean of w² (p, not p(1 − p): 1.43 times the variance) or the floor alone, is far outside."""
    fraction, count = 0.3, 4000
    shift = planes.shift_for_fraction(EXCESS, fraction)
    plane = planes.shifted_plane(system, EXCESS, shift)
    result = reactive_flux_monte_carlo(plane, commit=planes.commit_threshold(plane), duration=DURATION, batch=count,
                                       max_samples=count, target_stderr=0.0, flow=FLOW, seed=5)
    area = planes.reactive_flux(planes.shifted_excess(EXCESS, shift))
    assert result.surface_flux == pytest.approx(area, rel=1e-12)
    assert (result.antireactive, result.undecided) == (0, 0)
    observed = result.reactive / count
    sigma = math.sqrt(fraction * (1 - fraction) / count)
    assert abs(observed - fraction) < 4 * sigma
    assert result.stderr == pytest.approx(area * math.sqrt(observed * (1 - observed) / (count - 1)), rel=1e-12)
    population = area * sigma
    bound = (abs(1 - 2 * fraction) * 4 * sigma + 16 * sigma**2) / (fraction * (1 - fraction)) + 1 / (count - 1)
    assert abs(result.stderr**2 / population**2 - 1) < bound
    assert abs(result.flux - planes.reactive_flux(EXCESS)) < 4 * result.stderr


def test_standard_errors_cover_the_exact_flux_over_independent_seeds(system):
    """The stated standard error is honest where recrossings make the weights −1, 0 and 1: over 300
    independent estimates from N = 100 crossings of the tilted plane, the number within 1 (2) standard
    errors of the exact reactive flux is binomial with p = 68.27 % (95.45 %) (the mean of 100 weights is
    normal to well within these counts' resolution; the Student correction at 99 degrees of freedom
    lowers p by 0.3 %, one count), and the sum of the squared z-scores is χ²(300)-distributed. Each
    passes inside its central 99.9 %: a two-sided binomial test p-value ≥ 0.001 (178 to 231, and 273 to
    297, inside), χ² between its 0.05 % and 99.95 % quantiles, 226 and 387 (measured: 202 and 289
    inside, χ² = 309). A standard error √2 too large or too small (250 and 148 within one), or one that
    leaves out the antireactive weights (0.84 times the true one here; 163 within one), fails.

    The plane's allowed region is sampled in closed form (support.quadratic_planes.ExactlySampled), not
    by DividingPlane.sample (whose uniformity test_flux_3dof checks): its extent and quadrature would
    cost more than the 200 integrations of each estimate. It is checked here: its volume is the plane's
    quadrature, and the plane energy ε = |p_u|²/2 + uᵀKu/2 of uniform points of the 4-ball has
    Pr(ε ≤ ΔE/2) = (1/2)² = 1/4."""
    surface = planes.ExactlySampled(planes.tilted_plane(system, EXCESS, TILT))
    assert surface.area() == pytest.approx(surface.plane.area(), rel=1e-12)
    u, pu = surface.sample(100_000, np.random.default_rng(3))
    energy = surface.plane.potential(u) + 0.5 * np.sum(pu**2, axis=1)
    assert np.max(energy) <= EXCESS * (1 + 1e-12)
    assert abs(np.mean(energy <= EXCESS / 2) - 0.25) < 4 * math.sqrt(0.25 * 0.75 / len(u))
    exact = planes.reactive_flux(EXCESS)
    commit = planes.commit_threshold(surface.plane)
    seeds, count = 300, 100
    z = []
    for seed in range(seeds):
        result = reactive_flux_monte_carlo(surface, commit=commit, duration=DURATION, batch=count, max_samples=count,
                                           target_stderr=0.0, flow=FLOW, seed=1000 + seed)
        assert result.undecided == 0
        z.append((result.flux - exact) / result.stderr)
    z = np.abs(z)
    for sigmas, coverage in ((1, 0.6827), (2, 0.9545)):
        inside = int(np.sum(z <= sigmas))
        assert stats.binomtest(inside, seeds, coverage).pvalue >= 1e-3, (sigmas, inside)
    chi2 = float(np.sum(z**2))
    assert stats.chi2.ppf(5e-4, seeds) < chi2 < stats.chi2.ppf(1 - 5e-4, seeds), chi2
