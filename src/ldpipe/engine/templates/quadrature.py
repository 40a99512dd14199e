"""Template: the LD integrand |v_c(t)|^p over one step, where v_c is a velocity component.

On every step the stepping kernels hand over each phase-space velocity component as a
polynomial in the normalised time x = (t - t_0) / h on [0, 1] (monomial coefficients,
``VC[k, c, j]`` for coefficient k, component c, lane j). Its integrand |v|^p with p < 1 has a
cusp (s - r)^p at every root r of v, where any polynomial rule converges only like h^(1+p).
The rules here take the cusp into account:

fast path (all lanes at once, vectorized; ``fast`` in block_quadrature.py)
    Gauss–Legendre on [0, 1]. Used for a component when its samples on the step (the ends and
    the nodes) have one strict sign and the linear extrapolation from either end puts no root
    within ``window`` step lengths outside the step. The nearest singularity is then at least
    that far away and the rule converges geometrically (a singularity at distance d beyond an
    end of [0, 1] gives an error ~ rho^(-2n), rho = 1 + 2d + 2 sqrt(d + d^2)).
special path (``special`` in block_quadrature.py for the common cases, else one lane and one
component at a time: ``component_integral`` below)
    The roots of the polynomial on [-window u, (1 + window) u] are bracketed on a sample grid
    and refined by safeguarded Newton. [0, u] is cut at the interior roots. Each piece [a, b]
    whose nearest root r outside or at an end lies within one piece length is integrated with
    Gauss–Jacobi nodes for the weight (s - r)^p, as the difference of the integrals from r to b
    and from r to a (the second is zero when r = a); the integrand left after the weight,
    |v(s) / (s - r)|^p, is smooth. A piece with such roots on both sides is halved first.
    Other pieces use Gauss–Legendre. Two roots between one pair of samples (where v dips to
    the other sign and back) are found from the minimum of |v| (``root_pair``); a sample
    exactly at a simple root looks for a second root towards a neighbour of the same sign.
    Where a root has another beyond it closer than the piece is long, Gauss–Jacobi takes only
    that gap and Gauss–Legendre the rest, on pieces growing geometrically (``_from_root``).
    The fast path sends a component here also when such a dip is possible between two of its
    samples (``pair_possible``, with a bound of |v''| from the coefficients), unless ``pair_check``
    (flag_checks.py) rules the pair out with a bound over each sample interval.

near-touches (a dip of |v| towards zero that turns back, or a double root)
    The fast pass and ``special`` flag a component without a sign change where the local
    quadratic at an end has complex roots within DIP_PER_WINDOW * window, or where
    ``dip_possible`` holds at the nodes; the scalar path records such minima (``root_pair``)
    and double roots as dips, cuts the step at them and integrates the pieces next to them with
    the sinh substitution x = x_m + eps sinh(w) (``sinh_piece``). A flag with no root near
    either end is ``one_dip``'s (block_dips.py: this search and rule, vectorized, for one dip;
    anything else comes here); one beside a root just outside an end reaches the scalar path
    only where ``touch_matters`` (flag_checks.py) finds a minimum of |v| narrower than the dip
    width. Two roots outside the step, close together, count as one double-root dip.

Arc length sqrt(sum_c v_c^2) is smooth unless every component vanishes together, so it always
takes the Gauss–Legendre path.

Every routine works in x: results are integrals over dx and the caller multiplies by |h|.

Header names used: njit, JIT, math, KIND_HALF, KIND_ONE.
"""
# ruff: noqa: F821  (njit, JIT and the KIND_* constants come from the generated header)

