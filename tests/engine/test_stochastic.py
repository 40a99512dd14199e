"""The stochastic engine against closed forms: the Ornstein-Uhlenbeck process's mean and variance,
Brownian spreading 2 K t, reflection in a box (mass kept, the variance saturating at L^2/12) and
off a coast of land cells (the reflected Gaussian), the measured strong and weak orders of Euler-Maruyama and Milstein on geometric Brownian motion
(its exact solution driven by the same increments), the zero-noise LD against the linear
saddle's closed form, and the random streams against numpy's Philox and across tilings.

Two compiled modules serve every test: OU in x and GBM in y (one system, multiplicative
diagonal noise; Euler-Maruyama and Milstein are a run-time switch), and free diffusion (the
reflecting box is a run-time argument). Ensembles are vectorised: one call, many members.
"""

import math

import numpy as np
import pytest

from ldpipe.engine.stochastic import (StochasticSettings, brownian_endpoints, compute_stochastic_ld, path_normals,
                                      philox_module, stream_key)
from ldpipe.errors import ConfigError
from ldpipe.systems import make_system
from ldpipe.systems.noise import parse_noise
from support.closed_forms import linear_saddle_ld

THETA, MU = 1.0, 1.0  # OU's rate in x, GBM's growth in y
SIGMA, BETA = 0.5, 1.0  # OU's noise amplitude, GBM's volatility (large: the noise's error dominates the drift's)
K = 0.05  # diffusivity of the free particle
FAR = 1e6  # an escape radius no path reaches


@pytest.fixture(scope="module")
def ou_gbm():
    spec = {"vector_field": {"x": "-theta*x", "y": "mu*y"}, "coordinates": ["x", "y"],
            "parameters": {"theta": THETA, "mu": MU}}
    system = make_system("sde_ou_gbm", spec)
    noise = parse_noise({"diffusion": {"x": "sigma", "y": "beta*y"}, "parameters": {"sigma": SIGMA, "beta": BETA}},
                        system, "ld_maps.test.noise")
    return system, noise


@pytest.fixture(scope="module")
def free():
    system = make_system("sde_free", {"vector_field": {"x": "0", "y": "0"}, "coordinates": ["x", "y"]})
    return system, parse_noise({"diffusivity": K}, system, "ld_maps.test.noise")


def run(model, start, tau, members, dt, scheme="euler_maruyama", seed=1, direction=1, noise=None, **kwargs):
    system, default = model
    settings = StochasticSettings(scheme=scheme, dt=dt, seed=seed, members=members)
    return compute_stochastic_ld(system, noise or default, np.atleast_2d(start), direction, tau, 0.5, settings, FAR,
                                 **kwargs)


def test_philox_equals_numpys():
    # numpy.random.Philox is Philox4x64-10; it increments its counter before each block of four,
    # so its first block is that of the counter one past the one given.
    key, counter = (2**63 + 12345, 987654321), (41, 7, 2**40 + 8, 9)
    ours = np.zeros((3, 4), dtype=np.uint64)
    philox_module().raw_blocks(np.uint64(key[0]), np.uint64(key[1]), np.uint64(counter[0] + 1), 3,
                               *(np.uint64(c) for c in counter[1:]), ours)
    numpys = np.random.Philox(key=np.array(key, dtype=np.uint64), counter=np.array(counter, dtype=np.uint64))
    np.testing.assert_array_equal(ours, numpys.random_raw(12).reshape(3, 4))


def test_stream_normals_are_standard():
    # 200,000 draws of one stream: mean 0 and variance 1 within 5 standard errors (sqrt(1/n), sqrt(2/n)),
    # and the kurtosis 3 of a normal law within 5 of its standard errors (sqrt(24/n)).
    xi = path_normals(seed=3, t0=0.0, trajectory=5, member=0, direction=1, steps=50_000, n_noise=4).ravel()
    n = xi.size
    assert abs(xi.mean()) < 5 * math.sqrt(1 / n)
    assert abs(xi.var() - 1) < 5 * math.sqrt(2 / n)
    assert abs(np.mean(xi**4) / xi.var() ** 2 - 3) < 5 * math.sqrt(24 / n)


