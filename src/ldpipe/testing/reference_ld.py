"""A careful, independent reference Lagrangian descriptor for one initial condition.

Independent of the rest of ``ldpipe``, on purpose: this module imports only numpy and scipy,
and the vector fields are written out here by hand, so it can judge the engine. It lives in the
package so that the benchmarks (benchmarks/compare.py, profile_engine.py, alternatives.py) and
the tests import it by name.

Method
------
1. Integrate the trajectory with scipy's ``solve_ivp`` (DOP853, rtol = atol = 1e-13 by default)
   and keep its dense output (a 7th-order interpolant on every step).
2. Locate every zero crossing of every phase-space velocity component ``f_i(x(t))`` on the dense
   output: each accepted step is sampled at a few interior points, and every sign change is
   refined with ``brentq`` to ~1e-15.  (Sampling inside the steps catches a pair of zeros that
   falls inside one step, which a sign test at the step ends alone would miss.)  Every local
   minimum of ``|f_i|`` on the samples is located too (bounded Brent on ``sign * f_i``): where it has
   the other sign it brackets a pair of crossings closer than the samples; otherwise it is a
   near-touch (``|f_i|`` dips towards zero and turns back, ``|f_i|**p`` ~ ``(a + b (t - t_m)**2)**p``,
   nearly singular when a is small) and the pieces are cut there as well.
3. Between consecutive crossings of component i, ``|f_i|**p`` behaves like ``|t - a|**p`` at an
   end that is a crossing and is smooth inside (nearly singular at most at an end that is a
   near-touch minimum, where the 48/80-node rules disagree and the piece goes to QAWS, which
   bisects adaptively towards that end).  Each such piece is integrated with
   ``scipy.integrate.quad(..., weight='alg', wvar=(alpha, beta))`` (QUADPACK QAWS), which takes
   the algebraic end-point factor ``(t - a)**alpha * (b - t)**beta`` out analytically; alpha = p
   at an end that is a crossing, 0 at an end that is t = 0 or t = tau.
4. The arc-length LD ``int ||f|| dt`` has a smooth integrand; it is integrated with plain ``quad``
   on the same pieces (the union of all crossings).

Accuracy: see ``estimate_accuracy`` and benchmarks/README.md (on the Barbanis section,
rtol 1e-13 vs 1e-11 agree to ~1e-12 relative; the closed-form tests in
tests/engine/test_reference_ld.py hold it to 5e-14 relative for M_1/2 and the arc length, 5e-13
with a box exit).

Variable time: ``box`` = {coordinate index: (lo, hi)} stops the integration (terminal event) the
first time one of those coordinates leaves [lo, hi]; the LD is then integrated up to that exit
time, which is returned.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass
from typing import Callable

import numpy as np
from scipy.integrate import IntegrationWarning, quad, solve_ivp
from scipy.optimize import brentq, minimize_scalar
from scipy.special import roots_jacobi

# Barbanis 2 DoF (Naik & Wiggins, sec. model_prob_2dof)
OMEGA_X = 1.0
OMEGA_Y = 1.1
DELTA = -0.11
E_SADDLE = 15.125


def barbanis_potential(x, y, omega_x=OMEGA_X, omega_y=OMEGA_Y, delta=DELTA):
    return 0.5 * omega_x**2 * x**2 + 0.5 * omega_y**2 * y**2 + delta * x * y**2


def barbanis_vector_field(state, omega_x=OMEGA_X, omega_y=OMEGA_Y, delta=DELTA):
    """Hamiltonian vector field of the Barbanis 2 DoF system; state (x, y, px, py), shape (4,) or (4, N)."""
    x, y, px, py = state[0], state[1], state[2], state[3]
    return np.array([px, py, -(omega_x**2 * x + delta * y * y), -(omega_y**2 * y + 2.0 * delta * x * y)])


def harmonic_vector_field(omegas: tuple[float, ...]) -> Callable[[np.ndarray], np.ndarray]:
    """Vector field of uncoupled oscillators V = sum(omega_i^2 q_i^2) / 2; state (q..., p...)."""
    w2 = np.asarray(omegas, dtype=float) ** 2
    n = len(omegas)

    def field(state):
        state = np.asarray(state)
        return np.concatenate([state[n:], -(w2 * state[:n].T).T])

    return field


def section_state(x, px, energy, omega_x=OMEGA_X, omega_y=OMEGA_Y, delta=DELTA):
    """Initial states on U_xpx: y = 0, p_y = +sqrt(2(E - V(x, 0)) - px^2).

    Returns (states, allowed): states has shape (..., 4), NaN where the point is forbidden.
    """
    x = np.asarray(x, dtype=float)
    px = np.asarray(px, dtype=float)
    py2 = 2.0 * (energy - barbanis_potential(x, 0.0, omega_x, omega_y, delta)) - px**2
    allowed = py2 >= 0.0
    py = np.sqrt(np.where(allowed, py2, np.nan))
    states = np.stack(np.broadcast_arrays(x, np.zeros_like(x), px, py), axis=-1)
    return states, allowed


@dataclass
class ReferenceLD:
    """Reference LD of one trajectory."""

    ld: float  # M_p, sum over all phase-space velocity components
    arclength: float  # int ||f|| dt
    t_end: float  # tau, or the exit time when the trajectory left the box first (always >= 0)
    exited: bool
    n_crossings: int  # zero crossings of velocity components found
    n_steps: int  # DOP853 steps
    quad_abserr: float  # sum of the quadrature's own error estimates (M_p)
    n_fallback: int = 0  # pieces where Gauss-Jacobi did not converge and QAWS was used
    n_minima: int = 0  # interior minima of some |f_i| that do not reach zero (pieces cut there)
    deepest_minimum: float = np.inf  # the smallest |f_i| at one of those minima


def _crossings(sol, field, t0, t1, component, samples_per_step):
    """Zero crossings and near-touch minima of field(x(t))[component] on (t0, t1), from the dense output.

    Returns (roots, minima), each sorted. ``minima`` are the interior local minima of |f| that
    do not reach zero (a near-touch: |f| dips towards 0 and turns back), located to ~1e-13 by
    bounded Brent minimisation of sign * f; where the minimum has the other sign, it is a pair of
    roots closer than the sampling, and both are added to ``roots`` instead.
    """
    ts = sol.ts
    # sample every step at `samples_per_step` points (ends included)
    frac = np.linspace(0.0, 1.0, samples_per_step + 1)[:-1]
    grid = (ts[:-1, None] + np.diff(ts)[:, None] * frac[None, :]).ravel()
    grid = np.append(grid, ts[-1])
    grid = grid[(grid >= t0) & (grid <= t1)]
    grid = np.unique(np.concatenate([[t0], grid, [t1]]))
    values = field(sol(grid))[component]

    def g(t):
        return field(sol(t))[component]

    def root(a, b):
        return brentq(g, a, b, xtol=1e-15, rtol=4 * np.finfo(float).eps, maxiter=200)

    roots = [root(grid[k], grid[k + 1]) for k in np.nonzero(values[:-1] * values[1:] < 0.0)[0]]
    # exact zeros on the sampling grid (rare) are crossings too, except at the ends
    for k in np.nonzero(values == 0.0)[0]:
        if 0 < k < len(grid) - 1:
            roots.append(grid[k])
    # local minima of |f| between samples of one sign
    minima = []
    a = np.abs(values)
    for k in np.nonzero((a[1:-1] < a[:-2]) & (a[1:-1] <= a[2:]) & (values[:-2] * values[2:] > 0.0)
                        & (values[1:-1] * values[:-2] > 0.0))[0] + 1:
        lo, hi = grid[k - 1], grid[k + 1]
        sign = np.sign(values[k])  # the minimum of sign * f: below zero, a pair of roots
        best = minimize_scalar(lambda t: sign * float(g(t)), bounds=(lo, hi), method="bounded",
                               options={"xatol": 1e-14 * max(1.0, abs(hi))})
        tm = float(best.x)
        fm = float(g(tm))
        if fm * values[k] < 0.0:  # a pair of roots between two samples
            roots += [root(lo, tm), root(tm, hi)]
        elif lo < tm < hi and fm != 0.0:
            minima.append(tm)
    return np.array(sorted(roots)), np.array(sorted(minima))


_RULES: dict = {}
_DEBUG = False


def _jacobi_rule(n: int, alpha: float, beta: float):
    """Nodes/weights on [-1, 1] for the weight (1+x)^alpha (1-x)^beta."""
    key = (n, alpha, beta)
    if key not in _RULES:
        _RULES[key] = roots_jacobi(n, beta, alpha)  # scipy: (1-x)^first (1+x)^second
    return _RULES[key]


def _integrate_pieces(pieces, integrand, quadrature, epsrel, epsabs, orders=(48, 80)):
    """Sum of int_a^b integrand * (t-a)^alpha (b-t)^beta dt over pieces; returns (value, err, n_fallback)."""
    total, err, fallback = 0.0, 0.0, 0
    for i, a, b, alpha, beta in pieces:
        if quadrature == "gauss-jacobi":
            half = 0.5 * (b - a)
            vals = []
            for n in orders:
                x, w = _jacobi_rule(n, alpha, beta)
                t = a + half * (x + 1.0)
                vals.append(half ** (1.0 + alpha + beta) * np.dot(w, integrand(i, t, a, b, alpha, beta)))
            diff = abs(vals[1] - vals[0])
            if diff <= max(epsabs, epsrel * abs(vals[1])) * 10:
                total += vals[1]
                err += diff
                continue
            fallback += 1
            if _DEBUG:
                print("fallback", i, a, b, alpha, beta, vals, diff)
        elif quadrature != "qaws":
            raise ValueError(f"unknown quadrature {quadrature!r}")

        def scalar(t, i=i, a=a, b=b, alpha=alpha, beta=beta):
            return float(integrand(i, np.array([t]), a, b, alpha, beta)[0])

        with warnings.catch_warnings():
            warnings.simplefilter("error", IntegrationWarning)
            val, e = quad(scalar, a, b, weight="alg", wvar=(alpha, beta),
                          epsabs=epsabs, epsrel=epsrel, limit=200)
        total += val
        err += e
    return total, err, fallback


def reference_ld(
    state0,
    tau: float = 50.0,
    p: float = 0.5,
    *,
    field: Callable[[np.ndarray], np.ndarray] = barbanis_vector_field,
    direction: int = +1,
    rtol: float = 1e-13,
    atol: float = 1e-13,
    quad_epsrel: float = 1e-13,
    quad_epsabs: float = 1e-15,
    box: dict[int, tuple[float, float]] | None = None,
    samples_per_step: int = 4,
    quadrature: str = "gauss-jacobi",
) -> ReferenceLD:
    """Reference LD of one trajectory, forward (direction=+1) or backward (-1) in time.

    Parameters
    ----------
    state0 : array_like, shape (n,)
        Initial state (q..., p...).
    tau : float
        Integration time (> 0).
    p : float
        Exponent of M_p, 0 < p <= 1.
    field : callable
        state (n,) or (n, N) -> velocity, same shape.
    direction : {+1, -1}
        Integrate forward or backward in time; the LD is an integral over |t|.
    box : dict, optional
        {coordinate index: (lo, hi)}: stop at the first exit from the box (variable-time LD).
    quadrature : {"gauss-jacobi", "qaws"}
        "gauss-jacobi" (default, fast): on every piece, Gauss-Jacobi rules with the weight
        (t-a)^alpha (b-t)^beta at 48 and 80 nodes; accepted when they agree to the requested
        tolerance, otherwise that piece falls back to QAWS.  "qaws": scipy.integrate.quad with
        weight='alg' (adaptive QUADPACK QAWS) on every piece -- slower, used as a cross-check.
    """
    state0 = np.asarray(state0, dtype=float)
    if direction not in (1, -1):
        raise ValueError("direction must be +1 or -1")
    # Integrate s(u) = x(direction * u), u in [0, tau]: ds/du = direction * f(s).
    def rhs(u, s):
        return direction * field(s)

    events = []
    if box:
        for index, (lo, hi) in box.items():
            for bound, sign in ((lo, 1.0), (hi, -1.0)):
                def event(u, s, index=index, bound=bound, sign=sign):
                    return sign * (s[index] - bound)

                event.terminal = True
                event.direction = -1.0
                events.append(event)
    sol_ivp = solve_ivp(rhs, (0.0, tau), state0, method="DOP853", rtol=rtol, atol=atol,
                        dense_output=True, events=events or None)
    if sol_ivp.status == -1:
        raise RuntimeError(f"reference integration failed: {sol_ivp.message}")
    sol = sol_ivp.sol
    t_end = float(sol_ivp.t[-1])
    exited = sol_ivp.status == 1

    n = state0.size
    # the velocity in u differs from f only by the sign `direction`; |.| is unchanged
    found = [_crossings(sol, field, 0.0, t_end, i, samples_per_step) for i in range(n)]
    all_roots = [roots for roots, _ in found]
    pieces = []  # (component, a, b, alpha, beta)
    for i, (roots, minima) in enumerate(found):
        # cut at the roots (cusp factor p at a root end) and at the near-touch minima (no factor;
        # the near-singular end is left to the adaptive fallback when Gauss-Jacobi disagrees)
        ends = np.concatenate([[0.0], roots, minima, [t_end]])
        is_root = np.concatenate([[False], np.ones(len(roots), bool), np.zeros(len(minima), bool), [False]])
        order = np.argsort(ends, kind="stable")
        ends, is_root = ends[order], is_root[order]
        for k in range(len(ends) - 1):
            if ends[k + 1] > ends[k]:
                pieces.append((i, ends[k], ends[k + 1], p if is_root[k] else 0.0, p if is_root[k + 1] else 0.0))
    breaks = np.unique(np.concatenate([[0.0], *all_roots, [t_end]]))
    arc_pieces = [(-1, a, b, 0.0, 0.0) for a, b in zip(breaks[:-1], breaks[1:])]

    def integrand(i, t, a, b, alpha, beta):
        f = field(sol(t))
        if i < 0:  # arc length
            return np.sqrt(np.sum(f * f, axis=0))
        # |v|^p / ((t-a)^alpha (b-t)^beta) is smooth on [a, b]
        den = np.maximum(t - a, 0.0) ** alpha * np.maximum(b - t, 0.0) ** beta
        num = np.abs(f[i]) ** p
        return np.divide(num, den, out=np.zeros_like(num), where=den > 0.0)

    ld, ld_err, ld_fallback = _integrate_pieces(pieces, integrand, quadrature, quad_epsrel, quad_epsabs)
    arclength, _, arc_fallback = _integrate_pieces(arc_pieces, integrand, quadrature, quad_epsrel, quad_epsabs)
    return ReferenceLD(ld=float(ld), arclength=float(arclength), t_end=t_end, exited=exited,
                       n_crossings=int(sum(len(r) for r in all_roots)),
                       n_minima=int(sum(len(m) for _, m in found)),
                       deepest_minimum=min([np.inf] + [float(np.min(np.abs(field(sol(m))[i])))
                                                       for i, (_, m) in enumerate(found) if len(m)]),
                       n_steps=len(sol_ivp.t) - 1, quad_abserr=float(ld_err),
                       n_fallback=ld_fallback + arc_fallback)


def reference_ld_many(states, tau=50.0, p=0.5, **kwargs) -> tuple[np.ndarray, np.ndarray]:
    """(M_p, arclength) for an array of states, shape (N, n)."""
    out = [reference_ld(s, tau, p, **kwargs) for s in np.atleast_2d(states)]
    return np.array([r.ld for r in out]), np.array([r.arclength for r in out])


def estimate_accuracy(states, tau=50.0, p=0.5, loose=1e-11, tight=1e-13, **kwargs) -> dict:
    """Relative difference of the reference at two tolerance levels (a bound on the loose one's error)."""
    ld_l, arc_l = reference_ld_many(states, tau, p, rtol=loose, atol=loose, **kwargs)
    ld_t, arc_t = reference_ld_many(states, tau, p, rtol=tight, atol=tight, **kwargs)
    d_ld = np.abs(ld_l - ld_t) / np.abs(ld_t)
    d_arc = np.abs(arc_l - arc_t) / np.abs(arc_t)
    return {
        "tolerances": [loose, tight],
        "n": int(len(ld_t)),
        "ld_reldiff_median": float(np.median(d_ld)),
        "ld_reldiff_max": float(np.max(d_ld)),
        "arclength_reldiff_median": float(np.median(d_arc)),
        "arclength_reldiff_max": float(np.max(d_arc)),
    }


if __name__ == "__main__":  # quick look: python -m ldpipe.testing.reference_ld
    import time

    rng = np.random.default_rng(1)
    energy = E_SADDLE - 0.125
    pts = []
    while len(pts) < 5:
        x, px = rng.uniform(-5.5, 5.5), rng.uniform(-5.5, 5.5)
        s, ok = section_state(x, px, energy)
        if ok:
            pts.append(s)
    pts = np.array(pts)
    t0 = time.perf_counter()
    r = reference_ld(pts[0])
    print(r, f"{time.perf_counter() - t0:.2f} s")
    t0 = time.perf_counter()
    q = reference_ld(pts[0], quadrature="qaws")
    print(q, f"{time.perf_counter() - t0:.2f} s", "rel diff", abs(q.ld - r.ld) / r.ld)
    print(estimate_accuracy(pts))
