"""The flow map of the C-grid interpolant by exact cell crossing: no step control, no tolerance.

In a cell of ``kernels/staggered_velocity.py`` and a data interval the interpolant separates:
the index velocity along i is (U_w(s) + (U_e(s) - U_w(s)) a) times the cell's scale, a in
[0, 1] the position from the cell's west face and U_w, U_e the cubics in time s of its two faces
(Keys' cubic convolution of their data), and likewise along j with b. Each fractional position obeys a scalar linear ODE with
polynomial coefficients, whose solution is an entire function of time; its Taylor series follows
from a three-term recurrence (Hairer, Nørsett & Wanner I, sec. I.8) and is summed here until its
terms fall below :data:`SERIES_TOL` cells. A trajectory therefore runs in pieces, each the part of
a data interval it spends in one cell: the piece ends where a or b first reaches a face (the root
of its series, located by safeguarded Newton), and the trajectory enters the next cell there.
This is the analytic cell crossing of TRACMASS (Döös et al. 2017) and Ariane (Blanke & Raynaud
1997) for a field linear in space within a cell, extended to the cubic time interpolation by the
series; it is the interpolant's trajectory to rounding, the limit DOP853 reaches at tight
tolerances, at a cost per face crossed instead of per step.

Where the kernel's velocity is zero the trajectory stops as DOP853's does: on a closed face (a
coast: the series never crosses it, to rounding, and the position is kept in its cell), at the
data's edge (the trajectory stops on the edge line, moved :data:`EDGE_OUTSIDE` outside, where
the stop flags see it), in a land cell or outside the cells read (it does not move). A face is looked
for at :data:`SAMPLES` points of a piece: a trajectory that touches a face and turns back between
two of them (a tangency within a fraction of a data step) is kept in its cell, an error of the
excursion's depth times the cell-to-cell jump of the velocity along the face.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from .regular import HEADER
from .staggered import LAND_AT, V_AT

#: The series' last two terms at the piece's end below this (in cells) end the sum.
SERIES_TOL = 1e-15
#: The most terms of a series; a piece whose series has not converged by then is halved.
MAX_TERMS = 40
#: Points of a piece at which the positions are checked for a face passed (see the module docstring).
SAMPLES = 4
#: How far past the data's edge (in cells) a trajectory that reaches it is left: outside to the stop
#: flags through the round trip to the grid's coordinates and back (rounding there: ~1e-13 cells).
EDGE_OUTSIDE = 1e-9
RECIPROCALS = 1.0 / np.maximum(np.arange(MAX_TERMS), 1.0)
# Outcome codes (ldpipe.engine's flow_status): the duration integrated, or failed (the piece cap, a state not finite).
COMPLETED, FAILED = 0, 3


@njit(cache=True)
def _time_cubic(data, at, k, st, out, frozen):
    """out[0..3]: the coefficients in the offset from st of the cubic convolution of the four times
    data[at + k .. at + k + 3] (Catmull-Rom between the middle two), st in [0, 1]; ``frozen``:
    its value at st alone (the kernel holds the data's end values beyond its times)."""
    d0, d1, d2, d3 = data[at + k], data[at + k + 1], data[at + k + 2], data[at + k + 3]
    c1 = 0.5 * (d2 - d0)
    c2 = d0 - 2.5 * d1 + 2.0 * d2 - 0.5 * d3
    c3 = -0.5 * d0 + 1.5 * d1 - 1.5 * d2 + 0.5 * d3
    out[0] = d1 + st * (c1 + st * (c2 + st * c3))
    if frozen:
        out[1] = out[2] = out[3] = 0.0
    else:
        out[1] = c1 + st * (2.0 * c2 + 3.0 * st * c3)
        out[2] = c2 + 3.0 * st * c3
        out[3] = c3


@njit(cache=True)
def _series(x0, p, q, scale, h, c):
    """Taylor coefficients c of x' = scale (p(s) + q(s) x), x(0) = x0, p and q cubics; returns
    (the number of coefficients summed, the span <= h over which the sum has converged)."""
    c[0] = x0
    hn = 1.0  # h ** n
    small = False  # the previous term at the span below SERIES_TOL
    for n in range(MAX_TERMS - 1):
        acc = p[n] if n < 4 else 0.0
        for m in range(min(3, n) + 1):
            acc += q[m] * c[n - m]
        c[n + 1] = scale * acc * RECIPROCALS[n + 1]
        hn *= h
        tiny = abs(c[n + 1]) * hn < SERIES_TOL
        if tiny and small:
            return n + 2, h
        small = tiny
    for _ in range(64):  # not converged over the span in MAX_TERMS terms (a rare, fast piece): a shorter one
        h *= 0.5
        hn = 1.0
        for n in range(1, MAX_TERMS - 1):
            hn *= h
            if abs(c[n]) * hn < SERIES_TOL and abs(c[n + 1]) * hn * h < SERIES_TOL:
                return n + 2, h
    return MAX_TERMS, h  # not finite: the caller fails the trajectory


@njit(cache=True)
def _value(c, n, s):
    value = c[n - 1]
    for m in range(n - 2, -1, -1):
        value = value * s + c[m]
    return value


@njit(cache=True)
def _slope(c, n, s):
    value = (n - 1) * c[n - 1]
    for m in range(n - 2, 0, -1):
        value = value * s + m * c[m]
    return value


@njit(cache=True)
def _face_time(c, n, face, lo, hi, x_lo, x_hi):
    """The s in [lo, hi] where the series c reaches ``face``, given it is short of it at lo (x_lo)
    and past it at hi (x_hi): safeguarded Newton from the secant's root, bisection where a Newton
    step leaves the bracket."""
    outward = 1.0 if face > 0.5 else -1.0
    s = lo + (hi - lo) * (face - x_lo) / (x_hi - x_lo)
    for _ in range(100):
        g = (_value(c, n, s) - face) * outward
        if g > 0.0:
            hi = s
        else:
            lo = s
        slope = _slope(c, n, s) * outward
        newton = s - g / slope if slope > 0.0 else -1.0
        if lo <= newton <= hi:
            if abs(newton - s) <= 4e-16 * max(1.0, abs(s)):
                return newton
            s = newton
        else:
            s = 0.5 * (lo + hi)
            if hi - lo <= 4e-16:
                return hi
    return hi


@njit(nogil=True, cache=True)
def cell_crossing_endpoints(states, start, stop, data, t0, direction, tau, max_pieces, o_end, o_status, o_time,
                            o_steps):
    """End indices (i, j) of trajectories start..stop-1 of ``states`` (rows of the grid's fractional
    indices) over |t - t0| = tau in ``direction`` (+1, -1) through the C-grid window ``data`` (the
    staggered kernel's buffer, at even times), with the outcome codes, the time |t - t0| reached and the pieces run (at
    most ``max_pieces``, else the trajectory fails where it is)."""
    nt, ny, nx = int(data[0]), int(data[1]), int(data[2])
    t_first, dt = data[7], data[8]
    v_at, land_at = int(data[V_AT]), int(data[LAND_AT])
    qt = nt + 2
    pa, qa, pb, qb = np.zeros(4), np.zeros(4), np.zeros(4), np.zeros(4)
    other = np.zeros(4)
    ca, cb = np.zeros(MAX_TERMS), np.zeros(MAX_TERMS)
    i0, j0 = data[3], data[5]  # the window's first centre (its box of the grid; integers: exact)
    for kk in range(start, stop):
        fi, fj = states[kk, 0] - i0, states[kk, 1] - j0
        o_end[kk, 0], o_end[kk, 1] = states[kk, 0], states[kk, 1]
        o_steps[kk] = 0
        if not (math.isfinite(fi) and math.isfinite(fj)):
            o_status[kk], o_time[kk] = FAILED, 0.0
            continue
        o_status[kk], o_time[kk] = COMPLETED, tau
        if not (fi >= 0.5 and fi <= nx - 1.5 and fj >= 0.5 and fj <= ny - 1.5):
            continue  # outside the cells read: the velocity is zero
        i, j = min(int(fi + 0.5), nx - 2), min(int(fj + 0.5), ny - 2)
        if data[land_at + j * nx + i] > 0.0:
            continue  # on land: no velocity
        a, b = fi - (i - 0.5), fj - (j - 0.5)
        # time as the data interval k and the fraction st of it, kept as such (not recomputed
        # from t, whose rounding could stall a trajectory at an interval's end)
        ft = (t0 - t_first) / dt
        k = min(max(int(math.floor(ft)) if direction > 0 else int(math.ceil(ft)) - 1, 0), nt - 2)
        st = min(max(ft - k, 0.0), 1.0)
        remaining = tau / dt  # in data steps
        pieces, status = 0, COMPLETED
        while remaining > 0.0:
            if pieces >= max_pieces:
                status = FAILED
                break
            pieces += 1
            to_end = 1.0 - st if direction > 0 else st  # to the interval's end
            # beyond the data's first or last time the kernel holds its values there
            frozen = to_end <= 0.0 and (k == nt - 2 if direction > 0 else k == 0)
            span = remaining if frozen else min(to_end, remaining)
            west = HEADER + (j * (nx - 1) + i - 1) * qt
            south = v_at + ((j - 1) * nx + i) * qt
            _time_cubic(data, west, k, st, pa, frozen)
            _time_cubic(data, west + qt, k, st, other, frozen)
            for m in range(4):
                qa[m] = other[m] - pa[m]
            _time_cubic(data, south, k, st, pb, frozen)
            _time_cubic(data, south + nx * qt, k, st, other, frozen)
            for m in range(4):
                qb[m] = other[m] - pb[m]
            if direction < 0:  # in the reversed time -s: odd powers change sign
                pa[1], pa[3], qa[1], qa[3] = -pa[1], -pa[3], -qa[1], -qa[3]
                pb[1], pb[3], qb[1], qb[3] = -pb[1], -pb[3], -qb[1], -qb[3]
            # the cell's scale (1 / its area when the faces carry fluxes, else 1), after the land
            scale = dt * direction * data[land_at + ny * nx + j * nx + i]
            na, span = _series(a, pa, qa, scale, span, ca)
            nb, span = _series(b, pb, qb, scale, span, cb)
            # Faces a trajectory may pass: open ones (water beyond) and the data's edge; a closed
            # face (land beyond) it reaches only to rounding, and stays in its cell.
            east_open = i + 1 > nx - 2 or data[land_at + j * nx + i + 1] == 0.0
            west_open = i - 1 < 1 or data[land_at + j * nx + i - 1] == 0.0
            north_open = j + 1 > ny - 2 or data[land_at + (j + 1) * nx + i] == 0.0
            south_open = j - 1 < 1 or data[land_at + (j - 1) * nx + i] == 0.0
            lo, exit_s, exit_axis, exit_face = 0.0, span, -1, 0.0
            a_lo, b_lo = a, b
            for m in range(1, SAMPLES + 1):
                s = span * m / SAMPLES
                va, vb = _value(ca, na, s), _value(cb, nb, s)
                out_a = (va > 1.0 and east_open) or (va < 0.0 and west_open)
                out_b = (vb > 1.0 and north_open) or (vb < 0.0 and south_open)
                if out_a or out_b:
                    if out_a:
                        exit_face = 1.0 if va > 1.0 else 0.0
                        exit_s, exit_axis = _face_time(ca, na, exit_face, lo, s, a_lo, va), 0
                    if out_b:
                        face = 1.0 if vb > 1.0 else 0.0
                        sb = _face_time(cb, nb, face, lo, s, b_lo, vb)
                        if exit_axis < 0 or sb < exit_s:
                            exit_s, exit_axis, exit_face = sb, 1, face
                    break
                lo, a_lo, b_lo = s, va, vb
            a = min(max(_value(ca, na, exit_s), 0.0), 1.0)
            b = min(max(_value(cb, nb, exit_s), 0.0), 1.0)
            if not (math.isfinite(ca[na - 1]) and math.isfinite(cb[nb - 1])):
                status = FAILED
                break
            if exit_axis < 0 and exit_s == span and span == remaining:
                remaining = 0.0
                continue
            remaining -= exit_s
            if exit_axis < 0 and exit_s == span and not frozen and span == to_end:  # on to the next interval
                k, st = (k + 1, 0.0) if direction > 0 else (k - 1, 1.0)
            elif not frozen:
                st = min(max(st + direction * exit_s, 0.0), 1.0)
            if exit_axis < 0:
                continue
            step = 1 if exit_face > 0.5 else -1
            if exit_axis == 0:
                i += step
                a = 0.0 if step > 0 else 1.0
                leaving = i < 1 or i > nx - 2
            else:
                j += step
                b = 0.0 if step > 0 else 1.0
                leaving = j < 1 or j > ny - 2
            if leaving:  # on the data's edge, where the velocity is zero: moved just outside, stopped
                fi, fj = i - 0.5 + a, j - 0.5 + b
                if exit_axis == 0:
                    fi += step * EDGE_OUTSIDE
                else:
                    fj += step * EDGE_OUTSIDE
                o_end[kk, 0], o_end[kk, 1] = fi + i0, fj + j0
                break
        else:
            o_end[kk, 0], o_end[kk, 1] = i - 0.5 + a + i0, j - 0.5 + b + j0
        if status == FAILED:
            o_end[kk, 0], o_end[kk, 1] = i - 0.5 + a + i0, j - 0.5 + b + j0
            o_time[kk] = tau - remaining * dt
        o_status[kk] = status
        o_steps[kk] = pieces
