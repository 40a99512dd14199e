# The closing section of the flow engine of velocity data on a curvilinear grid
# (ldpipe.systems.velocity_data.curvilinear, appended by ldpipe.engine.vector_field after the
# driver's templates). The state is the grid's fractional indices (i, j), whose velocity the
# regular grid's kernel interpolates; the LD is taken in physical units: the section rebinds
#
# * ``dense`` to the state's dense output followed by the physical velocity's: at each stage m of
#   the step, the stage's index velocity K[m] times the metric P at the stage's own state (P: the
#   physical velocity per unit index velocity, 2 x 2, interpolated by cubic convolution from its
#   nodes), so VC holds the physical velocity with the order of the state's dense output (as
#   sphere_ld_metric.py does with cos(lat));
# * ``step_ld`` to the quadrature of that velocity, the arc length times header value 13 (on the
#   sphere the data's velocity unit in km per time unit: the LD in km).
#
# Header values read (ldpipe.systems.velocity_data.curvilinear): 1, 2 the ny, nx of the box of the
# grid read (the whole grid, or a window's); 3, 5 the indices i, j of its first node; 12 where
# P's nodes start in the buffer, (ny + 2, nx + 2, 4) padded as the velocities are
# (P[0] P[1]; P[2] P[3]) row by row; 13 the arc length's factor.
# ruff: noqa: F821  (the engine's functions, constants and the kernel's pointer come from the generated module)

_index_dense = dense
_index_step_ld = step_ld


@njit(**JIT)
def curvilinear_metric(head, fi, fj, P):
    """P at the fractional indices (fi, fj), clamped to the grid (a stopped trajectory's
    velocity is 0 whatever P is)."""
    ny = int(head[1])
    nx = int(head[2])
    fx = min(max(fi - head[3], 0.0), nx - 1.0)  # from the box's first node (an integer: exact)
    fy = min(max(fj - head[5], 0.0), ny - 1.0)
    i = min(int(fx), nx - 2)
    j = min(int(fy), ny - 2)
    sx = fx - i
    sy = fy - j
    wx = np.empty(4)
    wy = np.empty(4)
    wx[0] = ((-0.5 * sx + 1.0) * sx - 0.5) * sx
    wx[1] = (1.5 * sx - 2.5) * sx * sx + 1.0
    wx[2] = ((-1.5 * sx + 2.0) * sx + 0.5) * sx
    wx[3] = (0.5 * sx - 0.5) * sx * sx
    wy[0] = ((-0.5 * sy + 1.0) * sy - 0.5) * sy
    wy[1] = (1.5 * sy - 2.5) * sy * sy + 1.0
    wy[2] = ((-1.5 * sy + 2.0) * sy + 0.5) * sy
    wy[3] = (0.5 * sy - 0.5) * sy * sy
    base = int(head[12])
    px = nx + 2
    for c in range(4):
        P[c] = 0.0
    for b in range(4):
        for a in range(4):
            w = wy[b] * wx[a]
            node = base + 4 * ((j + b) * px + i + a)
            for c in range(4):
                P[c] += w * head[node + c]


@njit(**JIT)
def dense(xv, t, h, K, xs, fs, QC, VC):
    _index_dense(xv, t, h, K, xs, fs, QC, VC)
    head = velocity_data_pointer()  # the raw pointer, as the kernels read it
    physical = np.empty((DENSE_STAGES, 2))
    P = np.empty(4)
    for m in range(DENSE_STAGES):
        stage_state(xv, h, K, m, xs)
        curvilinear_metric(head, xs[0], xs[1], P)
        physical[m, 0] = P[0] * K[m, 0] + P[1] * K[m, 1]
        physical[m, 1] = P[2] * K[m, 0] + P[3] * K[m, 1]
    for c in range(2):
        for k in range(1, NC):
            s = 0.0
            for m in range(DENSE_STAGES):
                s += G[k - 1, m] * physical[m, c]
            VC[k - 1, c, 0] = k * s


@njit(**JIT)
def step_ld(VC, theta, kind, p_exp, glx, glw, gjx, gjf, window, roots):
    value = _index_step_ld(VC, theta, kind, p_exp, glx, glw, gjx, gjf, window, roots)
    if kind == KIND_ARCLENGTH:
        head = velocity_data_pointer()  # the raw pointer, as the kernels read it
        return value * head[13]
    return value