def test_ornstein_uhlenbeck_mean_and_variance(ou_gbm):
    # dx = -theta x dt + sigma dW from x0: mean x0 e^(-theta t), variance sigma^2 (1 - e^(-2 theta t)) / (2 theta).
    # Euler-Maruyama's bias at dt = 0.005 is ~3e-3 of either, below the ensemble's standard errors.
    x0, tau, members = 1.0, 1.0, 20_000
    x = run(ou_gbm, [x0, 1.0], tau, members, 0.005).end_state[0, :, 0]
    mean = x0 * math.exp(-THETA * tau)
    variance = SIGMA**2 * (1 - math.exp(-2 * THETA * tau)) / (2 * THETA)
    assert abs(x.mean() - mean) < 4 * math.sqrt(variance / members)
    assert abs(x.var(ddof=1) - variance) < 4 * variance * math.sqrt(2 / (members - 1))


def test_free_diffusion_spreads_as_2kt(free):
    # dx = sqrt(2 K) dW: variance 2 K t along each axis, no covariance (independent Wiener processes).
    tau, members = 2.0, 20_000
    end = run(free, [0.3, -0.2], tau, members, 0.05).end_state[0]
    variance = 2 * K * tau
    for axis in range(2):
        assert abs(end[:, axis].var(ddof=1) - variance) < 4 * variance * math.sqrt(2 / (members - 1))
        assert abs(end[:, axis].mean() - [0.3, -0.2][axis]) < 4 * math.sqrt(variance / members)
    assert abs(np.corrcoef(end.T)[0, 1]) < 4 / math.sqrt(members)


def test_a_full_diffusion_matrix_gives_covariance_g_gt_t(free):
    # Additive noise by a 2 x 3 matrix G (three Wiener processes): the end state's covariance is G G^T t,
    # each entry within 4 standard errors sqrt((s_ii s_jj + s_ij^2) / n) of a sample covariance.
    system, _ = free
    rows = [[0.3, 0.4, 0.0], [0.0, 0.2, 0.5]]
    matrix = parse_noise({"diffusion": [[str(v) for v in row] for row in rows]}, system, "test")
    assert matrix.n_noise == 3 and not matrix.diagonal
    tau, members = 1.5, 20_000
    end = run(free, [0.0, 0.0], tau, members, 0.5, noise=matrix).end_state[0]
    expected = np.array(rows) @ np.array(rows).T * tau
    sample = np.cov(end.T)
    error = np.sqrt((np.outer(np.diag(expected), np.diag(expected)) + expected**2) / members)
    assert np.all(np.abs(sample - expected) < 4 * error)


def test_velocity_data_drift_and_spread(tmp_path):
    # Velocity data of a uniform current u = U (sampled on a grid: its cubic convolution is exact for a
    # constant) with diffusivity K: mean displacement U t, variance 2 K t per axis, within 4 standard errors.
    from support.gridded import write_velocity_file

    current, diffusivity, tau, members = 0.1, 0.01, 10.0, 20_000
    path = write_velocity_file(tmp_path / "current.nc", lambda x, y, t: (current + 0 * x, 0 * y),
                               np.linspace(0, 10, 11), np.linspace(0, 5, 6), np.linspace(0, 20, 5))
    data = make_system("sde_uniform_current", {"velocity_data": {"path": str(path)}})
    noise = parse_noise({"diffusivity": diffusivity}, data, "test")
    end = run((data, noise), [2.0, 2.5], tau, members, 0.5).end_state[0]
    variance = 2 * diffusivity * tau
    np.testing.assert_array_less(np.abs(end.mean(axis=0) - [2.0 + current * tau, 2.5]),
                                 4 * math.sqrt(variance / members))
    np.testing.assert_array_less(np.abs(end.var(axis=0, ddof=1) - variance), 4 * variance * math.sqrt(2 / members))


