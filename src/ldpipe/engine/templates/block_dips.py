"""Template: the LD quadrature of the special path's items with a near-touch.

``special`` (block_quadrature.py) marks R_OK = ONE_DIP for an item without a sign change on its
samples (0, the Gauss nodes, 1), no root near either end outside, no zero end and a possible
near-touch (a dip of |v| towards zero that turns back); ``one_dip`` then does what
``component_integral`` would for it (steps 1 and 3 an item at a time, 2 across the items):

1. the scalar path's scan: the samples x_s = s / SAMPLES_PER_STEP over [-m_out / 8, 1 + m_out / 8]
   (m_out = ceil(8 window)), v and v' at each; an interval where |v| falls at the start and rises
   at the end and a pair of roots or a dip is possible (``pair_possible``, ``dip_possible`` with
   ``curvature_bound``) is where ``root_pair`` would look for the minimum of |v|;
2. with exactly one such interval, no sign change and no zero sample, the minimum x_m by Newton
   on v' kept inside it (``root_pair``'s iteration); eps = sqrt(2 v(x_m) / v''(x_m)), a dip when
   eps < DIP_PER_WINDOW window;
3. the pieces ``component_integral`` cuts: [0, x_m] and [x_m, 1] for x_m inside (0, 1), else
   [0, 1]; a piece within eps of x_m's singularities (``_piece``) by the sinh rule
   (``sinh_piece``: x = x_m + eps sinh(w), panels of equal width in w, at most SINH_PANEL), the
   others by Gauss–Legendre.

An item with no such interval, or whose minimum is no dip, keeps the Gauss–Legendre value of
``fast`` (what ``component_integral`` returns then). Anything else (a sign change or a zero among
the samples, two or more intervals, a minimum that reaches zero (a root pair or a double root),
Newton not converged, or a piece needing more than MAX_SINH_PANELS panels: eps below ~7e-4 of
the piece) gets R_OK = 0: the scalar path.

The exponentials of the sinh rule: with the panel width dw of a piece and its start wa, a node
xi_g of panel q is at w = wa + dw (q + xi_g), and e^w = e^wa (e^dw)^q e^(dw xi_g): one exp per
node and piece (e^wa = z + sqrt(z^2 + 1) from z = sinh(wa)), the powers by products (numba has no
vectorized exp here, so a call per node and panel would dominate).

The items are gathered into rows of their own in CB (``gather_items``: rows of CBS items, NC
coefficients, then the rows below).

Header names used: NC, CBS, OFC; R_OK, KEEP_FAST, gather_items, item_value of
block_quadrature.py; SAMPLES_PER_STEP, DIP_PER_WINDOW, SINH_PANEL, pair_possible, dip_possible,
_power of quadrature.py.
"""
# ruff: noqa: F821  (the upper-case constants, njit and JIT come from the generated header)

ONE_DIP = 6.0  # R_OK code set by ``special``: no sign change, a near-touch possible: done here
# Panels per piece of this template's sinh rule at most: asinh(L / eps) up to 8, eps down to
# ~7e-4 of the piece length L; narrower dips go to the scalar path
MAX_SINH_PANELS = 8
# Newton on v' from the secant point of its sample bracket (quadratic convergence; the scalar
# ``root_pair`` stops at 4e-16 and takes 4-6)
N_DIP_NEWTON = 10
DIP_CONVERGED = 1e-12  # the last Newton step (x units) of a converged minimum
(D_COUNT, D_BAD, D_LO, D_HI, D_FA, D_DA, D_DB, D_X, D_STEP, D_EPS, D_OK, D_SUM, D_A, D_B,
 D_SINH) = range(NC, NC + 15)
D_ROWS = NC + 15


@njit(**JIT)
def _value_slope(DB, t, x):
    """Item t's v and v' at x."""
    v = DB[(NC - 1) * CBS + t]
    d = 0.0
    for k in range(NC - 2, -1, -1):
        d = d * x + v
        v = v * x + DB[k * CBS + t]
    return v, d


@njit(**JIT)
def _slope_curvature(DB, t, x):
    """Item t's v, v' and v'' at x."""
    v = DB[(NC - 1) * CBS + t]
    d = 0.0
    dd = 0.0
    for k in range(NC - 2, -1, -1):
        dd = dd * x + d
        d = d * x + v
        v = v * x + DB[k * CBS + t]
    return v, d, 2.0 * dd


