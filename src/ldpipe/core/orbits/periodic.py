"""Lyapunov periodic orbits of an index-1 saddle: differential correction, continuation, stability.

The method is the paper's appendix (``ssect:tube_mani``, after Koon et al.),
written for n degrees of freedom:

* **Seed.** At the saddle, Hess V u = h M u (M the kinetic matrix, the identity
  without masses) has one negative eigenvalue -lambda^2 (the reaction direction)
  and n - 1 positive ones omega_j^2 (centres). A centre's
  eigenvector u (position part; the phase-space eigenvector is (u, +-i omega u))
  is scaled so that its largest component, the *held* coordinate k, is 1. A
  small orbit starts at rest at q0 = q_eq + A u.
* **Differential correction.** The Lyapunov orbits of H = p^T M^-1 p / 2 + V(q) are
  brake orbits: all momenta (and so all velocities M^-1 p) vanish at the two
  turning points, half a period apart. Holding q0_k, the other n - 1 coordinates of q0 are corrected by Newton
  steps until, at the next zero of p_k (the half-period event), every other
  momentum vanishes too. With Phi the state transition matrix at the event and
  f the vector field there, the Jacobian is
  ``J = Phi[p_free, q_free] - f[p_free] Phi[p_k, q_free] / f[p_k]``
  (the paper's (Phi_42 - Phi_32 vy'/vx')^-1 for n = 2).
* **Continuation.** Natural-parameter continuation in the amplitude A = q0_k -
  q_eq,k, with a secant predictor for the corrected coordinates and an
  adaptive step; a correction larger than the step is refused (and the step
  halved), so the family cannot jump to another one.
* **Target energies.** Two members bracketing a target energy are refined by
  bracketed root finding on A (Illinois regula falsi, i.e. bisection with
  secant steps), correcting the orbit at every trial amplitude.
* **Stability.** The monodromy matrix M = Phi(T) and its eigenvalues, the
  Floquet multipliers: lambda, 1/lambda, 1, 1 for 2 DoF (the unit pair is
  numerically split by about sqrt(machine precision)).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ...logs import get_logger
from ...systems import System
from ..variational import propagate, sample

log = get_logger(__name__)


class CorrectionFailed(RuntimeError):
    """Differential correction did not converge from the guess given."""


@dataclass(frozen=True)
class SaddleLinearization:
    """The linearization at an index-1 saddle, from Hess V u = h M u there.

    ``saddle_rate`` is lambda (eigenvalues +-lambda of the Jacobian); ``omegas``
    are the centre frequencies in increasing order and ``center_vectors[:, j]``
    the position part of centre j's eigenvector, scaled so that its largest
    component is +1.
    """

    position: np.ndarray
    critical_energy: float
    saddle_rate: float
    saddle_vector: np.ndarray
    omegas: np.ndarray
    center_vectors: np.ndarray


def linearize_saddle(system: System, position: np.ndarray) -> SaddleLinearization:
    position = np.asarray(position, dtype=np.float64)
    values, vectors = system.normal_modes(position)
    if not (values[0] < 0 < values[1]):
        raise ValueError(f"{system.name}: the point {position} is not an index-1 saddle (Hess V eigenvalues {values})")
    centers = vectors[:, 1:].copy()
    for j in range(centers.shape[1]):
        k = int(np.argmax(np.abs(centers[:, j])))
        centers[:, j] /= centers[k, j]
    return SaddleLinearization(
        position=position, critical_energy=system.potential(position), saddle_rate=float(np.sqrt(-values[0])),
        saddle_vector=vectors[:, 0].copy(), omegas=np.sqrt(values[1:]), center_vectors=centers,
    )


@dataclass(frozen=True)
class CorrectorSettings:
    """Numerical settings of the differential corrector.

    ``tolerance`` bounds the closure error ||x(T) - x(0)|| of an accepted target
    orbit; family members are accepted when the half-period residual (the free
    momenta at the half-period event) is below ``tolerance``. ``rtol``/``atol``
    are DOP853's tolerances.
    """

    tolerance: float = 1e-10
    max_iterations: int = 20
    rtol: float = 1e-13
    atol: float = 1e-13


@dataclass
class BrakeOrbit:
    """A corrected Lyapunov orbit, started at rest at ``initial_state``."""

    amplitude: float
    initial_state: np.ndarray
    half_period: float
    energy: float
    residual: float
    iterations: int
    closure_error: float = 0.0
    monodromy: np.ndarray | None = field(default=None, repr=False)

    @property
    def period(self) -> float:
        return 2.0 * self.half_period


class LyapunovFamily:
    """The Lyapunov family of one centre mode of an index-1 saddle."""

    def __init__(self, system: System, saddle: SaddleLinearization, mode: int, settings: CorrectorSettings):
        if not 0 <= mode < len(saddle.omegas):
            raise ValueError(f"centre mode {mode} does not exist; the saddle has {len(saddle.omegas)} centre modes")
        self.system = system
        self.saddle = saddle
        self.mode = mode
        self.settings = settings
        self.direction = saddle.center_vectors[:, mode]
        self.held = int(np.argmax(np.abs(self.direction)))
        self.free = [i for i in range(system.n_dof) if i != self.held]
        self.omega = float(saddle.omegas[mode])
        self.members: list[BrakeOrbit] = []

    # -- one orbit -------------------------------------------------------------------------
    def initial_state(self, amplitude: float, free_coordinates: np.ndarray) -> np.ndarray:
        n = self.system.n_dof
        state = np.zeros(2 * n)
        state[:n] = self.saddle.position
        state[self.held] += amplitude
        state[self.free] = free_coordinates
        return state

    def linear_guess(self, amplitude: float) -> np.ndarray:
        return (self.saddle.position + amplitude * self.direction)[self.free]

    def correct(self, amplitude: float, free_guess: np.ndarray) -> BrakeOrbit:
        """Differential correction at fixed amplitude from ``free_guess`` (the other coordinates)."""
        system, s = self.system, self.settings
        n = system.n_dof
        free = np.asarray(self.free)
        z = np.array(free_guess, dtype=np.float64)
        # At rest at q0 = q_eq + A u the restoring force sends p_k against A; it returns to 0 increasing
        # (A > 0) or decreasing (A < 0) at the other turning point.
        direction = 1 if amplitude > 0 else -1
        residual = previous = np.inf
        for iteration in range(1, s.max_iterations + 1):
            state = self.initial_state(amplitude, z)
            end = propagate(system, state, 50.0 * np.pi / self.omega, rtol=s.rtol, atol=s.atol,
                            event_momentum=self.held, event_direction=direction)
            if not end.event:
                raise CorrectionFailed(f"no half-period event within 25 linear periods (amplitude {amplitude:g})")
            r = end.state[n + free]
            residual = float(np.max(np.abs(r))) if len(free) else 0.0
            if not np.all(np.isfinite(end.state)):
                raise CorrectionFailed(f"the trajectory diverged (amplitude {amplitude:g})")
            # Converged: well below the tolerance, or below it and no longer improving (round-off floor).
            if len(free) == 0 or residual < 1e-3 * s.tolerance or (residual < s.tolerance and residual > 0.1 * previous):
                break
            previous = residual
            f = system.vector_field(end.state)
            phi = end.stm
            jac = phi[np.ix_(n + free, free)] - np.outer(f[n + free], phi[n + self.held, free]) / f[n + self.held]
            try:
                step = np.linalg.solve(jac, r)
            except np.linalg.LinAlgError:
                raise CorrectionFailed(f"singular correction matrix (amplitude {amplitude:g})") from None
            z = z - step
        else:
            if residual >= s.tolerance:
                raise CorrectionFailed(
                    f"no convergence in {s.max_iterations} iterations (amplitude {amplitude:g}, residual {residual:.3g})"
                )
        if residual >= s.tolerance:
            raise CorrectionFailed(f"stalled at residual {residual:.3g} (amplitude {amplitude:g})")
        state = self.initial_state(amplitude, z)
        return BrakeOrbit(
            amplitude=amplitude, initial_state=state, half_period=end.time, energy=system.energy(state),
            residual=residual, iterations=iteration,
        )

    def finish(self, orbit: BrakeOrbit) -> BrakeOrbit:
        """Integrate one full period for the monodromy matrix and the closure error."""
        s = self.settings
        end = propagate(self.system, orbit.initial_state, orbit.period, rtol=s.rtol, atol=s.atol)
        orbit.monodromy = end.stm
        orbit.closure_error = float(np.linalg.norm(end.state - orbit.initial_state))
        if orbit.closure_error > s.tolerance:
            raise CorrectionFailed(
                f"closure error {orbit.closure_error:.3g} over a period exceeds the tolerance {s.tolerance:g} "
                f"at energy {orbit.energy:.12g}; tighten the integrator tolerances or loosen the correction tolerance"
            )
        return orbit

    def saddle_orbit(self) -> BrakeOrbit:
        """The zero-amplitude limit: the saddle itself, with the linear period and monodromy."""
        n = self.system.n_dof
        state = np.concatenate([self.saddle.position, np.zeros(n)])
        period = 2.0 * np.pi / self.omega
        jac = self.system.jacobian(state)
        values, vectors = np.linalg.eig(jac)
        monodromy = (vectors @ np.diag(np.exp(values * period)) @ np.linalg.inv(vectors)).real
        return BrakeOrbit(amplitude=0.0, initial_state=state, half_period=period / 2, energy=self.saddle.critical_energy,
                          residual=0.0, iterations=0, closure_error=0.0, monodromy=monodromy)

    # -- the family ------------------------------------------------------------------------
    def continue_to(self, energy: float, *, initial_amplitude: float, max_step: float, max_members: int) -> None:
        """Continue the family from the seed until a member's energy reaches ``energy``."""
        if not self.members:
            for amplitude in (initial_amplitude, 2.0 * initial_amplitude):
                self.members.append(self.correct(amplitude, self.linear_guess(amplitude)))
        step = min(initial_amplitude, max_step)
        min_step = 1e-6 * initial_amplitude
        while self.members[-1].energy < energy:
            if len(self.members) >= max_members:
                raise CorrectionFailed(
                    f"{max_members} members reached before energy {energy:.12g} (last {self.members[-1].energy:.12g}); "
                    "raise continuation.max_members or continuation.max_step"
                )
            a, b = self.members[-2], self.members[-1]
            amplitude = b.amplitude + step
            slope = (b.initial_state[self.free] - a.initial_state[self.free]) / (b.amplitude - a.amplitude)
            guess = b.initial_state[self.free] + slope * step
            try:
                orbit = self.correct(amplitude, guess)
                jump = float(np.max(np.abs(orbit.initial_state[self.free] - guess))) if self.free else 0.0
                if jump > max(step, 10 * self.settings.tolerance):
                    raise CorrectionFailed(f"correction {jump:.3g} larger than the step {step:.3g}")
                if orbit.energy <= b.energy or orbit.half_period <= 0:
                    raise CorrectionFailed("energy did not increase along the family")
            except CorrectionFailed as error:
                step /= 2.0
                log.debug("continuation step refused (%s); step now %.3g", error, step)
                if step < min_step:
                    raise CorrectionFailed(
                        f"continuation stalled at amplitude {b.amplitude:.6g}, energy {b.energy:.12g}: {error}"
                    ) from None
                continue
            self.members.append(orbit)
            if orbit.iterations <= 4:
                step = min(2.0 * step, max_step)

    def at_energy(self, energy: float, *, energy_tolerance: float, max_iterations: int = 200) -> BrakeOrbit:
        """The member at ``energy``, bracketed by two family members and refined (Illinois regula falsi)."""
        ec = self.saddle.critical_energy
        if energy < ec:
            raise ValueError(f"energy {energy!r} is below the saddle's critical energy {ec!r}: no Lyapunov orbit")
        if energy - ec <= energy_tolerance:
            return self.saddle_orbit()
        members = [self.saddle_orbit(), *self.members]
        energies = np.array([m.energy for m in members])
        if energy > energies[-1]:
            raise ValueError(f"energy {energy!r} beyond the continued family (up to {energies[-1]!r})")
        k = int(np.searchsorted(energies, energy))  # energies[k-1] < energy <= energies[k]
        lo, hi = members[k - 1], members[k]
        if abs(hi.energy - energy) <= energy_tolerance:
            return self.finish(hi)
        lo_z = lo.initial_state[self.free]
        hi_z = hi.initial_state[self.free]
        a_lo, f_lo = lo.amplitude, lo.energy - energy
        a_hi, f_hi = hi.amplitude, hi.energy - energy
        side = 0
        for _ in range(max_iterations):
            a = (a_lo * f_hi - a_hi * f_lo) / (f_hi - f_lo)
            if not min(a_lo, a_hi) < a < max(a_lo, a_hi):
                a = 0.5 * (a_lo + a_hi)
            w = (a - a_lo) / (a_hi - a_lo)
            orbit = self.correct(a, (1 - w) * lo_z + w * hi_z)
            f = orbit.energy - energy
            if abs(f) <= energy_tolerance:
                return self.finish(orbit)
            if f < 0:
                a_lo, f_lo, lo_z = a, f, orbit.initial_state[self.free]
                if side == -1:
                    f_hi /= 2.0
                side = -1
            else:
                a_hi, f_hi, hi_z = a, f, orbit.initial_state[self.free]
                if side == 1:
                    f_lo /= 2.0
                side = 1
        raise CorrectionFailed(f"energy {energy!r} not reached within {energy_tolerance:g} in {max_iterations} iterations")


def floquet_multipliers(monodromy: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Eigenvalues and eigenvectors of the monodromy matrix, ordered lambda, 1/lambda, then the
    rest by decreasing distance from 1 (the trivial pair, 1 and 1, last); conjugates + first."""
    values, vectors = np.linalg.eig(monodromy)
    largest = int(np.argmax(np.abs(values)))
    rest = [i for i in range(len(values)) if i != largest]
    smallest = rest[int(np.argmin(np.abs(values[rest])))]
    rest = [i for i in rest if i != smallest]
    rest.sort(key=lambda i: (-round(abs(values[i] - 1.0), 6), -values[i].imag))
    order = [largest, smallest, *rest]
    return values[order], vectors[:, order]


def sample_orbit(system: System, orbit: BrakeOrbit, samples: int, settings: CorrectorSettings) -> tuple[np.ndarray, np.ndarray]:
    """``samples`` states evenly spaced in time over one period, both ends included."""
    times = np.linspace(0.0, orbit.period, samples)
    if orbit.amplitude == 0.0:
        return times, np.repeat(orbit.initial_state[None, :], samples, axis=0)
    states, _ = sample(system, orbit.initial_state, times, rtol=settings.rtol, atol=settings.atol)
    return times, states