def test_a_coast_reflects_brownian_particles_into_the_reflected_gaussian(tmp_path):
    """Still water (u = v = 0) east of a straight coast, the grid line x = 0 (the nodes west of it
    land: NaN), diffusivity K, particles from x = a: none ends on land or is lost (mass kept), and
    their x is the reflected Brownian motion |a + W|, W ~ N(0, 2 K t): density phi(x - a) +
    phi(x + a) on x >= 0. With no drift the reflected Gaussian-step walk has that law exactly at
    the step times (|y| + xi and y + xi have the same modulus in law for a symmetric xi), so only
    sampling error remains: the mean within 4 standard errors, the Kolmogorov-Smirnov distance
    below 1.95 / sqrt(n) (its 0.1 % point). Free diffusion would leave Phi(-a / sigma) = 36 % on
    land. Along the coast, y spreads as 2 K t. In a corner of land each coordinate is reflected on
its own: both means are the reflected Gaussian's."""
    from scipy.stats import norm

    from support.gridded import write_velocity_file

    diffusivity, tau, members, a = 0.01, 1.0, 20_000, 0.05
    nodes = np.linspace(-1.0, 2.0, 31)
    path = write_velocity_file(tmp_path / "coast.nc", lambda x, y, t: (0 * x, 0 * y), nodes, nodes,
                               np.linspace(0, 20, 5), land=lambda x, y: x < -0.05)
    data = make_system("sde_coast", {"velocity_data": {"path": str(path)}})
    noise = parse_noise({"diffusivity": diffusivity}, data, "test")
    result = run((data, noise), [a, 0.5], tau, members, 0.05)
    assert result.started.all() and not result.escaped.any() and np.all(result.time == tau)
    x, y = result.end_state[0].T
    assert np.all(x >= 0.0)
    sigma = math.sqrt(2 * diffusivity * tau)
    mean = sigma * math.sqrt(2 / math.pi) * math.exp(-a * a / (2 * sigma * sigma)) + a * (1 - 2 * norm.cdf(-a / sigma))
    error = math.sqrt((a * a + sigma * sigma - mean * mean) / members)
    assert abs(x.mean() - mean) < 4 * error
    ordered = np.sort(x)
    law = norm.cdf((ordered - a) / sigma) - norm.cdf((-ordered - a) / sigma)
    steps = np.arange(1, members + 1) / members
    assert max(np.max(steps - law), np.max(law - steps + 1 / members)) < 1.95 / math.sqrt(members)
    assert abs(y.var(ddof=1) - sigma**2) < 4 * sigma**2 * math.sqrt(2 / members)
    # a start on land is not integrated
    assert not run((data, noise), [-0.5, 0.5], tau, 2, 0.05).started.any()
    # In a corner of land (west of x = 0 and south of y = 0) each coordinate is reflected on its own
    # (the walls are perpendicular), so each is the reflected Gaussian from its start.
    path = write_velocity_file(tmp_path / "corner.nc", lambda x, y, t: (0 * x, 0 * y), nodes, nodes,
                               np.linspace(0, 20, 5), land=lambda x, y: (x < -0.05) | (y < -0.05))
    corner = make_system("sde_coast", {"velocity_data": {"path": str(path)}})
    result = run((corner, noise), [a, a], tau, members, 0.05)
    assert result.started.all() and not result.escaped.any()
    end = result.end_state[0]
    assert np.all(end >= 0.0)
    assert np.all(np.abs(end.mean(axis=0) - mean) < 4 * error)


@pytest.mark.compiles  # the stochastic engine of a rectilinear grid's kernel
def test_a_coast_on_a_rectilinear_grid_is_a_wall_too(tmp_path):
    """The coast of the test above on a grid of uneven spacing east of it (its walls are the
    nodes' own values): every particle at sea, the reflected Gaussian's mean within 4 standard errors."""
    from scipy.stats import norm

    from support.gridded import write_velocity_file

    diffusivity, tau, members, a = 0.01, 1.0, 20_000, 0.05
    x_nodes = np.concatenate([np.linspace(-1.0, 0.0, 11), [0.03, 0.08, 0.15, 0.25, 0.4, 0.6, 0.9, 1.3, 2.0]])
    path = write_velocity_file(tmp_path / "coast.nc", lambda x, y, t: (0 * x, 0 * y), x_nodes,
                               np.linspace(-1.0, 2.0, 31), np.linspace(0, 20, 5), land=lambda x, y: x < -0.05)
    data = make_system("sde_coast_rectilinear", {"velocity_data": {"path": str(path)}})
    assert type(data).__name__ == "RectilinearVelocitySystem"
    result = run((data, parse_noise({"diffusivity": diffusivity}, data, "test")), [a, 0.5], tau, members, 0.05)
    assert result.started.all() and not result.escaped.any()
    x = result.end_state[0, :, 0]
    assert np.all(x >= 0.0)
    sigma = math.sqrt(2 * diffusivity * tau)
    mean = sigma * math.sqrt(2 / math.pi) * math.exp(-a * a / (2 * sigma * sigma)) + a * (1 - 2 * norm.cdf(-a / sigma))
    assert abs(x.mean() - mean) < 4 * math.sqrt((a * a + sigma * sigma - mean * mean) / members)


