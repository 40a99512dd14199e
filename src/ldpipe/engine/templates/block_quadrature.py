"""Template: the vectorized LD quadrature passes over a block workspace.

``fast(W, kind, p, glx, glw, window, SP)`` writes, for every lane j and component c,
FC[c, j] = Gauss–Legendre value of int_0^1 |v_c|^p dx and SP[c, j] = True where the
component needs the special path (see quadrature.py). For arc length, FC[0, j] holds the
whole integral and SP is all False.

``special(W, SP, kind, p, glx, glw, gjx, gjf, window, CB, ITEM, roots)`` replaces FC[c, j] by
the cusp-aware integral for every (c, j) with SP[c, j]. The flagged components are gathered
into the compact buffer ``CB`` (flat; rows of CBS items: NC coefficients, then scratch rows)
so that the common cases run vectorized across items:

* one sign change on the sample grid (0, the Gauss nodes, 1) and no root near either end
  outside: the root r in (0, 1) by Newton from the regula falsi point, kept in the bracket,
  then int_0^1 = J(r -> 0) + J(r -> 1); a root exactly at 0 or 1 (a turning point at the
  start of a trajectory) is taken as it is;
* no sign change and a root near one end only (linear extrapolation within ``window``):
  the root r outside by Newton, then int_0^1 = J(r -> far end) - J(r -> near end); if the
  polynomial has no sign change over the search interval (the extrapolated root does not
  exist) the Gauss–Legendre value of ``fast`` stands;

where J(r -> e) is the Gauss–Jacobi integral from the root r to e with the weight
|s - r|^p taken out (folded into the weights ``gjf``, so nothing is divided). Anything else
(more roots, a sample exactly at zero, Newton not converged) goes to the scalar
``component_integral``.

The workspace sizes are compile-time constants, so the Horner loops unroll and the lane
loops vectorize. The loops over items are written with selects instead of branches, and
tests of the run-time ``kind`` stay outside them: either in a loop body stops LLVM from
vectorizing it (measured: the Gauss–Jacobi loop ran 37x slower with the test inside).

Two more cases have templates of their own (a block has a few of their items, so these work
an item at a time where that costs less than loops across items): two sign changes, or one and
a root near an end outside (``two_roots``, block_two_roots.py; near also where v moves away from
zero at the end but its quadratic model there reaches zero within ``window``), and, with no sign
change and no root near an end, a possible near-touch (``one_dip``, block_dips.py: the scalar
path's search for the minimum of |v| and its sinh rule).
A near-touch flag beside a root just outside an end (the left/right case) goes to the scalar
path only where ``touch_matters`` (scalar, a few Horner evaluations per start) finds a minimum of
|v| that ``component_integral`` would take as a dip; a flag that is only a possible root pair
between two samples, only where ``pair_check`` (vectorized) cannot rule the pair out with a
bound of |v''| over each sample interval. Elsewhere the Gauss–Legendre value (or the Jacobi
pieces) stand. Both checks are in flag_checks.py.

Header names used: NC (coefficients per polynomial), NCOMP (= 2 n_dof),
LANES, CS (= NCOMP * LANES, the stride between coefficients in VC), the offsets OVC, OFC,
OMIN, OMAX, OACC, OPRV, ORAT, OCRV, and KIND_HALF, KIND_ONE, KIND_ARCLENGTH.
"""
# ruff: noqa: F821  (the upper-case constants, njit and JIT come from the generated header)

# CB is flat: row r of the item buffer holds items at CB[r * CBS + t]; the NC coefficient rows,
# then scratch rows; R_SOURCE and the CASE_ROWS rows from CASE on hold the items of ``one_dip``'s
# case gathered for its rule (``gather_items``), so that no call allocates.
(R_PREV, R_NSC, R_A, R_B, R_FA, R_FB, R_LO, R_HI, R_ROOT, R_OK, R_J0, R_J1, R_FAR, R_NEAR, R_MINABS, R_TOUCH,
 R_ENDS, R_SOURCE) = range(NC, NC + 18)