SAMPLES_PER_STEP = 8  # sample grid of the special path, per unit of u
ROOT_ITERATIONS = 60
# Near-touches (a dip of |v| towards zero that turns back, or a double root): a minimum x_m of
# |v| with v ~ v_m + v''(x - x_m)^2 / 2 puts the singularities of |v|^p at x_m +- i eps,
# eps = sqrt(2 v_m / v''), so close to the real axis that Gauss–Legendre stalls. The fast pass
# flags a component where 2 min|v| < width^2 * (a bound of |v''|) over the samples, i.e.
# where such a pair could lie within width = DIP_PER_WINDOW * window step lengths of a sample
# (``dip_possible``): 0.25 at the window 0.1 of loose tolerances, 0.5 at 0.2 (measured on
# Hénon–Heiles near-touches with dop853 at rtol 1e-12: worst LD error 3e-10 with 0.25, 1.5e-11
# with 0.5, 3e-12 with 16 nodes). The cost (Barbanis section, dop853, CPU time against the
# quadrature without the near-touch rule): 1.23x at rtol 1e-6 and 1e-8, 1.05x at 1e-10 with 2.5;
# ~1.08x at 1e-6/1e-8 with 1.5, whose worst error at rtol 1e-12 is 1.6e-10 (no longer falling
# 10x per two decades of rtol).
DIP_PER_WINDOW = 2.5
MAX_DIPS = 4  # dips kept per component and step, at the top of the ``roots`` scratch
SINH_PANEL = 1.0  # panel width in w of the sinh rule (its integrand is analytic for |Im w| < pi / 2)
DOUBLE_ROOT = 1e-8  # a zero sample whose local quadratic's other root is closer (x units): a double root
EPS_FLOOR = 1e-12  # the smallest eps of the sinh rule (x units): a double root's integrand ~ eps^(1 + 2p) below


@njit(**JIT)
def horner(VC, c, j, nc, x):
    """Value at x of the polynomial sum_k VC[k, c, j] x^k of nc coefficients."""
    v = VC[nc - 1, c, j]
    for k in range(nc - 2, -1, -1):
        v = v * x + VC[k, c, j]
    return v


@njit(**JIT)
def horner_d(VC, c, j, nc, x):
    """Value and first derivative at x of the polynomial sum_k VC[k, c, j] x^k."""
    v = VC[nc - 1, c, j]
    d = 0.0
    for k in range(nc - 2, -1, -1):
        d = d * x + v
        v = v * x + VC[k, c, j]
    return v, d


@njit(**JIT)
def horner_dd(VC, c, j, nc, x):
    """Value, first and second derivative at x of the polynomial sum_k VC[k, c, j] x^k."""
    v = VC[nc - 1, c, j]
    d = 0.0
    dd = 0.0
    for k in range(nc - 2, -1, -1):
        dd = dd * x + d
        d = d * x + v
        v = v * x + VC[k, c, j]
    return v, d, 2.0 * dd


@njit(**JIT)
def refine_root(VC, c, j, nc, shift, a, b, fa, fb):
    """Root of (polynomial - shift) in [a, b] where it changes sign: Newton kept inside a bisection bracket."""
    x = a - fa * (b - a) / (fb - fa)
    if not (a < x < b):
        x = 0.5 * (a + b)
    for _ in range(ROOT_ITERATIONS):
        f, d = horner_d(VC, c, j, nc, x)
        f -= shift
        if f == 0.0:
            return x
        if (f < 0.0) == (fa < 0.0):
            a = x
            fa = f
        else:
            b = x
        step_ok = d != 0.0
        x_new = x - f / d if step_ok else 0.5 * (a + b)
        if not (a < x_new < b):
            x_new = 0.5 * (a + b)
        if abs(x_new - x) <= 2e-16 * max(1.0, abs(x)) or b - a <= 4e-16 * max(1.0, abs(a)):
            return x_new
        x = x_new
    return x


@njit(**JIT)
def curvature_bound(VC, c, j, nc, radius):
    """An upper bound of |v''(x)| for |x| <= radius: sum_k k (k - 1) |c_k| radius^(k - 2)."""
    bound = 0.0
    scale = 1.0
    for k in range(2, nc):
        bound += k * (k - 1.0) * abs(VC[k, c, j]) * scale
        scale *= radius
    return bound