def test_reflecting_box_keeps_mass_and_saturates_at_uniform_variance(free):
    # In a box of side L every member stays inside (no mass lost through a wall), and after many
    # relaxation times L^2 / (4 pi^2 K) (the slowest even mode) the law is uniform: variance L^2 / 12,
    # standard error sqrt((L^4/80 - L^4/144) / n) for the uniform law's fourth moment.
    lower, upper = (-0.5, -0.5), (0.5, 0.5)
    system, _ = free
    walled = parse_noise({"diffusivity": K, "reflect": {"x": [-0.5, 0.5], "y": [-0.5, 0.5]}}, system, "test")
    starts = np.array([[0.0, 0.0], [0.49, -0.49]])  # the centre, and a corner a step from both walls
    tau, members = 6.0, 10_000
    result = run(free, starts, tau, members, 0.05, noise=walled)
    assert result.started.all() and not result.escaped.any() and np.all(result.time == tau)
    end = result.end_state
    assert np.all((end >= np.array(lower)) & (end <= np.array(upper)))
    side = 1.0
    error = math.sqrt((side**4 / 80 - side**4 / 144) / members)
    for k in range(2):
        for axis in range(2):
            assert abs(end[k, :, axis].var(ddof=1) - side**2 / 12) < 4 * error
    # without walls the same paths spread past the box: the walls did the work
    assert run(free, starts, tau, members, 0.05).end_state.var() > 3 * side**2 / 12
    # From a wall, before the far wall matters (7 standard deviations away), a reflected Brownian motion is
    # the wall minus |N(0, 2 K t)|: mean distance sqrt(2 K t) sqrt(2 / pi), standard error of it
    # sqrt(2 K t (1 - 2 / pi) / n). (A wall that wrapped paths round to the other side would fail this.)
    t = 0.2
    end = run(free, [0.5, -0.5], t, members, 0.05, noise=walled).end_state[0]
    distance = math.sqrt(2 * K * t) * math.sqrt(2 / math.pi)
    error = math.sqrt(2 * K * t * (1 - 2 / math.pi) / members)
    assert abs((0.5 - end[:, 0]).mean() - distance) < 4 * error
    assert abs((end[:, 1] + 0.5).mean() - distance) < 4 * error


def gbm_errors(ou_gbm, scheme, steps_list, members, y0=1.0, tau=1.0, seed=11):
    """Per step count: (mean |Y_h - Y|, mean (Y_h - Y)) at tau over the members, Y = y0 exp((mu - beta^2/2) tau
    + beta W_tau) the exact GBM driven by the same increments (brownian_endpoints sums them)."""
    strong, weak = [], []
    for steps in steps_list:
        h = tau / steps
        y = run(ou_gbm, [0.0, y0], tau, members, h, scheme=scheme, seed=seed).end_state[0, :, 1]
        w = brownian_endpoints(seed, 0.0, 0, members, 1, steps, h, 2)[:, 1]
        exact = y0 * np.exp((MU - BETA**2 / 2) * tau + BETA * w)
        strong.append(np.mean(np.abs(y - exact)))
        weak.append(np.mean(y - exact))  # E[exact] = y0 e^(mu tau): the weak error with the exact path's noise removed
    return np.array(strong), np.array(weak)


def slope(steps_list, errors):
    return np.polyfit(np.log(1.0 / np.asarray(steps_list)), np.log(np.abs(errors)), 1)[0]