CASE = NC + 18
CASE_ROWS = NC + 15  # the rows a case's rule takes (block_dips.py: D_ROWS)
CB_ROWS = CASE + CASE_ROWS
# R_OK: 1 the root is found (Jacobi pieces), 2 keep the fast Gauss–Legendre value, 0 the scalar path,
# 4 a possible root pair alone: the scalar path only if ``pair_check`` keeps it possible;
# TWO_ROOTS (block_two_roots.py) and ONE_DIP (block_dips.py): done there, or 0
KEEP_FAST = 2.0
PAIR_CHECK = 4.0
# The SP code written by ``fast`` where a component needs the special path: a root, a root pair,
# a root near an end or a near-touch possible (``special`` tells them apart again)
SP_SPECIAL = 1
CBS = NCOMP * LANES  # the row stride, a compile-time constant (no runtime alias checks)
N_NEWTON = 6  # from the regula falsi point: converged after 4-5 (measured: as many unconverged at 5 as at 8)


@njit(**JIT)
def fast(W, kind, p, glx, glw, window, SP):
    n_nodes = glx.shape[0]
    last_gap = 1.0 - glx[n_nodes - 1]
    if kind == KIND_ARCLENGTH:
        arclength_fast(W, glx, glw)  # block_arclength.py
        for c in range(NCOMP):
            for j in range(LANES):
                SP[c, j] = 0
        return
    dip_reach = (DIP_PER_WINDOW * window) ** 2
    for c in range(NCOMP):
        for j in range(LANES):
            base = OVC + c * LANES + j
            v0 = W[base]
            # OMIN, OMAX: over the nodes (the ends are added at the end, so that min |v| over
            # the nodes alone is known for the near-touch test)
            W[OMIN + j] = math.inf
            W[OMAX + j] = -math.inf
            W[OACC + j] = 0.0
            W[OPRV + j] = v0
            # ORAT: 1 where some sample interval [a, b] (0, the nodes, 1) may hide a pair of
            # roots (``pair_possible``), with OCRV the bound of |v''|; the last interval at the end
            W[OCRV + j] = _curvature(W, base)
            W[ORAT + j] = 0.0
        for g in range(n_nodes):
            x = glx[g]
            w = glw[g]
            gap = x - (glx[g - 1] if g > 0 else 0.0)
            if kind == KIND_HALF:
                for j in range(LANES):
                    base = OVC + c * LANES + j
                    v = W[base + (NC - 1) * CS]
                    for k in range(NC - 2, -1, -1):
                        v = v * x + W[base + k * CS]
                    W[OACC + j] += w * math.sqrt(abs(v))
                    W[OMIN + j] = min(W[OMIN + j], v)
                    W[OMAX + j] = max(W[OMAX + j], v)
                    W[ORAT + j] = max(W[ORAT + j], pair_possible(W[OPRV + j], v, W[OCRV + j], gap))
                    W[OPRV + j] = v
            elif kind == KIND_ONE:
                for j in range(LANES):
                    base = OVC + c * LANES + j
                    v = W[base + (NC - 1) * CS]
                    for k in range(NC - 2, -1, -1):
                        v = v * x + W[base + k * CS]
                    W[OACC + j] += w * abs(v)
                    W[OMIN + j] = min(W[OMIN + j], v)
                    W[OMAX + j] = max(W[OMAX + j], v)
                    W[ORAT + j] = max(W[ORAT + j], pair_possible(W[OPRV + j], v, W[OCRV + j], gap))
                    W[OPRV + j] = v
            else:
                for j in range(LANES):
                    base = OVC + c * LANES + j
                    v = W[base + (NC - 1) * CS]
                    for k in range(NC - 2, -1, -1):
                        v = v * x + W[base + k * CS]
                    W[OACC + j] += w * abs(v) ** p
                    W[OMIN + j] = min(W[OMIN + j], v)
                    W[OMAX + j] = max(W[OMAX + j], v)
                    W[ORAT + j] = max(W[ORAT + j], pair_possible(W[OPRV + j], v, W[OCRV + j], gap))
                    W[OPRV + j] = v
        if kind == KIND_ONE:
            for j in range(LANES):
                W[OFC + c * LANES + j] = W[OACC + j]
                base = OVC + c * LANES + j
                v1 = 0.0
                for k in range(NC):
                    v1 += W[base + k * CS]
                pair = max(W[ORAT + j], pair_possible(W[OPRV + j], v1, W[OCRV + j], last_gap)) > 0.0
                v_min = min(W[OMIN + j], min(W[base], v1))
                v_max = max(W[OMAX + j], max(W[base], v1))
                SP[c, j] = SP_SPECIAL if (((v_min < 0.0) & (v_max > 0.0) | pair) & (W[OH + j] != 0.0)) else 0
        else:
            for j in range(LANES):
                W[OFC + c * LANES + j] = W[OACC + j]
                base = OVC + c * LANES + j
                v0 = W[base]
                d0 = W[base + CS]
                v1 = 0.0
                d1 = 0.0
                a1 = 0.0
                for k in range(NC - 1, -1, -1):  # Horner at x = 1: v1 = v(1), d1 = v'(1), a1 = v''(1) / 2
                    a1 = a1 + d1
                    d1 = d1 + v1
                    v1 = v1 + W[base + k * CS]
                a0 = 2.0 * W[base + 2 * CS]  # v''(0)
                a1 = 2.0 * a1
                near_left = (v0 * d0 > 0.0) & (abs(v0) <= window * abs(d0))
                near_right = (v1 * d1 < 0.0) & (abs(v1) <= window * abs(d1))
                pair = max(W[ORAT + j], pair_possible(W[OPRV + j], v1, W[OCRV + j], last_gap)) > 0.0
                # An idle lane (h = 0; never loaded: all zero) is never special: its FC is not
                # used, and its zero polynomials would each take the scalar path.
                # (bitwise operators: no branches in the lane loop)
                crossing = (min(W[OMIN + j], min(v0, v1)) <= 0.0) & (max(W[OMAX + j], max(v0, v1)) >= 0.0)
                # A near-touch (complex roots of v) within DIP_PER_WINDOW window of a sample:
                # at an end e, where the quadratic model v + d x + (a / 2) x^2 has complex roots
                # (a v > 0, d^2 < 2 a v) at distance sqrt(2 v / a) < width; at the nodes (no
                # crossing: min |v| there is OMIN or -OMAX) by ``dip_possible`` with the larger
                # |v''| of the ends for the curvature. (With the bound of |v''| of
                # ``pair_possible`` instead, 1.6x the CPU time at rtol 1e-6.)
                curv = max(abs(a0), abs(a1))
                dip = 2.0 * min(abs(W[OMIN + j]), abs(W[OMAX + j])) < dip_reach * curv
                dip0 = (a0 * v0 > 0.0) & (2.0 * abs(v0) < dip_reach * abs(a0)) & (d0 * d0 < 2.0 * a0 * v0)
                dip1 = (a1 * v1 > 0.0) & (2.0 * abs(v1) < dip_reach * abs(a1)) & (d1 * d1 < 2.0 * a1 * v1)
                dip = dip | dip0 | dip1
                root = crossing | near_left | near_right | pair
                SP[c, j] = SP_SPECIAL if ((root | dip) & (W[OH + j] != 0.0)) else 0


