"""Template: the cheap checks that spare the scalar path a flag of ``fast`` that needs nothing.

``fast`` (block_quadrature.py) flags a component for the special path on bounds that hold for
the whole step, so most flags of a step without a sign change on its samples are false alarms;
``special`` sends those items here before paying ~50 Horner evaluations of the scalar
``component_integral`` for them:

* ``touch_matters`` (a near-touch beside a root just outside an end): Newton's method
  on v' finds the minima of |v|; only one that ``component_integral`` would take as a dip
  sends the component on;
* ``pair_check`` (a possible root pair between two samples alone): ``pair_possible`` again with
  a bound of |v''| over each sample interval instead of over the step.

Header names used: NC, CBS and the item rows of block_quadrature.py (R_OK and
the R_OK codes), SAMPLES_PER_STEP and DIP_PER_WINDOW of quadrature.py.
"""
# ruff: noqa: F821  (the upper-case constants, njit and JIT come from the generated header)

TOUCH_ITERATIONS = 12  # Newton on v' in ``touch_matters`` (quadratic convergence from a node)


@njit(**JIT)
def touch_matters(VC, c, j, nc, glx, ends, window):
    """False if the near-touch flagged on a step of lane j, component c, beside a root just
    outside an end would not be taken as a dip by ``component_integral`` (the Jacobi pieces at
    the root stand); True where it would, or where that is not certain.

    ``block_quadrature.special`` calls it for a component without a sign change on its samples
    (0, the nodes ``glx``, 1), with a root just beyond one end (the left/right case), flagged
    because a near-touch may lie within DIP_PER_WINDOW * window of a sample. The minima of |v|
    are looked for by Newton's method on v' from every sample where |v| is a local minimum over
    the samples, and from the vertex of the local quadratic at the end 0 (``ends`` & 1) and 1
    (& 2), flagged where that quadratic has complex roots or beside the root (where the nodes
    next to the root are small because of it, and a search from the vertex that ends on the
    range's bound found no minimum). As in ``root_pair``, each minimum's eps =
    sqrt(2 v(x_m) / v''(x_m)) is compared with the dip width; outside the scalar path's sample
    range (where ``component_integral`` does not look), or with eps at least the width, it is no
    dip. Most flags are of this kind (the flag bounds eps from below by the samples), and the
    test costs a few Horner evaluations per start where the scalar path costs ~50.
    """
    m_out = int(math.ceil(window * SAMPLES_PER_STEP))
    lo = -m_out / SAMPLES_PER_STEP
    hi = 1.0 + m_out / SAMPLES_PER_STEP
    width = DIP_PER_WINDOW * window
    v0, d0, a0 = horner_dd(VC, c, j, nc, 0.0)
    v1, d1, a1 = horner_dd(VC, c, j, nc, 1.0)
    n_nodes = glx.shape[0]
    f_prev = math.inf
    f_here = abs(v0)
    for start in range(n_nodes + 4):
        if start < n_nodes + 2:  # a sample (0, the nodes, 1) where |v| is a local minimum over them
            x = 0.0 if start == 0 else (glx[start - 1] if start <= n_nodes else 1.0)
            if start <= n_nodes:
                f_next = abs(horner(VC, c, j, nc, glx[start])) if start < n_nodes else abs(v1)
            else:
                f_next = math.inf
            local = f_here <= f_prev and f_here <= f_next
            f_prev = f_here
            f_here = f_next
            if not local:
                continue
        elif start == n_nodes + 2:  # the vertex of the quadratic at 0 (the bound for a straight line)
            if not ends & 1:
                continue
            x = -d0 / a0 if a0 != 0.0 else (lo if d0 * v0 > 0.0 else hi)
        else:
            if not ends & 2:
                continue
            x = 1.0 - d1 / a1 if a1 != 0.0 else (hi if d1 * v1 < 0.0 else lo)
        x = min(max(x, lo), hi)
        converged = False
        for _ in range(TOUCH_ITERATIONS):
            _, d, dd = horner_dd(VC, c, j, nc, x)
            if dd == 0.0:
                break
            x_new = min(max(x - d / dd, lo), hi)
            converged = abs(x_new - x) <= 1e-12
            x = x_new
            if converged:
                break
        if not converged:
            return True
        if not lo < x < hi:
            continue  # v' keeps its sign towards the bound: no minimum that way
        v_m, _, dd_m = horner_dd(VC, c, j, nc, x)
        if v_m * dd_m <= 0.0:  # no minimum of |v| that stays off zero
            if v_m * v0 <= 0.0:
                return True  # beyond the root: a second root there (a root pair outside)
            continue  # a maximum of |v| on the step's side of the root
        if 2.0 * abs(v_m) < width * width * abs(dd_m):  # eps < width
            return True
    return False


@njit(**JIT)
def pair_check(CB, m, glx):
    """R_OK of the items flagged for a possible root pair alone (PAIR_CHECK): KEEP_FAST where
    ``pair_possible`` rules the pair out on every sample interval with a bound of |v''| over
    that interval, else 0 (the scalar path).

    ``fast`` bounds |v''| over the whole step (sum k (k - 1) |c_k|); over an interval [a, b]
    of midpoint x_c and half-width r, |v''| <= |v''(x_c)| + |v'''(x_c)| r + B4 r^2 / 2 (Taylor,
    B4 = sum k (k - 1) (k - 2) (k - 3) |c_k| bounds |v''''| on [0, 1]) is much smaller: most
    such flags at rtol 1e-4 and 1e-5 are cleared here and keep the Gauss–Legendre value, as an
    unflagged component does.
    """
    # only the PAIR_CHECK items (a few of the m): their indices, and per item the sample before,
    # whether a pair is possible so far, and B4 (the same on every interval)
    n = 0
    for t in range(m):
        n += 1 if CB[R_OK * CBS + t] == PAIR_CHECK else 0
    IDX = np.empty(n, dtype=np.int64)
    PREV = np.empty(n)
    PAIR = np.zeros(n)
    B4 = np.zeros(n)
    i = 0
    for t in range(m):
        if CB[R_OK * CBS + t] == PAIR_CHECK:
            IDX[i] = t
            PREV[i] = CB[t]
            for k in range(4, NC):
                B4[i] += k * (k - 1.0) * (k - 2.0) * (k - 3.0) * abs(CB[k * CBS + t])
            i += 1
    n_nodes = glx.shape[0]
    x_prev = 0.0
    for s in range(n_nodes + 1):
        x = glx[s] if s < n_nodes else 1.0
        x_c = 0.5 * (x_prev + x)
        r = 0.5 * (x - x_prev)
        for i in range(n):
            t = IDX[i]
            v = CB[(NC - 1) * CBS + t]
            for k in range(NC - 2, -1, -1):
                v = v * x + CB[k * CBS + t]
            # Horner's derivative chains at x_c: d2 = v''(x_c) / 2, d3 = v'''(x_c) / 6
            w = CB[(NC - 1) * CBS + t]
            d1 = 0.0
            d2 = 0.0
            d3 = 0.0
            for k in range(NC - 2, -1, -1):
                d3 = d3 * x_c + d2
                d2 = d2 * x_c + d1
                d1 = d1 * x_c + w
                w = w * x_c + CB[k * CBS + t]
            bound = 2.0 * abs(d2) + 6.0 * abs(d3) * r + 0.5 * B4[i] * r * r
            PAIR[i] = max(PAIR[i], pair_possible(PREV[i], v, bound, x - x_prev))
            PREV[i] = v
        x_prev = x
    for i in range(n):
        CB[R_OK * CBS + IDX[i]] = KEEP_FAST if PAIR[i] == 0.0 else 0.0
