"""The flux over an index-1 saddle of a 2 DoF system, three independent ways.

* :func:`orbit_action`: the action ∮ p·dq of the Lyapunov periodic orbit. For a sampled
  periodic orbit (uniform in time over one period) the derivative dq/dt is taken
  spectrally (FFT) and the integral by the trapezoidal rule; on smooth periodic data both
  converge exponentially with the number of samples.
* :func:`closed_curve_area`: the signed symplectic area ∮ p dx of a closed curve in a 2D
  section, e.g. the first cut of a manifold tube with U_xpx (the reactive island). The tube
  is a Lagrangian cylinder, so ∮ p·dq over any loop round it is the orbit's action; on the
  section y = 0 that loop integral is ∮ p_x dx. With points uniform in the orbit phase the
  cut is a smooth periodic curve of that phase and the spectral rule converges
  exponentially; the polygon (shoelace) rule, offered for comparison, only as N⁻².
* :func:`reactive_flux_monte_carlo`: uniform samples of the dividing surface (a straight
  line through the saddle, normal to its unstable Hessian direction), each integrated
  forward and backward until it commits to the well or the product side; see the function.

The directional flux through a configuration-space surface s(q) = 0 at energy E is
∫ δ(E − H) δ(s) ṡ θ(ṡ) dq dp. For a line with unit normal n, tangent t, coordinates
q = q_s + u t, p = p_u t + p_n n (a rotation, hence canonical), ṡ = p_n and
∫ dp_n p_n δ(E − p_n²/2 − p_u²/2 − V) θ(p_n) = 1, so the flux is the area of the allowed
region {(u, p_u): p_u²/2 + V(q_s + u t) ≤ E} = ∫ 2 √(2 (E − V)) du (:meth:`DividingLine.area`).
Every sample of that region is a crossing with p_n > 0; trajectories that recross the line
make the directional flux larger than the reactive flux, which the classification removes.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy import integrate as sp_integrate
from scipy import optimize

from ..trajectories import FlowSettings, integrate
from ...systems import System


def _spectral_derivative(values: np.ndarray) -> np.ndarray:
    """d/dφ of samples of a 2π-periodic function at φ_j = 2π j / N (axis 0), Nyquist mode dropped."""
    count = values.shape[0]
    k = np.fft.rfftfreq(count, d=1.0 / count)
    coefficients = np.fft.rfft(values, axis=0)
    factor = 1j * k
    if count % 2 == 0:
        factor[-1] = 0.0
    return np.fft.irfft(coefficients * factor.reshape((-1,) + (1,) * (values.ndim - 1)), n=count, axis=0)


def closed_curve_area(x: np.ndarray, p: np.ndarray, *, method: str = "spectral") -> float:
    """The loop integral ∮ p dx of a closed curve given by N points (not repeating the first).

    Parameters
    ----------
    x, p : array_like, shape (N,)
        The curve at parameter values uniformly spaced over one period (``spectral``), or
        any ordered points round it (``shoelace``).
    method : {"spectral", "shoelace"}
        ``spectral``: ∫ p(φ) x'(φ) dφ with x' from the FFT and the trapezoidal rule,
        exponentially accurate for a smooth periodic parametrization. ``shoelace``: the
        area of the polygon through the points, accurate to O(N⁻²).

    Returns
    -------
    float
        ∮ p dx, signed: minus the enclosed area for a counterclockwise curve in the (x, p)
        plane, plus it for a clockwise one.
    """
    x = np.asarray(x, dtype=np.float64)
    p = np.asarray(p, dtype=np.float64)
    if x.shape != p.shape or x.ndim != 1 or len(x) < 3:
        raise ValueError(f"x and p must be 1D arrays of the same length >= 3, got {x.shape} and {p.shape}")
    if method == "spectral":
        return float(2.0 * math.pi / len(x) * np.sum(p * _spectral_derivative(x)))
    if method == "shoelace":
        x_next, p_next = np.roll(x, -1), np.roll(p, -1)
        return float(np.sum(0.5 * (p + p_next) * (x_next - x)))
    raise ValueError(f"method must be 'spectral' or 'shoelace', got {method!r}")


def orbit_action(trajectory: np.ndarray, n_dof: int, *, endpoint: bool = True) -> float:
    """The action ∮ p·dq of a periodic orbit sampled uniformly in time over one period.

    Parameters
    ----------
    trajectory : array_like, shape (samples, 2 n_dof)
        Rows (q_1..q_n, p_1..p_n) at t_j = j T / (samples − 1) when ``endpoint`` (the UPO
        stage's ``trajectory``: both ends included), else at t_j = j T / samples.
    n_dof : int
        Degrees of freedom.

    Returns
    -------
    float
        Σ_i ∮ p_i dq_i, along the direction of motion (positive for H = |p|²/2 + V, where
        it equals ∫_0^T |p|² dt).
    """
    trajectory = np.asarray(trajectory, dtype=np.float64)
    if trajectory.ndim != 2 or trajectory.shape[1] != 2 * n_dof:
        raise ValueError(f"trajectory must have shape (samples, {2 * n_dof}), got {trajectory.shape}")
    if endpoint:
        closure = np.max(np.abs(trajectory[-1] - trajectory[0]))
        scale = max(1.0, float(np.max(np.abs(trajectory))))
        if closure > 1e-6 * scale:
            raise ValueError(f"the first and last samples differ by {closure:.3g}: not one closed period")
        trajectory = trajectory[:-1]
    q, p = trajectory[:, :n_dof], trajectory[:, n_dof:]
    return float(2.0 * math.pi / len(q) * np.sum(p * _spectral_derivative(q)))


def saddle_eigenvectors(system: System, saddle, well=None) -> tuple[np.ndarray, np.ndarray]:
    """The saddle as an array and the Hessian's unit eigenvectors there (columns, by increasing
    eigenvalue), the first, unstable, one pointing away from ``well`` (default: the origin), so
    that s = n·(q − q_s) > 0 is the product side; a ValueError unless the saddle has index 1."""
    saddle = np.asarray(saddle, dtype=np.float64)
    values, vectors = np.linalg.eigh(system.hessian(saddle))
    if not (values[0] < 0 < values[1]):
        raise ValueError(f"{saddle} is not an index-1 saddle: Hessian eigenvalues {values}")
    well = np.zeros(len(saddle)) if well is None else np.asarray(well, dtype=np.float64)
    if vectors[:, 0] @ (saddle - well) < 0:
        vectors[:, 0] = -vectors[:, 0]
    return saddle, vectors


@dataclass(frozen=True)
class DividingLine:
    """The straight dividing surface of a 2 DoF saddle at energy E, and its allowed region.

    ``normal`` is the unit normal n (pointing to the products); the tangent is t = (−n_y, n_x).
    Points of the surface are q = saddle + u t; the allowed region is
    {(u, p_u): p_u²/2 + V(q) ≤ energy} on the component of u containing 0.
    """

    system: System
    saddle: np.ndarray
    normal: np.ndarray
    energy: float

    @classmethod
    def at_saddle(cls, system: System, saddle, energy: float, *, well=None) -> DividingLine:
        """The line through ``saddle`` normal to the Hessian's unstable eigenvector.

        The normal is oriented away from ``well`` (default: the origin), so s = n·(q − q_s) > 0
        is the product side.
        """
        if system.n_dof != 2:
            raise ValueError(f"DividingLine is for 2 DoF systems; {system.name} has {system.n_dof}")
        saddle, vectors = saddle_eigenvectors(system, saddle, well)
        return cls(system, saddle, vectors[:, 0] / np.linalg.norm(vectors[:, 0]), float(energy))

    @property
    def tangent(self) -> np.ndarray:
        return np.array([-self.normal[1], self.normal[0]])

    def potential(self, u: float) -> float:
        return self.system.potential(self.saddle + u * self.tangent)

    def interval(self) -> tuple[float, float]:
        """The ends (u_lo, u_hi) of the allowed interval containing u = 0, where V = energy."""
        excess = self.energy - self.potential(0.0)
        if excess <= 0:
            raise ValueError(f"energy {self.energy!r} is not above the saddle's {self.potential(0.0)!r}")
        curvature = float(self.tangent @ self.system.hessian(self.saddle) @ self.tangent)
        guess = math.sqrt(2.0 * excess / curvature)
        ends = []
        for sign in (-1.0, 1.0):
            inner, outer = 0.0, guess
            while self.potential(sign * outer) < self.energy:
                inner, outer = outer, 2.0 * outer
                if outer > 1e6:
                    raise ValueError("the allowed region of the dividing line is unbounded")
            root = optimize.brentq(lambda u: self.potential(sign * u) - self.energy, inner, outer,
                                   xtol=1e-15, rtol=4 * np.finfo(float).eps, maxiter=200)
            ends.append(sign * root)
        return ends[0], ends[1]

    def momentum_bound(self, u: np.ndarray) -> np.ndarray:
        """√(2 (E − V)) at the points u (0 where forbidden)."""
        u = np.atleast_1d(np.asarray(u, dtype=np.float64))
        values = self.system.potentials(self.saddle[None, :] + u[:, None] * self.tangent[None, :])
        return np.sqrt(np.maximum(2.0 * (self.energy - values), 0.0))

    def area(self) -> float:
        """∫ 2 √(2 (E − V(u))) du over the allowed interval: the directional flux through the line.

        With u = c + h sin θ the square-root endpoint behaviour becomes smooth in θ.
        """
        lo, hi = self.interval()
        centre, half = 0.5 * (hi + lo), 0.5 * (hi - lo)

        def integrand(theta):
            u = centre + half * math.sin(theta)
            return 2.0 * math.sqrt(max(2.0 * (self.energy - self.potential(u)), 0.0)) * half * math.cos(theta)

        value, _ = sp_integrate.quad(integrand, -0.5 * math.pi, 0.5 * math.pi, epsabs=0.0, epsrel=1e-13, limit=200)
        return float(value)

    def states(self, u: np.ndarray, pu: np.ndarray) -> np.ndarray:
        """Phase-space states (x, y, p_x, p_y) at (u, p_u) with p_n = +√(2(E − V) − p_u²) (crossing outwards)."""
        u = np.asarray(u, dtype=np.float64)
        pu = np.asarray(pu, dtype=np.float64)
        pn = np.sqrt(np.maximum(self.momentum_bound(u) ** 2 - pu**2, 0.0))
        q = self.saddle[None, :] + u[:, None] * self.tangent[None, :]
        p = pu[:, None] * self.tangent[None, :] + pn[:, None] * self.normal[None, :]
        return np.hstack([q, p])

    def sample(self, count: int, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
        """``count`` points (u, p_u) uniform on the allowed region (rejection from its bounding box)."""
        lo, hi = self.interval()
        grid = np.linspace(lo, hi, 2001)
        bound = float(np.max(self.momentum_bound(grid))) * 1.01
        u_out, pu_out, have = [], [], 0
        while have < count:
            u = rng.uniform(lo, hi, size=2 * (count - have) + 16)
            pu = rng.uniform(-bound, bound, size=len(u))
            keep = pu**2 < self.momentum_bound(u) ** 2
            u_out.append(u[keep])
            pu_out.append(pu[keep])
            have += int(keep.sum())
        return np.concatenate(u_out)[:count], np.concatenate(pu_out)[:count]


@dataclass(frozen=True)
class MonteCarloFlux:
    """Result of :func:`reactive_flux_monte_carlo`.

    ``flux`` and ``stderr``: the reactive flux and its standard error; ``surface_flux``: the
    directional flux through the line (the area of its allowed region); ``samples``; counts of
    samples that are ``reactive`` (backward to the well, forward to the products),
    ``antireactive`` (the reverse), ``nonreactive`` (both ways to the same side) and
    ``undecided`` (not committed within the integration time, weight 0).
    """

    flux: float
    stderr: float
    surface_flux: float
    samples: int
    reactive: int
    antireactive: int
    nonreactive: int
    undecided: int


def harmonic_flux(excess_energy, frequencies) -> np.ndarray:
    """(2π)^{n−1} ΔE^{n−1} / ((n−1)! ∏ ω_i): the flux over a quadratic saddle with centre frequencies ω_i.

    The centre–centre part of phase space at energy ΔE above the saddle is {Σ ω_i I_i ≤ ΔE} in
    actions times (2π)^{n−1} in angles, a simplex of volume ΔE^{n−1}/((n−1)! ∏ ω_i): 2πΔE/ω in 2 DoF
    (:class:`DividingLine`), (2π)² ΔE²/(2 ω_1 ω_2) in 3 DoF (derived in :mod:`ldpipe.core.transport.plane`).
    """
    m = len(frequencies)
    return (2 * math.pi * np.asarray(excess_energy)) ** m / (math.factorial(m) * float(np.prod(frequencies)))


def _commit_side(samples: np.ndarray, saddle: np.ndarray, normal: np.ndarray, commit: float) -> np.ndarray:
    """+1 / −1 for the side (sign of s = n·(q − q_s)) where |s| first exceeds ``commit``; 0 if never."""
    s = (samples[:, :, : len(saddle)] - saddle) @ normal
    beyond = np.abs(s) > commit
    first = np.argmax(beyond, axis=1)
    hit = beyond[np.arange(len(s)), first]
    return np.where(hit, np.sign(s[np.arange(len(s)), first]), 0.0)


def classify(line: DividingLine, states: np.ndarray, *, commit: float, duration: float, sample_step: float,
             flow: FlowSettings, threads: int | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Weights w ∈ {+1, −1, 0} of states on the line (+1 reactive: from the well to the products,
    −1 antireactive, 0 otherwise), and a mask of the undecided ones (weight 0).

    Each state is integrated backward and forward for ``duration``, sampled every ``sample_step``;
    a direction commits to the side where the reaction coordinate s = n·(q − q_s) first leaves
    [−commit, commit]. Escaping trajectories end early; their last state is held, beyond ``commit``.
    """
    times = np.arange(0.0, duration + 0.5 * sample_step, sample_step)
    sides = []
    for sign in (-1.0, 1.0):
        result = integrate(line.system, states, sign * times[-1], flow, sample_times=sign * times, threads=threads)
        sides.append(_commit_side(result.samples, line.saddle, line.normal, commit))
    backward, forward = sides
    weight = np.where((backward < 0) & (forward > 0), 1.0, 0.0) - np.where((backward > 0) & (forward < 0), 1.0, 0.0)
    return weight, (backward == 0) | (forward == 0)