@pytest.mark.parametrize("scheme, strong_order", [("euler_maruyama", 0.5), ("milstein", 1.0)])
def test_measured_orders_on_geometric_brownian_motion(ou_gbm, scheme, strong_order):
    # Theory (Kloeden and Platen, thms 10.2.2, 10.3.5, 14.1.5): with multiplicative noise Euler-Maruyama
    # converges with strong order 1/2, Milstein 1; both with weak order 1. Both schemes' mean is
    # y0 (1 + mu h)^n exactly (Milstein's term has zero mean), so their weak error is that closed form,
    # whose slope over h = 1/4 .. 1/32 is 0.92 (tending to 1). Measured: strong slopes within 0.04 of the
    # orders (h = 1/8 .. 1/64), weak slopes within 0.08 of the closed form's, its values within 20 %.
    steps_list = np.array([4, 8, 16, 32, 64])
    strong, weak = gbm_errors(ou_gbm, scheme, steps_list, 20_000)
    assert abs(slope(steps_list[1:], strong[1:]) - strong_order) < 0.1
    exact_weak = (1 + MU / steps_list) ** steps_list - math.exp(MU)
    assert abs(slope(steps_list[:-1], weak[:-1]) - slope(steps_list[:-1], exact_weak[:-1])) < 0.15
    assert 0.85 < slope(steps_list[:-1], exact_weak[:-1]) < 1.0
    np.testing.assert_allclose(weak[:-1], exact_weak[:-1], rtol=0.35)


def test_measured_orders_of_heun_on_geometric_brownian_motion(ou_gbm):
    """Heun, the Stratonovich predictor-corrector of the same Ito SDE (drift a = mu - beta^2/2 in the
    Stratonovich form dY = a Y dt + beta Y o dW): strong order 1 for commuting (here scalar) noise
    (Kloeden and Platen, sec. 11.1). Its step multiplies Y by 1 + z + z^2/2, z = a h + beta dW, whose
    mean is 1 + mu h + a^2 h^2 / 2: the scheme's mean y0 (1 + mu h + a^2 h^2/2)^n in closed form, a weak
    error of order 1 (its slope over h = 1/4 .. 1/32 is 0.93). Measured as the other schemes' are."""
    steps_list = np.array([4, 8, 16, 32, 64])
    strong, weak = gbm_errors(ou_gbm, "heun", steps_list, 20_000)
    assert abs(slope(steps_list[1:], strong[1:]) - 1.0) < 0.1
    a = MU - BETA**2 / 2
    h = 1.0 / steps_list
    exact_weak = (1 + MU * h + a * a * h * h / 2) ** steps_list - math.exp(MU)
    assert 0.85 < slope(steps_list[:-1], exact_weak[:-1]) < 1.0
    assert abs(slope(steps_list[:-1], weak[:-1]) - slope(steps_list[:-1], exact_weak[:-1])) < 0.15
    np.testing.assert_allclose(weak[:-1], exact_weak[:-1], rtol=0.35)


def test_additive_noise_milstein_is_euler_maruyama(ou_gbm):
    # For additive noise Milstein's correction 1/2 g g' (dW^2 - h) is zero: the same bits. (EM's strong
    # order is then 1, Milstein's.)
    system, _ = ou_gbm
    additive = parse_noise({"diffusivity": 0.1}, system, "test")
    a = run(ou_gbm, [0.5, 0.5], 1.0, 8, 0.1, noise=additive)
    b = run(ou_gbm, [0.5, 0.5], 1.0, 8, 0.1, scheme="milstein", noise=additive)
    np.testing.assert_array_equal(a.end_state, b.end_state)
    np.testing.assert_array_equal(a.ld, b.ld)