@njit(**JIT)
def _curvature(W, base):
    """sum_k k (k - 1) |c_k|: a bound of |v''| on [0, 1] for the polynomial at W[base + k * CS]."""
    bound = 0.0
    for k in range(2, NC):
        bound += k * (k - 1.0) * abs(W[base + k * CS])
    return bound


@njit(**JIT)
def item_value(CB, t, x):
    """Item t's polynomial at x (its coefficients in rows 0 .. NC - 1 of CB, or of a case's rows)."""
    v = CB[(NC - 1) * CBS + t]
    for k in range(NC - 2, -1, -1):
        v = v * x + CB[k * CBS + t]
    return v


@njit(**JIT)
def _at_both_sides(CB, t, s0, s1):
    """Item t's polynomial at s0 and at s1 (two Horner chains, interleaved)."""
    v0 = CB[(NC - 1) * CBS + t]
    v1 = v0
    for k in range(NC - 2, -1, -1):
        v0 = v0 * s0 + CB[k * CBS + t]
        v1 = v1 * s1 + CB[k * CBS + t]
    return v0, v1


@njit(**JIT)
def gather_items(CB, m, code, rows):
    """The items of ``special`` whose R_OK is ``code``, for a rule of their own (``one_dip``):
    (a view of ``rows`` rows of CBS items in CB from row CASE on, its first NC rows
    their coefficients; the index in CB of each, as floats in row R_SOURCE; their count). The
    rows above CASE, ``special``'s, are left as they are."""
    if rows > CASE_ROWS:
        raise ValueError("gather_items: a case's rule takes more rows than CASE_ROWS")
    # branch-free compaction: each index is written, and kept where the item is one of them
    n = 0
    for t in range(m):
        CB[R_SOURCE * CBS + n] = t
        n += CB[R_OK * CBS + t] == code
    source = CB[R_SOURCE * CBS : R_SOURCE * CBS + n]
    items = CB[CASE * CBS : (CASE + rows) * CBS]
    for k in range(NC):
        for i in range(n):
            items[k * CBS + i] = CB[k * CBS + int(source[i])]
    return items, source, n


