"""Template: the vectorized LD quadrature of the special path's items with two roots in the step.

``special`` (block_quadrature.py) marks R_OK = TWO_ROOTS for an item with no zero end and
either exactly two sign changes on its samples (0, the Gauss nodes, 1) and no root near either
end outside, or one sign change and a root near one end outside (within ``window`` by linear
extrapolation; R_FAR is then the far end of its search interval, -2 window or 1 + 2 window).
``two_roots`` then does what ``component_integral`` would for it, vectorized across those items:
both roots r1 < r2 by Newton from the regula falsi point of their brackets (the sample brackets;
the search interval between the end and R_FAR for a root outside), kept inside them (as the
one-root case of ``special``), then, with m = (r1 + r2) / 2,

    int_0^1 |v|^p = F(r1 -> 0) + J(r1 -> m) + J(r2 -> m) + F(r2 -> 1)        both inside,
                  = F(r1 -> 0) + J(r1 -> m) + J(r2 -> m) - J(r2 -> 1)        r2 > 1, m <= 1,
                  = F(r1 -> 0) + J(r1 -> 1)                                  r2 > 1, m > 1,

and mirrored for r1 < 0 (-J(r1 -> 0) + J(r1 -> m) + J(r2 -> m) + F(r2 -> 1) for m >= 0, else
J(r2 -> 0) + F(r2 -> 1)). Each Jacobi piece so has the other root at least its own length beyond
its end (rho >= 3 + 2 sqrt 2, as ``_from_root``'s pieces).

where J(r -> e) is the Gauss–Jacobi integral from the root r with the weight |s - r|^p taken
out, and F(r -> e) is ``_from_root``'s graded rule with the other root gap = r2 - r1 beyond r:
J over [r, r +- min(gap, |e - r|)], then Gauss–Legendre on pieces each as long as their
distance from r (so that the other root's cusp never lies closer to a piece than its length).
GRADING_LEVELS such pieces are laid out for every item (empty where the end is reached
earlier); an item that needs more (gap < |e - r| 2^-GRADING_LEVELS), whose Newton did not
converge, whose roots coincide in floating point, or whose root near an end does not exist (no
sign change over the search interval), gets R_OK = 0: the scalar path.

The items are gathered into rows of their own in CB (``gather_items``: rows of CBS items, NC
coefficients, then the rows below).

Header names used: NC, CBS, OFC, KIND_HALF, KIND_ONE; R_OK, KEEP_FAST, gather_items of
block_quadrature.py.
"""
# ruff: noqa: F821  (the upper-case constants, njit and JIT come from the generated header)

TWO_ROOTS = 5.0  # R_OK code set by ``special``: two sign changes on the samples, done here
# Legendre pieces of the graded rule per side: handles gap >= |e - r| / 16; with 4, fewer than
# 0.05 per 1000 lane steps go on to the scalar path, of 17.3 (rtol 1e-4) and 7.8 (1e-5) routed
# here (benchmarks/profile_engine.py --n 150)
GRADING_LEVELS = 4
# Newton iterations per root: more than ``special``'s N_NEWTON, because with the roots close the
# regula falsi start of each bracket lies near the extremum between them, where the first step
# leaves the bracket and bisects (roots 0.3 and 0.36 between the 4-node samples: not converged after 6)
N_TWO_NEWTON = 10
(T_PREV, T_COUNT, T_LO1, T_HI1, T_F1, T_LO2, T_HI2, T_F2, T_R1, T_R2, T_START, T_STEP, T_SUM,
 T_OK, T_FAR, T_SIGN) = range(NC, NC + 16)
T_ROWS = NC + 16


@njit(inline="always", **JIT)
def _bracketed_newton(TB, t, x, lo, hi, f_lo):
    """One Newton step for item t's root in [lo, hi] (f_lo: v at the bracket's start, nonzero):
    the bracket shrinks to the side of x that keeps the sign change, and a step that leaves it
    (or a zero derivative) bisects. Selects only, as the lanes of a vector."""
    v = TB[(NC - 1) * CBS + t]
    d = 0.0
    for k in range(NC - 2, -1, -1):
        d = d * x + v
        v = v * x + TB[k * CBS + t]
    same = (v < 0.0) == (f_lo < 0.0)
    lo = x if same else lo
    hi = hi if same else x
    x_new = x - v / (d if d != 0.0 else 1.0)
    leaves = (d == 0.0) | (x_new < lo) | (x_new > hi)
    return (0.5 * (lo + hi) if leaves else x_new), lo, hi