@njit(**JIT)
def _scan(DB, n, window):
    """Step 1 (see the module docstring): D_COUNT intervals where ``root_pair`` would look, the
    last one's bracket [D_LO, D_HI] with v at its start (D_FA) and v' at both ends (D_DA, D_DB);
    D_BAD > 0 for a sign change or a zero sample."""
    m_out = int(math.ceil(window * SAMPLES_PER_STEP))
    dx = 1.0 / SAMPLES_PER_STEP
    radius = 1.0 + (m_out + 1) * dx  # ``curvature_bound``'s radius in ``component_integral``, u = 1
    dip_limit = DIP_PER_WINDOW * window
    x0 = -m_out * dx
    # an item at a time (a few per call: see ``_add_piece``), the scan's state in locals
    for t in range(n):
        bound = 0.0
        scale = 1.0
        for k in range(2, NC):
            bound += k * (k - 1.0) * abs(DB[k * CBS + t]) * scale
            scale *= radius
        DB[D_EPS * CBS + t] = bound  # the curvature bound (D_EPS is free until step 2)
        f_prev, d_prev = _value_slope(DB, t, x0)
        count = 0.0
        bad = 1.0 if f_prev == 0.0 else 0.0
        lo = 0.0
        hi = 0.0
        fa = 1.0
        da = 0.0
        db = 0.0
        x_prev = x0
        for s in range(-m_out + 1, SAMPLES_PER_STEP + m_out + 1):
            x = 1.0 if s == SAMPLES_PER_STEP else s * dx
            f, d = _value_slope(DB, t, x)
            possible = (pair_possible(f_prev, f, bound, dx) > 0.0) | (dip_possible(f_prev, f, bound, dip_limit) > 0.0)
            # |v| falls at x_prev and rises at x: a minimum inside (``root_pair``'s test)
            look = (f_prev * f > 0.0) & possible & (f_prev * d_prev <= 0.0) & (f * d >= 0.0)
            count += 1.0 if look else 0.0
            bad += 1.0 if ((f_prev * f < 0.0) | (f == 0.0)) else 0.0
            lo = x_prev if look else lo
            hi = x if look else hi
            fa = f_prev if look else fa
            da = d_prev if look else da
            db = d if look else db
            f_prev = f
            d_prev = d
            x_prev = x
        DB[D_COUNT * CBS + t] = count
        DB[D_BAD * CBS + t] = bad
        DB[D_LO * CBS + t] = lo
        DB[D_HI * CBS + t] = hi
        DB[D_FA * CBS + t] = fa
        DB[D_DA * CBS + t] = da
        DB[D_DB * CBS + t] = db


@njit(**JIT)
def _minimum(DB, n):
    """Step 2: D_X, the minimum of |v| in [D_LO, D_HI] by Newton on v' from the secant point,
    kept inside the bracket (bisecting where a step leaves it); D_STEP the last step's size."""
    for t in range(n):
        lo = DB[D_LO * CBS + t]
        hi = DB[D_HI * CBS + t]
        da = DB[D_DA * CBS + t]
        db = DB[D_DB * CBS + t]
        x = lo - da * (hi - lo) / (db - da if db != da else 1.0)
        DB[D_X * CBS + t] = x if ((lo < x) & (x < hi)) else 0.5 * (lo + hi)
        DB[D_STEP * CBS + t] = math.inf
    # Each item stops at its own convergence: iterating a converged item on (because another
    # item of the batch has not converged) could move its x by a rounding step, so an item's
    # minimum, and its LD, would depend on which trajectories share its block.
    for _ in range(N_DIP_NEWTON):
        moving = 0
        for t in range(n):
            x = DB[D_X * CBS + t]
            lo = DB[D_LO * CBS + t]
            hi = DB[D_HI * CBS + t]
            step = DB[D_STEP * CBS + t]
            converged = step <= DIP_CONVERGED
            _, d, dd = _slope_curvature(DB, t, x)
            done = (d == 0.0) | converged
            falls = (d < 0.0) == (DB[D_DA * CBS + t] < 0.0)
            lo = x if (falls & (~done)) else lo
            hi = x if ((~falls) & (~done)) else hi
            x_new = x - d / (dd if dd != 0.0 else 1.0)
            # (a converged step may leave the bracket by rounding: x itself is an end of it)
            leaves = (dd == 0.0) | (((x_new < lo) | (x_new > hi)) & (abs(x_new - x) > DIP_CONVERGED))
            x_new = 0.5 * (lo + hi) if leaves else x_new
            x_new = x if done else x_new
            step = step if converged else abs(x_new - x)
            DB[D_STEP * CBS + t] = step
            moving += 0 if step <= DIP_CONVERGED else 1
            DB[D_X * CBS + t] = x_new
            DB[D_LO * CBS + t] = lo
            DB[D_HI * CBS + t] = hi
        if moving == 0:
            break


@njit(**JIT)
def _classify(DB, n, window):
    """D_OK: 1 a dip (D_X, D_EPS) integrated here, KEEP_FAST nothing to do, 0 the scalar path;
    for a dip, the first piece [D_A, D_B] (step 3)."""
    dip_limit = DIP_PER_WINDOW * window
    for t in range(n):
        x = DB[D_X * CBS + t]
        f, _, dd = _slope_curvature(DB, t, x)
        count = DB[D_COUNT * CBS + t]
        clean = DB[D_BAD * CBS + t] == 0.0
        converged = DB[D_STEP * CBS + t] <= DIP_CONVERGED
        # the minimum on the side of the samples (``root_pair``: a dip), not reaching zero
        above = f * DB[D_FA * CBS + t] > 0.0
        curved = f * dd > 0.0
        eps = math.sqrt(2.0 * f / dd) if curved else math.inf
        # (eps 0 only if 2 f / dd underflows: the scalar path's EPS_FLOOR takes it)
        dip = (count == 1.0) & clean & converged & above & curved & (eps < dip_limit) & (eps > 0.0)
        # no interval to look in, or a minimum that is no dip: Gauss–Legendre over the step
        plain = clean & ((count == 0.0) | ((count == 1.0) & converged & above & ((~curved) | (eps >= dip_limit))))
        DB[D_OK * CBS + t] = 1.0 if dip else (KEEP_FAST if plain else 0.0)
        DB[D_EPS * CBS + t] = eps if dip else 1.0
        DB[D_X * CBS + t] = x if dip else 2.0
        DB[D_SUM * CBS + t] = 0.0