@njit(**JIT)
def special(W, SP, kind, p, glx, glw, gjx, gjf, window, CB, ITEM, roots):
    # gather the flagged components: coefficient rows 0..NC-1 of the flat buffer CB
    # (branch-free compaction: each index is written, and kept where the component is flagged;
    # with a branch per component the gather cost ~25-45 cycles per lane step, as much as the
    # Newton iteration, through mispredictions)
    m = np.int64(0)  # (typed, not a literal: numba would compile the callees it reaches once more for the literal's type)
    for c in range(NCOMP):
        for j in range(LANES):
            ITEM[m] = c * LANES + j
            m += SP[c, j] != 0
    if m == 0:
        return
    for k in range(NC):
        for t in range(m):
            CB[k * CBS + t] = W[OVC + k * CS + ITEM[t]]
    n_nodes = glx.shape[0]
    # Sign changes on the grid 0, glx..., 1, and the bracket of the first one. Written without
    # branches (selects) so that the loops over items vectorize.
    for t in range(m):
        v0 = CB[t]
        CB[R_PREV * CBS + t] = v0
        CB[R_NSC * CBS + t] = 0.0
        CB[R_A * CBS + t] = 0.0
        CB[R_B * CBS + t] = 0.0  # a root exactly at x = 0: the bracket [0, 0]
        CB[R_FA * CBS + t] = v0
        CB[R_FB * CBS + t] = v0
        CB[R_MINABS * CBS + t] = math.inf  # over the interior samples (the nodes)
    x_prev = 0.0
    for s in range(n_nodes + 1):
        x = glx[s] if s < n_nodes else 1.0
        interior = s < n_nodes
        for t in range(m):
            v = CB[(NC - 1) * CBS + t]
            for k in range(NC - 2, -1, -1):
                v = v * x + CB[k * CBS + t]
            prev = CB[R_PREV * CBS + t]
            nsc = CB[R_NSC * CBS + t]
            change = prev * v < 0.0
            first = change & (nsc == 0.0)
            CB[R_A * CBS + t] = x_prev if first else CB[R_A * CBS + t]
            CB[R_B * CBS + t] = x if first else CB[R_B * CBS + t]
            CB[R_FA * CBS + t] = prev if first else CB[R_FA * CBS + t]
            CB[R_FB * CBS + t] = v if first else CB[R_FB * CBS + t]
            # an exact zero at an interior sample: the scalar path
            CB[R_NSC * CBS + t] = nsc + (1.0 if change else 0.0) + (10.0 if (interior & (v == 0.0)) else 0.0)
            CB[R_PREV * CBS + t] = v
            CB[R_MINABS * CBS + t] = min(CB[R_MINABS * CBS + t], abs(v) if interior else math.inf)
        x_prev = x
    # The case, the starting guess and the search interval:
    # inside: one sign change, no root near either end outside (an exact zero at 0 or 1 counts
    # as the root, bracket [0, 0] or [1, 1]); left/right: no sign change, a root within
    # ``window`` outside one end (linear extrapolation). Anything else: the scalar path, and so
    # is, without a sign change, a possible near-touch (``dip_possible`` over the samples) or a
    # zero end where v' is small too (a double root within the dip width; |v| with p = 1 has none).
    dip_width = 0.0 if kind == KIND_ONE else DIP_PER_WINDOW * window
    n_pair = 0
    for t in range(m):
        v0 = CB[t]
        d0 = CB[CBS + t]
        v1 = 0.0
        d1 = 0.0
        a1 = 0.0
        for k in range(NC - 1, -1, -1):
            a1 = a1 + d1
            d1 = d1 + v1
            v1 = v1 + CB[k * CBS + t]
        a0 = 2.0 * CB[2 * CBS + t]
        a1 = 2.0 * a1
        bound = max(abs(a0), abs(a1))
        near_left = (v0 * d0 > 0.0) & (abs(v0) <= window * abs(d0))
        near_right = (v1 * d1 < 0.0) & (abs(v1) <= window * abs(d1))
        nsc = CB[R_NSC * CBS + t]
        zero0 = v0 == 0.0
        zero1 = v1 == 0.0
        reach = dip_width * dip_width * bound
        # as in ``fast``: the nodes, and the ends where the quadratic model has complex roots
        low0 = (a0 * v0 > 0.0) & (2.0 * abs(v0) < dip_width * dip_width * abs(a0)) & (d0 * d0 < 2.0 * a0 * v0)
        low1 = (a1 * v1 > 0.0) & (2.0 * abs(v1) < dip_width * dip_width * abs(a1)) & (d1 * d1 < 2.0 * a1 * v1)
        low = (2.0 * CB[R_MINABS * CBS + t] < reach) | low0 | low1
        double = zero0 & (2.0 * abs(d0) < dip_width * bound) | zero1 & (2.0 * abs(d1) < dip_width * bound)
        dip = (nsc == 0.0) & (low | double)
        inside = (nsc == 1.0) & (~near_left) & (~near_right) & (~zero0) & (~zero1)
        at0 = (nsc == 0.0) & zero0 & (~zero1) & (~near_right)
        at1 = (nsc == 0.0) & zero1 & (~zero0) & (~near_left)
        left = (nsc == 0.0) & near_left & (~near_right) & (~zero1)
        right = (nsc == 0.0) & near_right & (~near_left) & (~zero0)
        a = CB[R_A * CBS + t]
        b = CB[R_B * CBS + t]
        fa = CB[R_FA * CBS + t]
        fb = CB[R_FB * CBS + t]
        # regula falsi inside the bracket (fa and fb have opposite signs there); the linear
        # extrapolation outside an end
        guess = a - fa * (b - a) / (fb - fa) if inside else 0.5 * (a + b)
        lo = a
        hi = b
        guess = -v0 / d0 if left else guess
        lo = -2.0 * window if left else lo
        hi = 0.0 if left else hi
        guess = 1.0 - v1 / d1 if right else guess
        lo = 1.0 if right else lo
        hi = 1.0 + 2.0 * window if right else hi
        guess = 0.0 if at0 else guess
        lo = 0.0 if at0 else lo
        hi = 0.0 if at0 else hi
        guess = 1.0 if at1 else guess
        lo = 1.0 if at1 else lo
        hi = 1.0 if at1 else hi
        # A near-touch flag without a root inside (no zero sample, no double root): beside a
        # root near one end (left/right), the Jacobi pieces here, checked after by
        # ``touch_matters`` (R_TOUCH = 2; R_ENDS: the ends whose quadratic's vertex the minimum
        # is looked for from); with no root near either end, ``one_dip``.
        clean = dip & (~double) & (~zero0) & (~zero1)
        beside = clean & (left | right)
        CB[R_OK * CBS + t] = 1.0 if ((inside | left | right | at0 | at1) & ((~dip) | beside)) else 0.0
        # no root near either end: the scalar path's search for the minimum (``one_dip``, block_dips.py)
        alone = clean & (~near_left) & (~near_right)
        CB[R_OK * CBS + t] = ONE_DIP if alone else CB[R_OK * CBS + t]
        # two sign changes and no root near an end, or one and a root near one end outside: both
        # roots by ``two_roots`` (block_two_roots.py; R_FAR below tells it where to look outside)
        two = (nsc == 2.0) & (~near_left) & (~near_right) & (~zero0) & (~zero1)
        # (near an end also where v moves away from zero there but curves back to it within
        # ``window``: the end's quadratic model changes sign; linear extrapolation misses that
        # root, and Gauss–Jacobi from the root inside would then converge slowly)
        turn_left = (v0 * d0 <= 0.0) & (v0 * (v0 - d0 * window + 0.5 * a0 * window * window) < 0.0)
        turn_right = (v1 * d1 >= 0.0) & (v1 * (v1 + d1 * window + 0.5 * a1 * window * window) < 0.0)
        beside_left = near_left | turn_left
        root_beside = (nsc == 1.0) & (beside_left != (near_right | turn_right)) & (~zero0) & (~zero1)
        CB[R_OK * CBS + t] = TWO_ROOTS if (two | root_beside) else CB[R_OK * CBS + t]
        # flagged by ``fast`` for a possible root pair between two samples and nothing else
        pair = (nsc == 0.0) & (~near_left) & (~near_right) & (~zero0) & (~zero1) & (~dip)
        CB[R_OK * CBS + t] = PAIR_CHECK if pair else CB[R_OK * CBS + t]
        n_pair += 1 if pair else 0
        CB[R_TOUCH * CBS + t] = 2.0 if beside else 0.0
        CB[R_ENDS * CBS + t] = (1.0 if (low0 | left) else 0.0) + (2.0 if (low1 | right) else 0.0)
        CB[R_ROOT * CBS + t] = guess
        CB[R_LO * CBS + t] = lo
        CB[R_HI * CBS + t] = hi
        CB[R_FA * CBS + t] = fa if inside else 0.0
        # for left/right: the far end of the search interval and the value at the near end (for
        # a root beside an end, the far end alone: two_roots searches there)
        far_end = -2.0 * window if beside_left else 1.0 + 2.0 * window
        CB[R_FAR * CBS + t] = far_end if (left | right | root_beside) else 0.0
        CB[R_NEAR * CBS + t] = v0 if left else (v1 if right else 0.0)
    if n_pair > 0:
        pair_check(CB, m, glx)
    # Newton, kept inside [lo, hi]; inside a sign-change bracket it bisects when it leaves
    for _ in range(N_NEWTON):
        for t in range(m):
            x = CB[R_ROOT * CBS + t]
            v = CB[(NC - 1) * CBS + t]
            d = 0.0
            for k in range(NC - 2, -1, -1):
                d = d * x + v
                v = v * x + CB[k * CBS + t]
            lo = CB[R_LO * CBS + t]
            hi = CB[R_HI * CBS + t]
            fa = CB[R_FA * CBS + t]
            bracketed = fa != 0.0
            same = (v < 0.0) == (fa < 0.0)
            lo = x if (bracketed & same) else lo
            hi = x if (bracketed & (~same)) else hi
            CB[R_LO * CBS + t] = lo
            CB[R_HI * CBS + t] = hi
            middle = 0.5 * (lo + hi)
            x_new = x - v / (d if d != 0.0 else 1.0)
            x_new = x_new if d != 0.0 else middle
            outside = (x_new < lo) | (x_new > hi)
            clamped = min(max(x_new, lo), hi)
            x_new = (middle if bracketed else clamped) if outside else x_new
            CB[R_ROOT * CBS + t] = x_new
    # converged? |v(r)| at rounding level of the coefficients
    for t in range(m):
        x = CB[R_ROOT * CBS + t]
        v = CB[(NC - 1) * CBS + t]
        scale = abs(v)
        ax = abs(x)
        for k in range(NC - 2, -1, -1):
            v = v * x + CB[k * CBS + t]
            scale = scale * ax + abs(CB[k * CBS + t])
        good = (abs(v) <= 1e-12 * scale) & (CB[R_LO * CBS + t] <= x) & (x <= CB[R_HI * CBS + t])
        # A left/right case whose search interval holds no sign change: the extrapolated root
        # does not exist (v turns back before reaching 0), and the Gauss–Legendre value of the
        # fast pass stands, as the scalar path would find no root either.
        x_far = CB[R_FAR * CBS + t]
        v_far = CB[(NC - 1) * CBS + t]
        for k in range(NC - 2, -1, -1):
            v_far = v_far * x_far + CB[k * CBS + t]
        no_root = v_far * CB[R_NEAR * CBS + t] > 0.0
        ok = CB[R_OK * CBS + t]
        keep = ok if good else (KEEP_FAST if (no_root & (ok != 0.0)) else 0.0)
        CB[R_OK * CBS + t] = ok if ok >= KEEP_FAST else keep  # the checks' answers stand
        CB[R_J0 * CBS + t] = 0.0
        CB[R_J1 * CBS + t] = 0.0
    # J(r -> 0) and J(r -> 1): Gauss–Jacobi for the weight |s - r|^p with the weights folded
    # (gjf = w xi^-p), so that J(r -> e) = |e - r| sum_g gjf_g |v(r + (e - r) xi_g)|^p
    # One loop per kind: a test of ``kind`` inside the loop over items stops LLVM from
    # vectorizing it (measured 37x slower).
    for g in range(gjx.shape[0]):
        xi = gjx[g]
        w = gjf[g]
        if kind == KIND_HALF:
            for t in range(m):
                r = CB[R_ROOT * CBS + t]
                v0, v1 = _at_both_sides(CB, t, r - r * xi, r + (1.0 - r) * xi)
                CB[R_J0 * CBS + t] += w * math.sqrt(abs(v0))
                CB[R_J1 * CBS + t] += w * math.sqrt(abs(v1))
        elif kind == KIND_ONE:
            for t in range(m):
                r = CB[R_ROOT * CBS + t]
                v0, v1 = _at_both_sides(CB, t, r - r * xi, r + (1.0 - r) * xi)
                CB[R_J0 * CBS + t] += w * abs(v0)
                CB[R_J1 * CBS + t] += w * abs(v1)
        else:
            for t in range(m):
                r = CB[R_ROOT * CBS + t]
                v0, v1 = _at_both_sides(CB, t, r - r * xi, r + (1.0 - r) * xi)
                CB[R_J0 * CBS + t] += w * abs(v0) ** p
                CB[R_J1 * CBS + t] += w * abs(v1) ** p
    for t in range(m):
        r = CB[R_ROOT * CBS + t]
        # [0, 1] = [r, 1] - [r, 0] for a root left of 0, [0, r] + [r, 1] inside, [0, r] - [1, r] right of 1
        sigma0 = 1.0 if r > 0.0 else -1.0
        sigma1 = 1.0 if r < 1.0 else -1.0
        CB[R_J0 * CBS + t] = sigma0 * abs(r) * CB[R_J0 * CBS + t] + sigma1 * abs(1.0 - r) * CB[R_J1 * CBS + t]
    two_roots(W, CB, ITEM, m, kind, p, glx, glw, gjx, gjf)  # R_OK TWO_ROOTS: done there, or 0
    one_dip(W, CB, ITEM, m, kind, p, glx, glw, window)  # R_OK ONE_DIP: done there, or 0
    # scatter; the rest by the scalar path
    VC = W[OVC : OVC + NC * CS].reshape((NC, NCOMP, LANES))
    for t in range(m):
        item = ITEM[t]
        ok = CB[R_OK * CBS + t]
        if ok == 1.0:
            W[OFC + item] = CB[R_J0 * CBS + t]
        if ((ok == 1.0) | (ok == KEEP_FAST)) & (CB[R_TOUCH * CBS + t] == 2.0):
            c = item // LANES
            j = item - c * LANES
            if touch_matters(VC, c, j, NC, glx, int(CB[R_ENDS * CBS + t]), window):
                W[OFC + item] = component_integral(VC, c, j, NC, 1.0, kind, p, glx, glw, gjx, gjf, window, roots)
        elif ok == 0.0:
            c = item // LANES
            j = item - c * LANES
            W[OFC + item] = component_integral(VC, c, j, NC, 1.0, kind, p, glx, glw, gjx, gjf, window, roots)