def reactive_flux_monte_carlo(
    line: DividingLine,
    *,
    commit: float,
    duration: float,
    target_stderr: float = 1e-3,
    batch: int = 10_000,
    max_samples: int = 1_000_000,
    sample_step: float = 0.1,
    flow: FlowSettings | None = None,
    seed: int = 0,
    threads: int | None = None,
) -> MonteCarloFlux:
    """The reactive flux through ``line`` at its energy, by Monte Carlo with recrossings counted once.

    ``line`` is a :class:`DividingLine` (2 DoF) or a :class:`~ldpipe.core.transport.plane.DividingPlane`
    (3 DoF): anything with ``area``, ``sample``, ``states``, ``system``, ``saddle`` and ``normal``.

    Points (u, p_u) are drawn uniformly on the allowed region of the line (area A, the directional
    flux), each crossing outwards (p_n > 0), and weighted w = +1 if its trajectory comes from the
    well and goes to the products, −1 if it comes from the products and goes to the well, else 0.
    A reactive trajectory that crosses the line 2k + 1 times crosses it k + 1 times outwards and
    k times inwards; by time reversal (p → −p) each inward crossing of it is an outward sample of
    weight −1, so its net count is one. The flux is A·mean(w), its standard error A·std(w)/√N,
    with var(w) at least 1/N (so never below A/N: a one-sigma-sized error when every sample has the
    same weight, not a 95 % bound; see where it is set).
    Batches of ``batch`` samples are drawn until the relative standard error is at most
    ``target_stderr`` or ``max_samples`` is reached.
    """
    flow = FlowSettings() if flow is None else flow
    rng = np.random.default_rng(seed)
    area = line.area()
    weights, undecided = [], 0
    while True:
        u, pu = line.sample(batch, rng)
        w, open_ = classify(line, line.states(u, pu), commit=commit, duration=duration, sample_step=sample_step,
                            flow=flow, threads=threads)
        weights.append(w)
        undecided += int(open_.sum())
        allw = np.concatenate(weights)
        mean = float(allw.mean())
        # Floor on the variance of w: 1/N, the sample variance (ddof=1) of N − 1 equal weights and one
        # that differs by 1, as if one sample in N had another weight. Without it a batch of
        # all-reactive samples (common at low energy, where recrossings are rare) would claim a zero
        # standard error. With none of N samples non-reactive, the exact (Clopper–Pearson) one-sided
        # upper bound on their fraction at confidence 1 − α is 1 − α^{1/N} ≈ −ln α / N: the flux lies
        # within k floor errors below the estimate with confidence ≈ 1 − e^{−k}, 63 % for k = 1 and
        # 95 % for k = 3 (the rule of three, 3/N), not the 84 % and 99.9 % of k normal errors.
        variance = max(float(allw.var(ddof=1)), 1.0 / len(allw))
        stderr = math.sqrt(variance / len(allw))
        if (mean != 0 and stderr <= target_stderr * abs(mean)) or len(allw) >= max_samples:
            break
    reactive = int(np.sum(allw > 0))
    antireactive = int(np.sum(allw < 0))
    return MonteCarloFlux(
        flux=area * mean, stderr=area * stderr, surface_flux=area, samples=len(allw), reactive=reactive,
        antireactive=antireactive, nonreactive=len(allw) - reactive - antireactive - undecided, undecided=undecided,
    )