@njit(**JIT)
def _add_piece(DB, n, kind, p, glx, glw):
    """D_SUM += int over [D_A, D_B] of |v|^p for every item: by the sinh rule about (D_X, D_EPS)
    where D_SINH is 1, else by Gauss–Legendre (see the module docstring); an item whose piece
    needs more than MAX_SINH_PANELS panels gets D_OK = 0.

    An item at a time: a call has a few (2-5 per block at rtol 1e-4 .. 1e-8), and loops across
    so few items, one per node and panel, cost more to set up than vectorizing saves. The sums
    run in the order of the loops across items before (node, then panel): the same values."""
    for t in range(n):
        a = DB[D_A * CBS + t]
        b = DB[D_B * CBS + t]
        length = b - a
        if DB[D_SINH * CBS + t] != 1.0:
            for g in range(glx.shape[0]):
                DB[D_SUM * CBS + t] += glw[g] * length * _power(abs(item_value(DB, t, a + length * glx[g])), kind, p)
            continue
        x_m = DB[D_X * CBS + t]
        eps = DB[D_EPS * CBS + t]
        za = (a - x_m) / eps
        zb = (b - x_m) / eps
        wa = math.asinh(za)
        span = math.asinh(zb) - wa
        panels = max(1.0, np.ceil(span / SINH_PANEL))  # a float: no conversion of a huge count
        if not panels <= MAX_SINH_PANELS:
            DB[D_OK * CBS + t] = 0.0
            continue
        dw = span / panels
        root = math.sqrt(za * za + 1.0)
        # e^asinh(z) without cancellation on either side
        e_start = za + root if za >= 0.0 else 1.0 / (root - za)
        ratio = math.exp(dw)
        for g in range(glx.shape[0]):
            # e^w at node g of panel q: e^wa (e^dw)^q e^(dw xi_g)
            grow = math.exp(dw * glx[g])
            e_panel = e_start
            for _ in range(int(panels)):
                e = e_panel * grow
                inverse = 1.0 / e
                y = x_m + 0.5 * eps * (e - inverse)
                jacobian = 0.5 * (e + inverse) * eps * dw
                DB[D_SUM * CBS + t] += glw[g] * jacobian * _power(abs(item_value(DB, t, y)), kind, p)
                e_panel *= ratio


@njit(**JIT)
def _set_piece(DB, n, first):
    """[D_A, D_B] and D_SINH of the first or second piece (``component_integral``'s walk): x_m
    inside (0, 1) cuts [0, 1] there; a piece takes the sinh rule where x_m's singularities lie
    within its length of the piece (``_piece``: |end - x_m|^2 + eps^2 <= length^2)."""
    for t in range(n):
        x_m = DB[D_X * CBS + t]
        eps = DB[D_EPS * CBS + t]
        inside = (x_m > 0.0) & (x_m < 1.0)
        a = 0.0 if first else (x_m if inside else 1.0)
        b = (x_m if inside else 1.0) if first else 1.0
        # the end nearer to x_m (the piece's end at x_m when inside)
        near = min(abs(a - x_m), abs(b - x_m))
        length = b - a
        DB[D_A * CBS + t] = a
        DB[D_B * CBS + t] = b
        DB[D_SINH * CBS + t] = 1.0 if ((length > 0.0) & (near * near + eps * eps <= length * length)) else 0.0


@njit(**JIT)
def one_dip(W, CB, ITEM, m, kind, p, glx, glw, window):
    """FC of every item of ``special`` with R_OK == ONE_DIP (see the module docstring); R_OK
    becomes KEEP_FAST where done (FC written, or the fast value stands), 0 for the scalar path."""
    DB, SOURCE, n = gather_items(CB, m, ONE_DIP, D_ROWS)
    if n == 0:
        return
    _scan(DB, n, window)
    _minimum(DB, n)
    _classify(DB, n, window)
    for first in (True, False):
        _set_piece(DB, n, first)
        _add_piece(DB, n, kind, p, glx, glw)
    for i in range(n):
        t = int(SOURCE[i])
        ok = DB[D_OK * CBS + i]
        if ok == 1.0:
            W[OFC + ITEM[t]] = DB[D_SUM * CBS + i]
        CB[R_OK * CBS + t] = KEEP_FAST if ok != 0.0 else 0.0