@njit(**JIT)
def pair_possible(va, vb, bound, gap):
    """1.0 if v may cross zero twice between samples va, vb of one sign, gap apart, given
    |v''| <= bound there; else 0.0.

    v lies above its chord less (bound / 2)(x - a)(b - x), a convex quadratic in x whose
    minimum, for |vb| - |va| = s and B = s / gap - bound gap / 2, is |va| - B^2 / (2 bound),
    inside the interval when |s| < bound gap^2 / 2. A pair of roots needs that minimum below
    zero. (The test min(|va|, |vb|) <= bound gap^2 / 8 used before is the case s = 0 and also
    flagged intervals whose ends differ much: 3-4x the scalar work at rtol 1e-5.)
    """
    a = abs(va)
    s = abs(vb) - a
    half_width = 0.5 * bound * gap * gap
    slope = s / gap - 0.5 * bound * gap
    possible = (va * vb > 0.0) & (abs(s) < half_width) & (2.0 * bound * a < slope * slope)
    return 1.0 if possible else 0.0


@njit(**JIT)
def dip_possible(va, vb, bound, width):
    """1.0 if a near-touch (complex roots x_m +- i eps of v) may lie within ``width`` of a sample
    where v = va or vb, given |v''| <= bound; else 0.0.

    In the quadratic model 2 |v(x)| / v'' = (x - x_m)^2 + eps^2, the squared distance of the
    singularities from x; with v'' <= bound, 2 |v| / bound is no more than that, so the test
    2 min(|va|, |vb|) < width^2 bound misses no pair within ``width``.
    """
    return 1.0 if 2.0 * min(abs(va), abs(vb)) < width * width * bound else 0.0


@njit(**JIT)
def add_dip(roots, n_dips, x_m, eps):
    """Keep the dip (x_m, eps) at the top of ``roots`` (pairs from the end); returns the count."""
    if n_dips >= MAX_DIPS:
        return n_dips
    top = roots.shape[0] - 2 * n_dips
    roots[top - 1] = x_m
    roots[top - 2] = eps
    return n_dips + 1


@njit(**JIT)
def sinh_piece(VC, c, j, nc, a, b, x_m, eps, kind, p, glx, glw):
    """int_a^b |v|^p dx where v has a near-touch at x_m (singularities x_m +- i eps), x_m <= a or x_m >= b.

    The substitution x = x_m + eps sinh(w) (Johnston & Elliott's sinh transformation) maps the
    near-singularities to w = +- i pi / 2 and spreads the layer of width eps around x_m over
    O(1) in w: in the quadratic model |v|^p dx = v_m^p cosh(w)^(1 + 2p) eps dw, analytic in the
    strip |Im w| < pi / 2. The w interval (length ~ log(2 (b - a) / eps)) is cut into panels of
    width SINH_PANEL, each by Gauss–Legendre. A double root (eps = 0) uses eps = EPS_FLOOR: the
    integrand near w = 0 is then ~ eps^(1 + 2p), below rounding.
    """
    eps = max(eps, EPS_FLOOR)
    wa = math.asinh((a - x_m) / eps)
    wb = math.asinh((b - x_m) / eps)
    n_panels = max(1, int(math.ceil((wb - wa) / SINH_PANEL)))
    dw = (wb - wa) / n_panels
    total = 0.0
    for q in range(n_panels):
        w0 = wa + q * dw
        for g in range(glx.shape[0]):
            # sinh and cosh from one exp (two transcendental calls were most of the rule's cost);
            # sinh loses relative accuracy near w = 0, but x = x_m + eps sinh(w) only an absolute
            # ~1e-16 eps
            e = math.exp(w0 + dw * glx[g])
            inverse = 1.0 / e
            x = x_m + 0.5 * eps * (e - inverse)
            total += glw[g] * 0.5 * (e + inverse) * _power(abs(horner(VC, c, j, nc, x)), kind, p)
    return total * eps * dw