@njit(inline="always", **JIT)
def _is_root(TB, t, x):
    """|v(x)| at the rounding level of the coefficients (``special``'s convergence test)."""
    v = TB[(NC - 1) * CBS + t]
    scale = abs(v)
    ax = abs(x)
    for k in range(NC - 2, -1, -1):
        v = v * x + TB[k * CBS + t]
        scale = scale * ax + abs(TB[k * CBS + t])
    return abs(v) <= 1e-12 * scale


@njit(**JIT)
def _add_rule(TB, n, kind, p, nodes, weights):
    """T_SUM += T_SIGN |T_STEP| sum_g weights_g |v(T_START + T_STEP nodes_g)|^p for every item: a
    rule on [0, 1] mapped onto the segment from T_START, T_STEP long (signed), added (T_SIGN 1) or
    taken away (-1). One item loop per kind (a test of ``kind`` inside it stops LLVM from
    vectorizing it)."""
    for g in range(nodes.shape[0]):
        xi = nodes[g]
        w = weights[g]
        if kind == KIND_HALF:
            for t in range(n):
                x = TB[T_START * CBS + t] + TB[T_STEP * CBS + t] * xi
                v = TB[(NC - 1) * CBS + t]
                for k in range(NC - 2, -1, -1):
                    v = v * x + TB[k * CBS + t]
                TB[T_SUM * CBS + t] += TB[T_SIGN * CBS + t] * abs(TB[T_STEP * CBS + t]) * w * math.sqrt(abs(v))
        elif kind == KIND_ONE:
            for t in range(n):
                x = TB[T_START * CBS + t] + TB[T_STEP * CBS + t] * xi
                v = TB[(NC - 1) * CBS + t]
                for k in range(NC - 2, -1, -1):
                    v = v * x + TB[k * CBS + t]
                TB[T_SUM * CBS + t] += TB[T_SIGN * CBS + t] * abs(TB[T_STEP * CBS + t]) * w * abs(v)
        else:
            for t in range(n):
                x = TB[T_START * CBS + t] + TB[T_STEP * CBS + t] * xi
                v = TB[(NC - 1) * CBS + t]
                for k in range(NC - 2, -1, -1):
                    v = v * x + TB[k * CBS + t]
                TB[T_SUM * CBS + t] += TB[T_SIGN * CBS + t] * abs(TB[T_STEP * CBS + t]) * w * abs(v) ** p


@njit(inline="always", **JIT)
def _graded_length(TB, t, r, left):
    """The length of F(r1 -> 0) (left) or F(r2 -> 1): 0 where that root is outside (T_FAR beyond
    that end)."""
    far = TB[T_FAR * CBS + t]
    return (r if far >= 0.0 else 0.0) if left else (1.0 - r if far <= 1.0 else 0.0)


@njit(**JIT)
def _graded(TB, n, kind, p, glx, glw, gjx, gjf, left):
    """T_SUM += F(r1 -> 0) (left) or F(r2 -> 1): Gauss–Jacobi from the root over
    min(gap, length), then GRADING_LEVELS Gauss–Legendre pieces [r + near, r + 2 near] cut at
    the end (``_from_root``, vectorized; empty pieces add nothing). Nothing where that root is
    the one outside [0, 1]."""
    for t in range(n):
        r = TB[(T_R1 if left else T_R2) * CBS + t]
        gap = TB[T_R2 * CBS + t] - TB[T_R1 * CBS + t]
        length = _graded_length(TB, t, r, left)
        TB[T_START * CBS + t] = r
        TB[T_STEP * CBS + t] = -min(gap, length) if left else min(gap, length)
        TB[T_SIGN * CBS + t] = 1.0
    _add_rule(TB, n, kind, p, gjx, gjf)
    for level in range(GRADING_LEVELS):
        scale = 2.0**level
        longest = 0.0
        for t in range(n):
            r = TB[(T_R1 if left else T_R2) * CBS + t]
            gap = TB[T_R2 * CBS + t] - TB[T_R1 * CBS + t]
            length = _graded_length(TB, t, r, left)
            near = min(scale * gap, length)
            far = min(2.0 * scale * gap, length)
            TB[T_START * CBS + t] = r - near if left else r + near
            TB[T_STEP * CBS + t] = near - far if left else far - near
            longest = max(longest, far - near)
        if longest == 0.0:  # every item's end reached: this level and the ones after add nothing
            break
        _add_rule(TB, n, kind, p, glx, glw)