@pytest.mark.parametrize("p", [0.5, 1.0, 0.3, "arclength"])
@pytest.mark.parametrize("direction", [1, -1])
def test_zero_noise_ld_is_the_linear_saddles(ou_gbm, direction, p):
    # With G = 0 the steps are Euler's on x' = -x, y' = y (backward time: the drift reversed), whose path is
    # geometric, x_n = x0 (1 -+ h)^n, y_n = y0 (1 +- h)^n, and the LD the trapezoidal sum of |x_n|^p + |y_n|^p
    # (the arc length: of sqrt(x_n^2 + y_n^2)): equal to rounding. As h -> 0 M_p is the linear saddle's in
    # closed form (support.closed_forms, axes exchanged), here within Euler's first-order error.
    system, _ = ou_gbm
    silent = parse_noise({"diffusivity": 0}, system, "test")
    starts = np.array([[0.3, 0.2], [-0.1, 0.5]])
    tau, h = 2.0, 0.01
    settings = StochasticSettings(dt=h, members=2)
    result = compute_stochastic_ld(system, silent, starts, direction, tau, p, settings, FAR)
    n = np.arange(201)
    for k, (x0, y0) in enumerate(starts):
        x, y = x0 * (1 - direction * h) ** n, y0 * (1 + direction * h) ** n
        g = np.hypot(x, y) if p == "arclength" else np.abs(x) ** p + np.abs(y) ** p
        np.testing.assert_allclose(result.ld[k], h * (g[:-1] + g[1:]).sum() / 2, rtol=1e-12)
        np.testing.assert_allclose(result.end_state[k, :, 0], x[-1], rtol=1e-12)
        if p != "arclength":
            # Euler's x_n^p is off by at most p tau h / 2 relative: ln (1 + h)^n = t - t h / 2 + ...
            np.testing.assert_allclose(result.ld[k], linear_saddle_ld(y0, x0, 1.0, tau, p, direction),
                                       rtol=p * tau * h / 2)


def test_paths_are_the_same_bits_in_any_order_tiling_and_thread_count(ou_gbm):
    # A path's noise is keyed by (seed, t0) and counted by (step, trajectory index, member, direction):
    # the starts permuted, split in two calls, or run on one thread give the same bits.
    rng = np.random.default_rng(0)
    starts = rng.uniform(-1, 1, (12, 2))
    index = np.arange(100, 112)
    whole = run(ou_gbm, starts, 0.5, 5, 0.05, scheme="milstein", index=index, t0=0.25)
    order = rng.permutation(12)
    permuted = run(ou_gbm, starts[order], 0.5, 5, 0.05, scheme="milstein", index=index[order], t0=0.25, threads=1)
    halves = [run(ou_gbm, starts[s], 0.5, 5, 0.05, scheme="milstein", index=index[s], t0=0.25)
              for s in (slice(0, 7), slice(7, 12))]
    for name in ("ld", "end_state", "time"):
        np.testing.assert_array_equal(getattr(permuted, name), getattr(whole, name)[order])
        np.testing.assert_array_equal(np.concatenate([getattr(h, name) for h in halves]), getattr(whole, name))
    # and the key: another start time, direction or seed draws other noise
    other = run(ou_gbm, starts, 0.5, 5, 0.05, scheme="milstein", index=index, t0=0.5)
    assert not np.any(other.end_state == whole.end_state)
    assert stream_key(1, -0.0) == stream_key(1, 0.0)


def test_milstein_refuses_non_diagonal_noise(ou_gbm):
    system, _ = ou_gbm
    coupled = parse_noise({"diffusion": {"x": "0.1*y", "y": "0.1"}}, system, "ld_maps.m.noise")
    assert not coupled.diagonal
    with pytest.raises(ValueError, match="milstein: needs diagonal noise"):
        run(ou_gbm, [0.1, 0.1], 0.1, 2, 0.05, scheme="milstein", noise=coupled)


@pytest.mark.parametrize("block, match", [
    ({"diffusivity": 0.1, "diffusion": {"x": "1", "y": "1"}}, "exactly one of diffusivity"),
    ({"diffusion": {"x": "__import__('os')", "y": "1"}}, "noise.diffusion"),
    ({"diffusion": {"x": "s", "y": "1"}}, "unknown names"),
    ({"diffusion": [["1", "0"]]}, "rows"),
    ({"diffusivity": {"x": 0.1}}, "one diffusivity for each"),
    ({"diffusivity": 0.1, "reflect": {"z": [0, 1]}}, "not state variables"),
    ({"diffusivity": 0.1, "reflect": {"x": [1, 0]}}, "low < high"),
    ({"diffusion": {"x": "theta", "y": "1"}, "parameters": {"theta": 2.0}}, "parameters of the system"),
])
def test_bad_noise_blocks_name_their_key(ou_gbm, block, match):
    with pytest.raises(ConfigError, match=match) as error:
        parse_noise(block, ou_gbm[0], "ld_maps.m.noise")
    assert "ld_maps.m.noise" in str(error.value)