@njit(**JIT)
def root_pair(VC, c, j, nc, a, b, fa, fb, da, db, roots, n_roots, n_dips, dip_limit):
    """Roots of v in (a, b) when v(a), v(b) have one sign but |v| dips to the other sign between.

    fa, fb, da, db: v and v' at a and b. Returns (n_roots, n_dips): where the dip does not reach zero and its eps (see
    ``dip_possible``) is below ``dip_limit``, the minimum is kept as a dip (``add_dip``).

    The samples a, b miss a pair of roots closer together than their spacing. If |v| falls at
    a and rises at b, its minimum (a root of v') is bracketed and found by Newton's method on
    v' kept inside the bracket (bisection where a Newton step leaves it; a few iterations, where
    plain bisection took ~50 and dominated the scalar path's time); where v has the other sign
    there, each half holds one root. Appends them to ``roots`` and returns the new count.
    """
    if not (fa * da <= 0.0 and fb * db >= 0.0):
        return n_roots, n_dips  # |v| monotone, or a maximum of |v| inside: no pair
    lo = a
    hi = b
    x_min = a - da * (b - a) / (db - da)  # the secant root of v'
    if not (lo < x_min < hi):
        x_min = 0.5 * (lo + hi)
    for _ in range(ROOT_ITERATIONS):
        _, dm, ddm = horner_dd(VC, c, j, nc, x_min)
        if dm == 0.0:
            break
        if (dm < 0.0) == (da < 0.0):
            lo = x_min
        else:
            hi = x_min
        x_new = x_min - dm / ddm if ddm != 0.0 else 0.5 * (lo + hi)
        if not (lo < x_new < hi):
            x_new = 0.5 * (lo + hi)
        converged = abs(x_new - x_min) <= 4e-16 * max(1.0, abs(x_min)) or hi - lo <= 4e-16 * max(1.0, abs(lo))
        x_min = x_new
        if converged:
            break
    f_min, _, dd_min = horner_dd(VC, c, j, nc, x_min)
    if f_min * fa >= 0.0:  # the dip does not reach zero: a near-touch when it is narrow
        if f_min * dd_min > 0.0:
            eps = math.sqrt(2.0 * f_min / dd_min)
            if eps < dip_limit:
                n_dips = add_dip(roots, n_dips, x_min, eps)
        elif f_min == 0.0:
            n_dips = add_dip(roots, n_dips, x_min, 0.0)
        return n_roots, n_dips
    roots[n_roots] = refine_root(VC, c, j, nc, 0.0, a, x_min, fa, f_min)
    roots[n_roots + 1] = refine_root(VC, c, j, nc, 0.0, x_min, b, f_min, fb)
    return n_roots + 2, n_dips


@njit(**JIT)
def _power(y, kind, p):
    """y^p for y >= 0 (the fast special cases first)."""
    if kind == KIND_HALF:
        return math.sqrt(y)
    if kind == KIND_ONE:
        return y
    return y**p


@njit(**JIT)
def _legendre(VC, c, j, nc, a, b, kind, p, glx, glw):
    total = 0.0
    length = b - a
    for g in range(glx.shape[0]):
        total += glw[g] * _power(abs(horner(VC, c, j, nc, a + length * glx[g])), kind, p)
    return total * length


@njit(**JIT)
def _jacobi(VC, c, j, nc, r, e, kind, p, gjx, gjf):
    """int over [r, e] (or [e, r]) of |v|^p, with the cusp (s - r)^p at the root r taken out.

    Gauss–Jacobi for the weight |s - r|^p with the weights folded: gjf_g = w_g xi_g^-p, so that
    the integral is |e - r| sum_g gjf_g |v(r + (e - r) xi_g)|^p (no division by |s - r|^p).
    """
    length = abs(e - r)
    if length == 0.0:
        return 0.0
    sign = 1.0 if e > r else -1.0
    total = 0.0
    for g in range(gjx.shape[0]):
        total += gjf[g] * _power(abs(horner(VC, c, j, nc, r + sign * length * gjx[g])), kind, p)
    return total * length


