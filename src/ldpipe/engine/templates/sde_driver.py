"""Template: ``sde_process``, fixed-step integration of dx = f(x, t) dt + G(x, t) dW and the LD
of the drift along each noisy path.

A work item k is one member of one trajectory: the start state ``states[k]``, the trajectory's
index in its whole map ``index[k // MEMBERS_STRIDE]`` (``members`` items per trajectory), and its
member ``k % members``. Its Brownian increments come from Philox (``philox.py``): the key is
(seed, the start time's bits), the counter (draw block, trajectory index, member, direction), so
an item's path depends on those numbers alone, never on the batch, thread or tile it runs in.

The step (``h``, ``n_steps`` of them cover tau exactly), in the time s = |t - t0| with
t = t0 + direction s (backward: the drift reversed, the noise as forward, fresh increments):

- Euler-Maruyama (``scheme`` 0): x += direction f h + G dW, dW = sqrt(h) xi;
- Milstein (``scheme`` 1, diagonal G with g_i depending on x_i alone, checked where the noise is
  parsed): the same plus 1/2 g_i dg_i/dx_i (dW_i^2 - h), strong order one (Kloeden and Platen,
  sec. 10.3). For additive noise the correction is zero and the two schemes agree bit for bit.
- Heun (``scheme`` 2, diagonal G as Milstein's): the stochastic Heun scheme
  (predictor-corrector, trapezoidal in f and G) of the Stratonovich form of the same SDE, whose
  drift is f~_i = direction f_i - 1/2 g_i dg_i/dx_i (the Ito-Stratonovich correction; zero for
  additive noise): y = x + f~(x) h + G(x) dW, then x += (f~(x) + f~(y)) h / 2 +
  (G(x) + G(y)) dW / 2. Strong order one for commuting noise, weak order one (Kloeden and Platen,
  sec. 11.1 and 15.1; for additive noise weak order two).

After each step a closed box reflects the state: a coordinate beyond a wall is mirrored into
the box (folded, so any overshoot lands inside). With ``walls`` (planar velocity data with land),
the land cells are walls too: a step whose end lies in one is followed from the start cell to
cell (the grid lines ``xs``, ``ys`` it crosses, in order) and mirrored across the face of the
first land cell it would enter, then followed on from there, so no path enters land and none is
lost (mass kept; the law by a straight coast is the reflected Gaussian). A step still in land
after ``MAX_BOUNCES`` faces (a corner it cannot leave) is not taken: the path stays where it was.
A start in a land cell is not integrated. The LD is the trapezoidal sum of the drift's
integrand, sum |f_i|^p or ||f||, at the step's ends (the drift, not the path's velocity, which a
Brownian path does not have). A trajectory whose state leaves the escape radius, or is not finite,
stops there, flagged, with its LD and time up to the last state inside.

``constant``: G depends on neither the state nor the time, and is evaluated once per path. Only
the normal numbers a step uses are transformed (``LAST_PAIRS`` Box-Muller pairs of the last
Philox block); the others of the block are drawn and left, so a path's numbers are those of
``philox.py``'s stream whatever m is.

Header names used: N, M_NOISE, BLOCKS, LAST_PAIRS, MAX_BOUNCES, KIND_HALF, KIND_ONE, KIND_ARCLENGTH, the kernels rhs,
diffusion, diffusion_slope, and ``normals`` of ``philox.py``.
"""
# ruff: noqa: F821  (the upper-case constants, njit, JIT, np, math and the kernels come from the generated module)


@njit(**JIT)
def drift_integrand(f, kind, p):
    """The LD's integrand of the drift f: the arc length's ||f||, or sum |f_i|^p."""
    total = 0.0
    if kind == KIND_ARCLENGTH:
        for i in range(N):
            total += f[i] * f[i]
        return math.sqrt(total)
    for i in range(N):
        a = abs(f[i])
        if kind == KIND_HALF:
            total += math.sqrt(a)
        elif kind == KIND_ONE:
            total += a
        else:
            total += a ** p
    return total