@njit(**JIT)
def two_roots(W, CB, ITEM, m, kind, p, glx, glw, gjx, gjf):
    """FC of every item of ``special`` with R_OK == TWO_ROOTS (see the module docstring); the
    items it cannot do get R_OK = 0 (the scalar path)."""
    TB, SOURCE, n = gather_items(CB, m, TWO_ROOTS, T_ROWS)
    if n == 0:
        return
    # the two sample brackets: [T_LO1, T_HI1] holds the first sign change, [T_LO2, T_HI2] the second
    for t in range(n):
        TB[T_PREV * CBS + t] = TB[t]
        TB[T_COUNT * CBS + t] = 0.0
        TB[T_FAR * CBS + t] = CB[R_FAR * CBS + int(SOURCE[t])]
    x_prev = 0.0
    n_nodes = glx.shape[0]
    for s in range(n_nodes + 1):
        x = glx[s] if s < n_nodes else 1.0
        for t in range(n):
            v = TB[(NC - 1) * CBS + t]
            for k in range(NC - 2, -1, -1):
                v = v * x + TB[k * CBS + t]
            prev = TB[T_PREV * CBS + t]
            count = TB[T_COUNT * CBS + t]
            change = prev * v < 0.0
            first = change & (count == 0.0)
            second = change & (count == 1.0)
            TB[T_LO1 * CBS + t] = x_prev if first else TB[T_LO1 * CBS + t]
            TB[T_HI1 * CBS + t] = x if first else TB[T_HI1 * CBS + t]
            TB[T_F1 * CBS + t] = prev if first else TB[T_F1 * CBS + t]
            TB[T_LO2 * CBS + t] = x_prev if second else TB[T_LO2 * CBS + t]
            TB[T_HI2 * CBS + t] = x if second else TB[T_HI2 * CBS + t]
            TB[T_F2 * CBS + t] = prev if second else TB[T_F2 * CBS + t]
            TB[T_COUNT * CBS + t] = count + (1.0 if change else 0.0)
            TB[T_PREV * CBS + t] = v
        x_prev = x
    # A root near an end outside: its bracket is the search interval, [T_FAR, 0] before the sample
    # bracket (which moves to the second) or [1, T_FAR] after it; it counts as a sign change
    # where v changes sign over the interval (else the count stays 1: the scalar path).
    any_outside = False
    for t in range(n):
        far = TB[T_FAR * CBS + t]
        left = far < 0.0
        right = far > 1.0
        v_far = TB[(NC - 1) * CBS + t]
        v1 = 0.0
        for k in range(NC - 2, -1, -1):
            v_far = v_far * far + TB[k * CBS + t]
        for k in range(NC):
            v1 += TB[k * CBS + t]
        TB[T_LO2 * CBS + t] = TB[T_LO1 * CBS + t] if left else (1.0 if right else TB[T_LO2 * CBS + t])
        TB[T_HI2 * CBS + t] = TB[T_HI1 * CBS + t] if left else (far if right else TB[T_HI2 * CBS + t])
        TB[T_F2 * CBS + t] = TB[T_F1 * CBS + t] if left else (v1 if right else TB[T_F2 * CBS + t])
        TB[T_LO1 * CBS + t] = far if left else TB[T_LO1 * CBS + t]
        TB[T_HI1 * CBS + t] = 0.0 if left else TB[T_HI1 * CBS + t]
        TB[T_F1 * CBS + t] = v_far if left else TB[T_F1 * CBS + t]
        near_end = TB[t] if left else v1
        TB[T_COUNT * CBS + t] += 1.0 if ((left | right) & (v_far * near_end < 0.0)) else 0.0
        any_outside |= left | right
    # regula falsi starts (v at the bracket's end is T_PREV of the next sample: recomputed here)
    for t in range(n):
        lo1 = TB[T_LO1 * CBS + t]
        hi1 = TB[T_HI1 * CBS + t]
        lo2 = TB[T_LO2 * CBS + t]
        hi2 = TB[T_HI2 * CBS + t]
        f1 = TB[T_F1 * CBS + t]
        f2 = TB[T_F2 * CBS + t]
        g1 = TB[(NC - 1) * CBS + t]
        g2 = g1
        for k in range(NC - 2, -1, -1):
            g1 = g1 * hi1 + TB[k * CBS + t]
            g2 = g2 * hi2 + TB[k * CBS + t]
        TB[T_R1 * CBS + t] = lo1 - f1 * (hi1 - lo1) / (g1 - f1)
        TB[T_R2 * CBS + t] = lo2 - f2 * (hi2 - lo2) / (g2 - f2)
    for _ in range(N_TWO_NEWTON):
        for t in range(n):
            f1 = TB[T_F1 * CBS + t]
            f2 = TB[T_F2 * CBS + t]
            r1, lo1, hi1 = _bracketed_newton(TB, t, TB[T_R1 * CBS + t], TB[T_LO1 * CBS + t], TB[T_HI1 * CBS + t], f1)
            r2, lo2, hi2 = _bracketed_newton(TB, t, TB[T_R2 * CBS + t], TB[T_LO2 * CBS + t], TB[T_HI2 * CBS + t], f2)
            TB[T_R1 * CBS + t] = r1
            TB[T_LO1 * CBS + t] = lo1
            TB[T_HI1 * CBS + t] = hi1
            TB[T_R2 * CBS + t] = r2
            TB[T_LO2 * CBS + t] = lo2
            TB[T_HI2 * CBS + t] = hi2
    reach = 2.0**GRADING_LEVELS
    for t in range(n):
        r1 = TB[T_R1 * CBS + t]
        r2 = TB[T_R2 * CBS + t]
        gap = r2 - r1
        # (the scan repeats special's, so the count is 2 unless a root outside does not exist;
        # tested so that a bracket never comes from the uninitialised buffer)
        good = (TB[T_COUNT * CBS + t] == 2.0) & _is_root(TB, t, r1) & _is_root(TB, t, r2)
        good = good & (TB[T_LO1 * CBS + t] <= r1) & (r1 <= TB[T_HI1 * CBS + t])
        good = good & (TB[T_LO2 * CBS + t] <= r2) & (r2 <= TB[T_HI2 * CBS + t])
        # the graded rule reaches reach * gap from each root (a root outside has none: r1 < 0 or
        # 1 - r2 < 0 passes)
        good = good & (gap > 0.0) & (r1 <= reach * gap) & (1.0 - r2 <= reach * gap)
        TB[T_OK * CBS + t] = 1.0 if good else 0.0
        TB[T_SUM * CBS + t] = 0.0
    # the middle piece, halved: J(r1 -> m) + J(r2 -> m), the other root one half-length beyond m;
    # with a root outside and m beyond that end, the piece from the inside root to the end alone
    # (the other root then more than its length beyond that end)
    for side in range(2):
        for t in range(n):
            r1 = TB[T_R1 * CBS + t]
            r2 = TB[T_R2 * CBS + t]
            half = 0.5 * (r2 - r1)
            far = TB[T_FAR * CBS + t]
            past_end = (far > 1.0) & (r1 + half > 1.0)
            past_start = (far < 0.0) & (r1 + half < 0.0)
            start = r1 if side == 0 else r2
            step = half if side == 0 else -half
            start = r2 if (past_start & (side == 0)) else start
            step = (-r2 if side == 0 else 0.0) if past_start else step
            step = (1.0 - r1 if side == 0 else 0.0) if past_end else step
            TB[T_START * CBS + t] = start
            TB[T_STEP * CBS + t] = step
            TB[T_SIGN * CBS + t] = 1.0
        _add_rule(TB, n, kind, p, gjx, gjf)
    # a root outside with m inside: take away J(r2 -> 1) or J(r1 -> 0), the part of the middle
    # piece beyond the end
    if any_outside:
        for t in range(n):
            r1 = TB[T_R1 * CBS + t]
            r2 = TB[T_R2 * CBS + t]
            middle = 0.5 * (r1 + r2)
            far = TB[T_FAR * CBS + t]
            beyond_end = (far > 1.0) & (middle <= 1.0)
            before_start = (far < 0.0) & (middle >= 0.0)
            TB[T_START * CBS + t] = r1 if before_start else r2
            TB[T_STEP * CBS + t] = -r1 if before_start else (1.0 - r2 if beyond_end else 0.0)
            TB[T_SIGN * CBS + t] = -1.0
        _add_rule(TB, n, kind, p, gjx, gjf)
    _graded(TB, n, kind, p, glx, glw, gjx, gjf, True)
    _graded(TB, n, kind, p, glx, glw, gjx, gjf, False)
    for i in range(n):
        t = int(SOURCE[i])
        if TB[T_OK * CBS + i] == 1.0:
            W[OFC + ITEM[t]] = TB[T_SUM * CBS + i]
            CB[R_OK * CBS + t] = KEEP_FAST  # done: the scatter leaves FC as it is
        else:
            CB[R_OK * CBS + t] = 0.0