@njit(**JIT)
def _from_root(VC, c, j, nc, r, gap, e, kind, p, glx, glw, gjx, gjf):
    """int over [r, e] (or [e, r]) of |v|^p from a root r, where the next root beyond r (away
    from e) lies ``gap`` from it (inf: none, or farther).

    Gauss–Jacobi at r leaves |v(s) / (s - r)|^p, whose cusp at the other root lies ``gap``
    beyond r: with d = gap / |e - r| the rule converges like rho^(-2n),
    rho = 1 + 2d + 2 sqrt(d + d^2), which stalls as d -> 0 (two roots much closer than the
    piece). So for d < 1 Gauss–Jacobi takes only [r, r +- gap] (the other root one length
    beyond its end: rho = 3 + 2 sqrt 2), and the rest is cut into pieces each as long as its
    distance from r, by Gauss–Legendre (the nearest singularity, r, one length away: the same
    rho; error ~ rho^(-2n), 6e-13 relative with 8 nodes, 8e-7 with 4).
    """
    length = abs(e - r)
    if gap >= length:
        return _jacobi(VC, c, j, nc, r, e, kind, p, gjx, gjf)
    sign = 1.0 if e > r else -1.0
    # a gap of 0 (two roots equal in floating point: a double root) starts the grading just off r
    near = max(gap, 1e-15 * length)
    total = _jacobi(VC, c, j, nc, r, r + sign * near, kind, p, gjx, gjf)
    while near < length:
        far = min(2.0 * near, length)
        if sign > 0.0:
            total += _legendre(VC, c, j, nc, r + near, r + far, kind, p, glx, glw)
        else:
            total += _legendre(VC, c, j, nc, r - far, r - near, kind, p, glx, glw)
        near = far
    return total


@njit(**JIT)
def _one_side(VC, c, j, nc, a, b, anchor, gap, left, kind, p, glx, glw, gjx, gjf):
    """int_a^b |v|^p with one root `anchor` at or beyond the end a (left) or b (right), and the
    next root beyond the anchor ``gap`` from it (inf: none)."""
    if left:
        distance = a - anchor
        if distance <= b - a:
            outer = _from_root(VC, c, j, nc, anchor, gap, b, kind, p, glx, glw, gjx, gjf)
            return outer - _from_root(VC, c, j, nc, anchor, gap, a, kind, p, glx, glw, gjx, gjf)
    else:
        distance = anchor - b
        if distance <= b - a:
            outer = _from_root(VC, c, j, nc, anchor, gap, a, kind, p, glx, glw, gjx, gjf)
            return outer - _from_root(VC, c, j, nc, anchor, gap, b, kind, p, glx, glw, gjx, gjf)
    return _legendre(VC, c, j, nc, a, b, kind, p, glx, glw)


@njit(**JIT)
def _side(VC, c, j, nc, a, b, x, eps, gap, left, kind, p, glx, glw, gjx, gjf):
    """int_a^b |v|^p with one feature beyond or at an end: a root x (eps < 0; the next root beyond
    it ``gap`` away) or a dip (x, eps)."""
    if eps < 0.0:
        return _one_side(VC, c, j, nc, a, b, x, gap, left, kind, p, glx, glw, gjx, gjf)
    return sinh_piece(VC, c, j, nc, a, b, x, eps, kind, p, glx, glw)


@njit(**JIT)
def _distance(x, eps, e):
    """Distance from the end e to a root x (eps < 0) or to the singularities x +- i eps of a dip."""
    if eps < 0.0:
        return abs(e - x)
    return math.sqrt((e - x) * (e - x) + eps * eps)


@njit(**JIT)
def _piece(VC, c, j, nc, a, b, left_x, left_eps, left_gap, right_x, right_eps, right_gap, kind, p, glx, glw, gjx,
           gjf):
    """int_a^b |v|^p, v without roots inside (a, b), with the nearest feature on each side:
    left_x <= a, right_x >= b (+-inf: none), each a root (eps < 0) or a dip (eps >= 0); a root's
    gap is the distance to the next root beyond it (inf: none)."""
    length = b - a
    if length <= 0.0:
        return 0.0
    near_left = _distance(left_x, left_eps, a) <= length
    near_right = _distance(right_x, right_eps, b) <= length
    if near_left and near_right:
        middle = 0.5 * (a + b)
        return _side(VC, c, j, nc, a, middle, left_x, left_eps, left_gap, True, kind, p, glx, glw, gjx, gjf) + _side(
            VC, c, j, nc, middle, b, right_x, right_eps, right_gap, False, kind, p, glx, glw, gjx, gjf
        )
    if near_left:
        return _side(VC, c, j, nc, a, b, left_x, left_eps, left_gap, True, kind, p, glx, glw, gjx, gjf)
    if near_right:
        return _side(VC, c, j, nc, a, b, right_x, right_eps, right_gap, False, kind, p, glx, glw, gjx, gjf)
    return _legendre(VC, c, j, nc, a, b, kind, p, glx, glw)


