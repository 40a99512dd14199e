"""Template: the LD quadrature of the special path's items with two roots in or beside the step.

``special`` (block_quadrature.py) marks R_OK = TWO_ROOTS for an item with no zero end and
either exactly two sign changes on its samples (0, the Gauss nodes, 1) and no root near either
end outside, or one sign change and a root near one end outside (within ``window`` by linear
extrapolation, or, where v moves away from zero at that end, by the end's quadratic model;
R_FAR is then the far end of its search interval, -2 window or 1 + 2 window).
``two_roots`` then does what ``component_integral`` would for it: both roots r1 < r2 by Newton
from the regula falsi point of their brackets (the sample brackets; the search interval between
the end and R_FAR for a root outside), kept inside them (as the one-root case of ``special``),
then, with m = (r1 + r2) / 2,

    int_0^1 |v|^p = F(r1 -> 0) + J(r1 -> m) + J(r2 -> m) + F(r2 -> 1)        both inside,
                  = F(r1 -> 0) + J(r1 -> m) + J(r2 -> m) - J(r2 -> 1)        r2 > 1, m <= 1,
                  = F(r1 -> 0) + J(r1 -> 1)                                  r2 > 1, m > 1,

and mirrored for r1 < 0 (-J(r1 -> 0) + J(r1 -> m) + J(r2 -> m) + F(r2 -> 1) for m >= 0, else
J(r2 -> 0) + F(r2 -> 1)). Each Jacobi piece so has the other root at least its own length beyond
its end (rho >= 3 + 2 sqrt 2, as ``_from_root``'s pieces).

where J(r -> e) is the Gauss–Jacobi integral from the root r with the weight |s - r|^p taken
out, and F(r -> e) is ``_from_root``'s graded rule with the other root gap = r2 - r1 beyond r:
J over [r, r +- min(gap, |e - r|)], then Gauss–Legendre on pieces each as long as their
distance from r (so that the other root's cusp never lies closer to a piece than its length),
at most GRADING_LEVELS of them. An item that needs more (gap < |e - r| 2^-GRADING_LEVELS),
whose Newton did not converge, whose roots coincide in floating point, or whose root near an
end does not exist (no sign change over the search interval), gets R_OK = 0: the scalar path.

An item at a time, on its coefficients where ``special`` left them in CB: a block has 1-2 such
items at rtol 1e-4 .. 1e-8, and loops across so few items, one per rule and node, cost more to
set up than vectorizing saves (as ``one_dip``'s scan and pieces, block_dips.py). The sums run in
the order of the loops across items before (the same values).

Header names used: NC, CBS, OFC; R_OK, R_FAR, KEEP_FAST, item_value of block_quadrature.py;
_power of quadrature.py.
"""
# ruff: noqa: F821  (the upper-case constants, njit and JIT come from the generated header)

TWO_ROOTS = 5.0  # R_OK code set by ``special``: two sign changes on the samples, done here
# Legendre pieces of the graded rule per side: handles gap >= |e - r| / 16; with 4, fewer than
# 0.05 per 1000 lane steps go on to the scalar path, of 17.3 (rtol 1e-4) and 7.8 (1e-5) routed
# here (benchmarks/profile_engine.py --n 150)
GRADING_LEVELS = 4
# Newton iterations per root at most: more than ``special``'s N_NEWTON, because with the roots
# close the regula falsi start of each bracket lies near the extremum between them, where the
# first step leaves the bracket and bisects (roots 0.3 and 0.36 between the 4-node samples: not
# converged after 6)
N_TWO_NEWTON = 10