@njit(**JIT)
def reflect_into(x, lo, hi, reflecting):
    """Mirror each reflected coordinate of ``x`` into [lo, hi] (folded for any overshoot)."""
    for i in range(N):
        if reflecting[i] and not (x[i] >= lo[i] and x[i] <= hi[i]):
            width = hi[i] - lo[i]
            y = (x[i] - lo[i]) % (2.0 * width)
            if y > width:
                y = 2.0 * width - y
            x[i] = lo[i] + y


@njit(**JIT)
def cell_of(value, nodes):
    """The cell of ``value`` among the grid lines ``nodes``: -1 below the first (or not a number),
    len(nodes) - 1 above the last."""
    if not value >= nodes[0]:
        return -1
    if value > nodes[-1]:
        return len(nodes) - 1
    return min(np.searchsorted(nodes, value, side="right") - 1, len(nodes) - 2)


@njit(**JIT)
def land_cell(i, j, cells):
    """Whether cell (i, j) is a land cell (one outside the grid is not: past the data's edge the
    noise carries a path on)."""
    return 0 <= i < cells.shape[1] and 0 <= j < cells.shape[0] and cells[j, i]


@njit(**JIT)
def wall_step(x, c, xs, ys, cells):
    """Reflect the step from ``x`` (at sea) to ``c`` off the land cells it would enter: ``c`` is
    changed in place; False if it is not resolved (``c`` set to ``x``: the step is not taken)."""
    sx = x[0]
    sy = x[1]
    i = cell_of(sx, xs)
    j = cell_of(sy, ys)
    for _ in range(MAX_BOUNCES):
        if not land_cell(cell_of(c[0], xs), cell_of(c[1], ys), cells):
            return True
        dx = c[0] - sx
        dy = c[1] - sy
        tx = 2.0
        ty = 2.0
        lx = 0.0
        ly = 0.0
        if dx > 0.0 and i + 1 < len(xs):
            lx = xs[i + 1]
            tx = max(0.0, (lx - sx) / dx)
        elif dx < 0.0 and i >= 0:
            lx = xs[i]
            tx = max(0.0, (lx - sx) / dx)
        if dy > 0.0 and j + 1 < len(ys):
            ly = ys[j + 1]
            ty = max(0.0, (ly - sy) / dy)
        elif dy < 0.0 and j >= 0:
            ly = ys[j]
            ty = max(0.0, (ly - sy) / dy)
        if tx > 1.0 and ty > 1.0:  # the end is in the start's own cell, a land cell: nothing to cross
            break
        if tx <= ty:  # the next line crossed is a line x = lx
            sy = sy + tx * dy
            sx = lx
            beyond = i + 1 if dx > 0.0 else i - 1
            if land_cell(beyond, j, cells):
                c[0] = 2.0 * lx - c[0]
            else:
                i = beyond
        else:
            sx = sx + ty * dx
            sy = ly
            beyond = j + 1 if dy > 0.0 else j - 1
            if land_cell(i, beyond, cells):
                c[1] = 2.0 * ly - c[1]
            else:
                j = beyond
    c[0] = x[0]
    c[1] = x[1]
    return False


@njit(**JIT)
def outside(x, lo, hi, reflecting, radius):
    """The state is not finite, beyond the escape radius, or outside the reflecting box."""
    for i in range(N):
        if not (abs(x[i]) <= radius):
            return True
        if reflecting[i] and not (x[i] >= lo[i] and x[i] <= hi[i]):
            return True
    return False