@njit(**JIT)
def component_integral(VC, c, j, nc, u, kind, p, glx, glw, gjx, gjf, window, roots):
    """int_0^u |v_c(x)|^p dx for lane j, cutting at the roots of v_c (the special path).

    Between two samples of one sign, a pair of roots is looked for (``root_pair``) where a
    polynomial of this curvature can dip to the other sign between them (``pair_possible``) or
    come near zero (``dip_possible``); a minimum that does not reach zero, with eps below
    DIP_PER_WINDOW window u, is a dip: the pieces are cut at it when it is inside [0, u], and the pieces
    next to it are integrated by the sinh rule (``sinh_piece``). A zero sample where v' vanishes
    too (a double root; DOUBLE_ROOT) is a dip with eps = 0, not a root: the Gauss–Jacobi weight
    (x - r)^p would be wrong there, |v|^p ~ |x - r|^(2p).

    ``roots`` is scratch space of at least 3 (2 m_out + SAMPLES_PER_STEP + 1) + 2 MAX_DIPS
    entries, m_out = ceil(window SAMPLES_PER_STEP): two roots per sample interval, one per
    sample; the dips are kept at its top.
    """
    m = SAMPLES_PER_STEP
    m_out = int(math.ceil(window * m))
    dx = u / m
    curvature = curvature_bound(VC, c, j, nc, max(1.0, u) + (m_out + 1) * dx)
    dip_limit = DIP_PER_WINDOW * window * u
    n_roots = 0
    n_dips = np.int64(0)  # (typed, not a literal: numba would compile the callees it reaches once more for the literal's type)
    # v and v' at each sample in one Horner pass: root_pair needs v' at both ends of an
    # interval, and each sample is the end of two
    x_prev = -m_out * dx
    f_prev, d_prev = horner_d(VC, c, j, nc, x_prev)
    # A sample exactly at a simple root r hides a second root between it and a neighbour of the
    # same sign (no sign change, and no pair test with a zero end): v leaves r towards the other
    # sign, so another root lies before that neighbour. d_zero is v' at the last zero sample
    # (0 for none, or a double root).
    d_zero = 0.0
    if f_prev == 0.0:
        roots[n_roots] = x_prev
        n_roots += 1
        d_zero = d_prev
    for s in range(-m_out + 1, m + m_out + 1):
        x = s * dx
        if s == m:
            x = u  # exactly the end, whatever the rounding of s * dx
        f, d_here = horner_d(VC, c, j, nc, x)
        if f_prev * f < 0.0:
            roots[n_roots] = refine_root(VC, c, j, nc, 0.0, x_prev, x, f_prev, f)
            n_roots += 1
        elif f_prev * f > 0.0 and (
            pair_possible(f_prev, f, curvature, dx) > 0.0 or dip_possible(f_prev, f, curvature, dip_limit) > 0.0
        ):
            n_roots, n_dips = root_pair(VC, c, j, nc, x_prev, x, f_prev, f, d_prev, d_here, roots, n_roots, n_dips,
                                        dip_limit)
        elif f_prev == 0.0 and d_zero * f < 0.0:  # leaves the zero sample towards the other sign
            roots[n_roots] = refine_root(VC, c, j, nc, 0.0, x_prev, x, d_zero, f)
            n_roots += 1
        d_zero = 0.0
        if f == 0.0:
            _, d, dd = horner_dd(VC, c, j, nc, x)
            if abs(2.0 * d) <= DOUBLE_ROOT * abs(dd):
                n_dips = add_dip(roots, n_dips, x, 0.0)
            else:
                if f_prev * d > 0.0:  # arrives at the zero sample from the other sign than f_prev
                    roots[n_roots] = refine_root(VC, c, j, nc, 0.0, x_prev, x, f_prev, -d)
                    n_roots += 1
                roots[n_roots] = x
                n_roots += 1
                d_zero = d
        x_prev = x
        f_prev = f
        d_prev = d_here
    # Two roots outside [0, u] on one side, closer to each other than half their distance from
    # the step: seen from the step they are a double root (|v|^p ~ |x - x_m|^(2p)), and the
    # Gauss–Jacobi weight of the nearer one alone would leave the other's cusp just beyond its
    # anchor. They become one dip of width 0 at their midpoint (the sinh rule).
    kept = 0
    i = 0
    while i < n_roots:
        r0 = roots[i]
        if i + 1 < n_roots:
            r1 = roots[i + 1]
            gap = r1 - r0
            outside_left = r1 <= 0.0 and -r1 >= 2.0 * gap
            outside_right = r0 >= u and r0 - u >= 2.0 * gap
            if outside_left or outside_right:
                n_dips = add_dip(roots, n_dips, 0.5 * (r0 + r1), 0.0)
                i += 2
                continue
        roots[kept] = r0
        kept += 1
        i += 1
    n_roots = kept
    # the dips, sorted by position (a few: insertion sort of the (x, eps) pairs at the top)
    top = roots.shape[0]
    for q in range(1, n_dips):
        k = q
        while k > 0 and roots[top - 1 - 2 * k] < roots[top - 1 - 2 * (k - 1)]:
            for o in range(1, 3):
                held = roots[top - o - 2 * k]
                roots[top - o - 2 * k] = roots[top - o - 2 * (k - 1)]
                roots[top - o - 2 * (k - 1)] = held
            k -= 1
    # Walk the pieces of [0, u] between the interior roots and dips; the features left and right
    # of each piece are the nearest root or dip (eps < 0 marks a root). Where such a root has
    # another root just beyond it (a close pair), its gap goes with it (``_from_root``).
    left_x = -math.inf
    left_eps = -1.0
    left_gap = math.inf
    k = 0
    q = 0
    total = 0.0
    a = 0.0
    for _ in range(n_roots + n_dips + 1):
        rk = roots[k] if k < n_roots else math.inf
        dq = roots[top - 1 - 2 * q] if q < n_dips else math.inf
        x_next = min(rk, dq)
        is_root = rk <= dq
        eps_next = -1.0 if is_root else roots[top - 2 - 2 * q]
        right_gap = math.inf
        if is_root and k + 1 < n_roots and roots[k + 1] <= dq:
            right_gap = roots[k + 1] - rk  # the next feature is a root too
        if x_next > 0.0 and x_next < u:
            total += _piece(VC, c, j, nc, a, x_next, left_x, left_eps, left_gap, x_next, eps_next, right_gap,
                            kind, p, glx, glw, gjx, gjf)
            a = x_next
        if x_next >= u:
            total += _piece(VC, c, j, nc, a, u, left_x, left_eps, left_gap, x_next, eps_next, right_gap,
                            kind, p, glx, glw, gjx, gjf)
            return total
        # the feature becomes the left one: the gap to the root before it, if both are roots
        left_gap = x_next - left_x if is_root and left_eps < 0.0 else math.inf
        left_x = x_next  # a feature at or before 0, or the cut just made
        left_eps = eps_next
        if is_root:
            k += 1
        else:
            q += 1
    return total


@njit(**JIT)
def arclength_integral(VC, n_comp, j, nc, u, glx, glw):
    """int_0^u sqrt(sum_c v_c(x)^2) dx for lane j (Gauss–Legendre; the integrand is smooth)."""
    total = 0.0
    for g in range(glx.shape[0]):
        x = u * glx[g]
        s = 0.0
        for c in range(n_comp):
            v = horner(VC, c, j, nc, x)
            s += v * v
        total += glw[g] * math.sqrt(s)
    return total * u