@njit(**JIT)
def _bracketed_newton(CB, t, x, lo, hi, f_lo):
    """One Newton step for item t's root in [lo, hi] (f_lo: v at the bracket's start, nonzero):
    the bracket shrinks to the side of x that keeps the sign change, and a step that leaves it
    (or a zero derivative) bisects."""
    v = CB[(NC - 1) * CBS + t]
    d = 0.0
    for k in range(NC - 2, -1, -1):
        d = d * x + v
        v = v * x + CB[k * CBS + t]
    same = (v < 0.0) == (f_lo < 0.0)
    lo = x if same else lo
    hi = hi if same else x
    x_new = x - v / (d if d != 0.0 else 1.0)
    leaves = (d == 0.0) | (x_new < lo) | (x_new > hi)
    return (0.5 * (lo + hi) if leaves else x_new), lo, hi


@njit(**JIT)
def _is_root(CB, t, x):
    """|v(x)| at the rounding level of the coefficients (``special``'s convergence test)."""
    v = CB[(NC - 1) * CBS + t]
    scale = abs(v)
    ax = abs(x)
    for k in range(NC - 2, -1, -1):
        v = v * x + CB[k * CBS + t]
        scale = scale * ax + abs(CB[k * CBS + t])
    return abs(v) <= 1e-12 * scale


@njit(**JIT)
def _add_rule(CB, t, total, start, step, sign, kind, p, nodes, weights):
    """total + sign |step| sum_g weights_g |v(start + step nodes_g)|^p: a rule on [0, 1] mapped
    onto the segment from start, step long (signed), added (sign 1) or taken away (-1)."""
    for g in range(nodes.shape[0]):
        v = item_value(CB, t, start + step * nodes[g])
        total += sign * abs(step) * weights[g] * _power(abs(v), kind, p)
    return total


@njit(**JIT)
def _graded(CB, t, total, r1, r2, far, left, kind, p, glx, glw, gjx, gjf):
    """total + F(r1 -> 0) (left) or F(r2 -> 1): Gauss–Jacobi from the root over min(gap, length),
    then up to GRADING_LEVELS Gauss–Legendre pieces [r + near, r + 2 near] cut at the end
    (``_from_root``'s); nothing where that root is the one outside [0, 1] (far beyond that end)."""
    r = r1 if left else r2
    gap = r2 - r1
    length = (r if far >= 0.0 else 0.0) if left else (1.0 - r if far <= 1.0 else 0.0)
    first = min(gap, length)
    total = _add_rule(CB, t, total, r, -first if left else first, 1.0, kind, p, gjx, gjf)
    for level in range(GRADING_LEVELS):
        scale = 2.0**level
        near = min(scale * gap, length)
        end = min(2.0 * scale * gap, length)
        if end - near == 0.0:  # the end reached: this piece and the ones after are empty
            break
        total = _add_rule(CB, t, total, r - near if left else r + near, near - end if left else end - near, 1.0,
                          kind, p, glx, glw)
    return total


