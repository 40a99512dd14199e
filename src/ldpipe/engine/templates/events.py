"""Template: where a step's configuration polynomial first leaves a box (region exit, escape).

The stepping kernels give q_i(t0 + x h) as polynomials ``QC[k, i, j]`` in x on [0, 1]. An exit
is looked for on a grid of ``EXIT_SAMPLES`` points over the step; in the first sample interval
where the configuration is outside, every coordinate that crossed a face is refined to
machine precision (safeguarded Newton on the polynomial) and the earliest crossing wins.
Excursions that leave and re-enter between two grid points (1/16 of a step) are not seen.

Names used from quadrature.py: horner, refine_root.
"""
# ruff: noqa: F821  (njit, JIT and the quadrature helpers come from the generated module)

EXIT_SAMPLES = 16
NO_EXIT = 2.0  # returned when no crossing is found in (0, 1]


@njit(**JIT)
def _outside(QC, j, nc, n, lo, hi, x):
    for i in range(n):
        v = horner(QC, i, j, nc, x)
        if v < lo[i] or v > hi[i]:
            return True
    return False


@njit(**JIT)
def first_exit(QC, j, nc, n, lo, hi):
    """(x, face): the smallest x in (0, 1] where lane j's configuration leaves the box [lo, hi]
    and the face it leaves by, +(i+1) for the upper face of coordinate i, -(i+1) for the lower
    (the earliest crossing's; at equal x the lowest coordinate, lower face first); else
    (NO_EXIT, 0)."""
    x_prev = 0.0
    for s in range(1, EXIT_SAMPLES + 1):
        x = s / EXIT_SAMPLES
        if _outside(QC, j, nc, n, lo, hi, x):
            best = x
            best_face = 0
            for i in range(n):
                va = horner(QC, i, j, nc, x_prev)
                vb = horner(QC, i, j, nc, x)
                for face in range(2):
                    bound = lo[i] if face == 0 else hi[i]
                    fa = va - bound
                    fb = vb - bound
                    outward = vb < bound if face == 0 else vb > bound
                    if not outward:
                        continue
                    if fa == 0.0:
                        r = x_prev
                    elif fa * fb < 0.0:
                        r = refine_root(QC, i, j, nc, bound, x_prev, x, fa, fb)
                    else:
                        r = x  # left and came back between samples: take the sample
                    # the first outward face found takes the sample x if no crossing beats it
                    if r < best or best_face == 0:
                        best = r
                        best_face = i + 1 if face == 1 else -(i + 1)
            return best, best_face
        x_prev = x
    return NO_EXIT, 0


@njit(**JIT)
def inside(qv, lo, hi):
    """Whether the configuration qv lies in the box [lo, hi] (not for a NaN coordinate)."""
    for i in range(N):
        if not (lo[i] <= qv[i] <= hi[i]):
            return False
    return True


@njit(**JIT)
def outside_face(qv, lo, hi):
    """The face of the box [lo, hi] a configuration outside it is beyond: +(i+1) above the
    upper face of coordinate i, -(i+1) below the lower, for the lowest such i; 0 if inside."""
    for i in range(N):
        if qv[i] < lo[i]:
            return -(i + 1)
        if qv[i] > hi[i]:
            return i + 1
    return 0


@njit(**JIT)
def flag_box_exits(QC, nc, qn, lo, hi, flags):
    """flags[j] = True where lane j is outside [lo, hi] at the step end or at x = 1/4, 1/2, 3/4."""
    n, lanes = qn.shape
    for j in range(lanes):
        flags[j] = False
    for i in range(n):
        low = lo[i]
        high = hi[i]
        for j in range(lanes):
            v = qn[i, j]
            out = v < low or v > high
            for s in range(1, 4):
                x = 0.25 * s
                w = QC[nc - 1, i, j]
                for k in range(nc - 2, -1, -1):
                    w = w * x + QC[k, i, j]
                out = out or w < low or w > high
            flags[j] = flags[j] or out


@njit(**JIT)
def flag_escapes(qn, radius, flags):
    """flags[j] = True where lane j's step ends with max_i |q_i| > radius; returns whether any did."""
    n, lanes = qn.shape
    for j in range(lanes):
        flags[j] = False
    for i in range(n):
        for j in range(lanes):
            flags[j] = flags[j] or abs(qn[i, j]) > radius
    found = False
    for j in range(lanes):
        found = found or flags[j]
    return found