@njit(**JIT)
def heun_step(x, f, g, slope, y, fy, gy, slope_y, xi, t, direction, h, root_h, constant, k, o_end):
    """Heun's candidate state into ``o_end[k]`` (see the module docstring): ``f``, ``g``,
    ``slope`` are the drift, diffusion and slope at ``x`` and ``t``."""
    t_next = t + direction * h
    for i in range(N):
        step = h * (direction * f[i] - 0.5 * g[i, i] * slope[i])
        for j in range(M_NOISE):
            step += g[i, j] * root_h * xi[j]
        y[i] = x[i] + step
    rhs(y, t_next, fy)
    if constant:
        for i in range(N):
            for j in range(M_NOISE):
                gy[i, j] = g[i, j]
    else:
        diffusion(y, t_next, gy)
    diffusion_slope(y, t_next, slope_y)
    for i in range(N):
        drift = 0.5 * ((direction * f[i] - 0.5 * g[i, i] * slope[i]) + (direction * fy[i] - 0.5 * gy[i, i] * slope_y[i]))
        step = h * drift
        for j in range(M_NOISE):
            step += 0.5 * (g[i, j] + gy[i, j]) * root_h * xi[j]
        o_end[k, i] = x[i] + step


@njit(nogil=True, **JIT)
def sde_process(
    states, start, stop, index, members, key0, key1, direction_word, t0, direction, h, n_steps, scheme,
    kind, p, lo, hi, reflecting, radius, constant, walls, xs, ys, cells,
    o_ld, o_time, o_escaped, o_started, o_end,
):  # fmt: skip
    x = np.zeros(N)
    f = np.zeros(N)
    g = np.zeros((N, M_NOISE))
    slope = np.zeros(N)
    y = np.zeros(N)  # Heun's predictor, and its drift, diffusion and slope
    fy = np.zeros(N)
    gy = np.zeros((N, M_NOISE))
    slope_y = np.zeros(N)
    xi = np.zeros(4 * BLOCKS)
    root_h = math.sqrt(h)
    for k in range(start, stop):
        trajectory = np.uint64(index[k // members])
        member = np.uint64(k % members)
        for i in range(N):
            x[i] = states[k, i]
        o_ld[k] = 0.0
        o_time[k] = 0.0
        o_escaped[k] = False
        o_started[k] = not outside(x, lo, hi, reflecting, radius) and not (
            walls and land_cell(cell_of(x[0], xs), cell_of(x[1], ys), cells))
        if o_started[k]:
            if constant:  # G depends on neither the state nor the time: once per path
                diffusion(x, t0, g)
            rhs(x, t0, f)
            value = drift_integrand(f, kind, p)
            ld = 0.0
            for s in range(n_steps):
                t = t0 + direction * s * h
                for b in range(BLOCKS):
                    normals(key0, key1, np.uint64(s * BLOCKS + b), trajectory, member, direction_word,
                            xi[4 * b:4 * b + 4], 2 if b < BLOCKS - 1 else LAST_PAIRS)
                if not constant:
                    diffusion(x, t, g)
                if scheme >= 1:
                    diffusion_slope(x, t, slope)
                if scheme == 2:
                    heun_step(x, f, g, slope, y, fy, gy, slope_y, xi, t, direction, h, root_h, constant, k, o_end)
                else:
                    for i in range(N):
                        step = direction * h * f[i]
                        for j in range(M_NOISE):
                            step += g[i, j] * root_h * xi[j]
                        if scheme == 1:
                            dw = root_h * xi[i]
                            step += 0.5 * g[i, i] * slope[i] * (dw * dw - h)
                        o_end[k, i] = x[i] + step  # the candidate state, kept only if it stays inside
                for i in range(N):
                    f[i] = o_end[k, i]
                reflect_into(f, lo, hi, reflecting)
                if walls:
                    wall_step(x, f, xs, ys, cells)
                if outside(f, lo, hi, reflecting, radius):
                    o_escaped[k] = True
                    break
                for i in range(N):
                    x[i] = f[i]
                rhs(x, t0 + direction * (s + 1) * h, f)
                after = drift_integrand(f, kind, p)
                ld += 0.5 * h * (value + after)
                value = after
                o_time[k] = (s + 1) * h
            o_ld[k] = ld
        for i in range(N):
            o_end[k, i] = x[i]