@njit(**JIT)
def two_roots(W, CB, ITEM, m, kind, p, glx, glw, gjx, gjf):
    """FC of every item of ``special`` with R_OK == TWO_ROOTS (see the module docstring); the
    items it cannot do get R_OK = 0 (the scalar path)."""
    n_nodes = glx.shape[0]
    reach = 2.0**GRADING_LEVELS
    for t in range(m):
        if CB[R_OK * CBS + t] != TWO_ROOTS:
            continue
        CB[R_OK * CBS + t] = 0.0  # until done below
        # the two sample brackets: [lo1, hi1] holds the first sign change (v = f1 at lo1),
        # [lo2, hi2] the second
        count = 0.0
        lo1 = hi1 = f1 = lo2 = hi2 = f2 = 0.0
        prev = CB[t]
        x_prev = 0.0
        for s in range(n_nodes + 1):
            x = glx[s] if s < n_nodes else 1.0
            v = item_value(CB, t, x)
            if prev * v < 0.0:
                if count == 0.0:
                    lo1, hi1, f1 = x_prev, x, prev
                elif count == 1.0:
                    lo2, hi2, f2 = x_prev, x, prev
                count += 1.0
            prev = v
            x_prev = x
        # A root near an end outside: its bracket is the search interval, [far, 0] before the
        # sample bracket (which moves to the second) or [1, far] after it; it counts as a sign
        # change where v changes sign over the interval (else the count stays 1: the scalar path).
        far = CB[R_FAR * CBS + t]
        left = far < 0.0
        right = far > 1.0
        if left | right:
            v_far = item_value(CB, t, far)
            v1 = 0.0
            for k in range(NC):
                v1 += CB[k * CBS + t]
            if left:
                lo2, hi2, f2 = lo1, hi1, f1
                lo1, hi1, f1 = far, 0.0, v_far
            else:
                lo2, hi2, f2 = 1.0, far, v1
            count += 1.0 if v_far * (CB[t] if left else v1) < 0.0 else 0.0
        # (the scan repeats special's, so the count is 2 unless a root outside does not exist)
        if count != 2.0:
            continue
        # regula falsi starts, then Newton until nothing moves (a fixed point: what more
        # iterations would leave)
        g1 = item_value(CB, t, hi1)
        g2 = item_value(CB, t, hi2)
        r1 = lo1 - f1 * (hi1 - lo1) / (g1 - f1)
        r2 = lo2 - f2 * (hi2 - lo2) / (g2 - f2)
        for _ in range(N_TWO_NEWTON):
            r1_new, lo1_new, hi1_new = _bracketed_newton(CB, t, r1, lo1, hi1, f1)
            r2_new, lo2_new, hi2_new = _bracketed_newton(CB, t, r2, lo2, hi2, f2)
            still = (r1_new == r1) & (lo1_new == lo1) & (hi1_new == hi1)
            still = still & (r2_new == r2) & (lo2_new == lo2) & (hi2_new == hi2)
            r1, lo1, hi1, r2, lo2, hi2 = r1_new, lo1_new, hi1_new, r2_new, lo2_new, hi2_new
            if still:
                break
        gap = r2 - r1
        good = _is_root(CB, t, r1) & _is_root(CB, t, r2)
        good = good & (lo1 <= r1) & (r1 <= hi1) & (lo2 <= r2) & (r2 <= hi2)
        # the graded rule reaches reach * gap from each root (a root outside has none: r1 < 0 or
        # 1 - r2 < 0 passes)
        good = good & (gap > 0.0) & (r1 <= reach * gap) & (1.0 - r2 <= reach * gap)
        if not good:
            continue
        # the middle piece, halved: J(r1 -> m) + J(r2 -> m), the other root one half-length
        # beyond m; with a root outside and m beyond that end, the piece from the inside root to
        # the end alone (the other root then more than its length beyond that end)
        half = 0.5 * (r2 - r1)
        past_end = right & (r1 + half > 1.0)
        past_start = left & (r1 + half < 0.0)
        total = 0.0
        if past_start:
            total = _add_rule(CB, t, total, r2, -r2, 1.0, kind, p, gjx, gjf)
        elif past_end:
            total = _add_rule(CB, t, total, r1, 1.0 - r1, 1.0, kind, p, gjx, gjf)
        else:
            total = _add_rule(CB, t, total, r1, half, 1.0, kind, p, gjx, gjf)
            total = _add_rule(CB, t, total, r2, -half, 1.0, kind, p, gjx, gjf)
            # a root outside with m inside: take away J(r2 -> 1) or J(r1 -> 0), the part of the
            # middle piece beyond the end
            middle = 0.5 * (r1 + r2)
            if left & (middle >= 0.0):
                total = _add_rule(CB, t, total, r1, -r1, -1.0, kind, p, gjx, gjf)
            elif right & (middle <= 1.0):
                total = _add_rule(CB, t, total, r2, 1.0 - r2, -1.0, kind, p, gjx, gjf)
        total = _graded(CB, t, total, r1, r2, far, True, kind, p, glx, glw, gjx, gjf)
        total = _graded(CB, t, total, r1, r2, far, False, kind, p, glx, glw, gjx, gjf)
        W[OFC + ITEM[t]] = total
        CB[R_OK * CBS + t] = KEEP_FAST  # done: the scatter leaves FC as it is
