"""Template: ``vector_field_process``, DOP853 and the LD of a general flow dx/dt = f(x, t).

The Hamiltonian driver (``driver.py``) integrates (q, p) in Nyström form across lanes; a
general flow has no such split, so this driver takes DOP853 in its first-order form (Hairer,
Nørsett & Wanner I, sec. II.5 and II.6: stages K_m = f(x + h sum_l A[m,l] K_l, t + C[m] h), the
5th/3rd-order error estimate and the 7th-order dense output, the tableau of
:mod:`ldpipe.tableaux`), one trajectory at a time. The dense output of a step is handed to the
same LD quadrature as the Hamiltonian driver's: ``VC[k, c, 0]``, the velocity of state
component c as a polynomial in x = (t - t_step)/h (the derivative of the continuous
extension), so every component's zero crossings are cut as there; ``QC[k, c, 0]``, the state
polynomial, for the region exit and the escape (``events.py``).

``t`` starts at ``t0`` and runs to ``t0 + direction tau``; the results' times are |t - t0|.

Header names used: N (state dimension), NC, ORDER, KIND_ARCLENGTH, the tableau arrays
A, C, E3, E5, G, and the kernel ``rhs(state, t, out)``.
"""
# ruff: noqa: F821  (the upper-case constants, njit, JIT, np and the kernel come from the generated module)

SAFETY = 0.9
MIN_FACTOR = 0.2
MAX_FACTOR = 10.0
FSAL = 12  # the stage evaluated at the step's end
DENSE_STAGES = 16


@njit(**JIT)
def inside(xv, lo, hi):
    for i in range(N):
        if not (lo[i] <= xv[i] <= hi[i]):
            return False
    return True


@njit(**JIT)
def initial_step(xv, f0, t, direction, tau, rtol, atol, x1, f1):
    """Hairer's starting step (Solving ODEs I, II.4) from xv with f0 = f(xv, t)."""
    d0 = 0.0
    d1 = 0.0
    for i in range(N):
        sk = atol + rtol * abs(xv[i])
        d0 += (xv[i] / sk) ** 2
        d1 += (f0[i] / sk) ** 2
    d0 = math.sqrt(d0 / N)
    d1 = math.sqrt(d1 / N)
    h0 = 1e-6 if (d0 < 1e-5 or d1 < 1e-5) else 0.01 * d0 / d1
    h0 = min(h0, tau)
    for i in range(N):
        x1[i] = xv[i] + direction * h0 * f0[i]
    rhs(x1, t + direction * h0, f1)
    d2 = 0.0
    for i in range(N):
        sk = atol + rtol * abs(xv[i])
        d2 += ((f1[i] - f0[i]) / sk) ** 2
    d2 = math.sqrt(d2 / N) / h0
    if d1 <= 1e-15 and d2 <= 1e-15:
        h1 = max(1e-6, h0 * 1e-3)
    else:
        h1 = (0.01 / max(d1, d2)) ** (1.0 / (ORDER + 1.0))
    return min(100.0 * h0, h1, tau)


@njit(**JIT)
def stage_state(xv, h, K, m, out):
    """out = xv + h sum_{l < m} A[m, l] K_l."""
    for i in range(N):
        s = 0.0
        for l in range(m):
            s += A[m, l] * K[l, i]
        out[i] = xv[i] + h * s


@njit(**JIT)
def attempt(xv, t, h, K, xs, xn, rtol, atol):
    """One DOP853 step of signed length h from (xv, t) with K[0] = f(xv, t): xn, K[1..12]
    (K[12] = f(xn, t + h)) and the scaled error (accept when <= 1)."""
    for m in range(1, FSAL):
        stage_state(xv, h, K, m, xs)
        rhs(xs, t + C[m] * h, K[m])
    stage_state(xv, h, K, FSAL, xn)
    rhs(xn, t + h, K[FSAL])
    err5 = 0.0
    err3 = 0.0
    for i in range(N):
        sk = atol + rtol * max(abs(xv[i]), abs(xn[i]))
        e5 = 0.0
        e3 = 0.0
        for l in range(FSAL + 1):
            e5 += E5[l] * K[l, i]
            e3 += E3[l] * K[l, i]
        err5 += (e5 / sk) ** 2
        err3 += (e3 / sk) ** 2
    denominator = max(err5 + 0.01 * err3, 1e-300)
    return abs(h) * err5 / math.sqrt(denominator * N)


@njit(**JIT)
def dense(xv, t, h, K, xs, QC, VC):
    """The step's state polynomial QC and velocity polynomial VC (see the module docstring),
    after the three extra stages of the continuous extension."""
    for m in range(FSAL + 1, DENSE_STAGES):
        stage_state(xv, h, K, m, xs)
        rhs(xs, t + C[m] * h, K[m])
    for i in range(N):
        QC[0, i, 0] = xv[i]
        for k in range(1, NC):
            s = 0.0
            for m in range(DENSE_STAGES):
                s += G[k - 1, m] * K[m, i]
            QC[k, i, 0] = h * s
            VC[k - 1, i, 0] = k * s
        VC[NC - 1, i, 0] = 0.0


@njit(**JIT)
def step_ld(VC, theta, kind, p_exp, glx, glw, gjx, gjf, window, roots):
    """int_0^theta of the LD integrand over the step, in units of the step (times |h| by the caller)."""
    if kind == KIND_ARCLENGTH:
        return arclength_integral(VC, N, 0, NC, theta, glx, glw)
    total = 0.0
    for c in range(N):
        total += component_integral(VC, c, 0, NC, theta, kind, p_exp, glx, glw, gjx, gjf, window, roots)
    return total


@njit(nogil=True, **JIT)
def vector_field_process(
    states, start, stop, t0, direction, tau, rtol, atol, kind, p_exp,
    lo, hi, has_region, radius, max_steps, glx, glw, gjx, gjf, window,
    o_ld, o_time, o_escaped, o_left, o_steps, o_failed, o_end, o_face,
):  # fmt: skip
    K = np.zeros((DENSE_STAGES, N))
    xv = np.zeros(N)
    xs = np.zeros(N)
    xn = np.zeros(N)
    f1 = np.zeros(N)
    QC = np.zeros((NC, N, 1))
    VC = np.zeros((NC, N, 1))
    # component_integral's roots: at most 2 per sample interval and 1 per sample (its docstring)
    roots = np.zeros(6 * SAMPLES_PER_STEP + 16 + int(12 * window * SAMPLES_PER_STEP))
    elo = np.full(N, -radius)
    ehi = np.full(N, radius)
    for k in range(start, stop):
        finite = True
        for i in range(N):
            xv[i] = states[k, i]
            o_end[k, i] = xv[i]
            finite = finite and math.isfinite(xv[i])
        o_ld[k] = 0.0
        o_time[k] = 0.0
        o_escaped[k] = False
        o_left[k] = False
        o_failed[k] = False
        o_steps[k] = 0
        o_face[k] = 0
        if not finite:
            o_failed[k] = True
            continue
        if has_region and not inside(xv, lo, hi):
            o_left[k] = True
            o_face[k] = outside_face(xv, lo, hi)
            continue
        if not inside(xv, elo, ehi):
            o_escaped[k] = True
            continue
        rhs(xv, t0, K[0])
        habs = initial_step(xv, K[0], t0, direction, tau, rtol, atol, xs, f1)
        elapsed = 0.0
        ld = 0.0
        steps = 0
        rejected = False
        failed = False
        escaped = False
        left = False
        face = 0
        while True:
            if habs > tau - elapsed:
                habs = tau - elapsed
            h = direction * habs
            t = t0 + direction * elapsed
            err = attempt(xv, t, h, K, xs, xn, rtol, atol)
            steps += 1
            finite = True
            for i in range(N):
                finite = finite and math.isfinite(xn[i])
            if finite and err <= 1.0:  # NaN error: not accepted
                dense(xv, t, h, K, xs, QC, VC)
                theta = NO_EXIT
                if has_region:
                    theta, face = first_exit(QC, 0, NC, N, lo, hi)
                    left = theta <= 1.0
                    if not left:
                        face = 0
                beyond = False
                for i in range(N):
                    beyond = beyond or abs(xn[i]) > radius
                if beyond:
                    theta_e = min(first_exit(QC, 0, NC, N, elo, ehi)[0], 1.0)
                    if theta_e < theta:
                        theta = theta_e
                        escaped = True
                        left = False
                        face = 0
                if left or escaped:
                    ld += habs * step_ld(VC, theta, kind, p_exp, glx, glw, gjx, gjf, window, roots)
                    elapsed += theta * habs
                    for i in range(N):
                        w = QC[NC - 1, i, 0]
                        for kk in range(NC - 2, -1, -1):
                            w = w * theta + QC[kk, i, 0]
                        xv[i] = w
                    break
                ld += habs * step_ld(VC, 1.0, kind, p_exp, glx, glw, gjx, gjf, window, roots)
                for i in range(N):
                    xv[i] = xn[i]
                    K[0, i] = K[FSAL, i]
                last = habs >= tau - elapsed
                elapsed = tau if last else elapsed + habs
                if last:
                    break
                e = err
                factor = min(MAX_FACTOR, SAFETY * e**(-1.0 / (ORDER + 1.0))) if e > 0.0 else MAX_FACTOR
                if rejected:
                    factor = min(1.0, factor)
                habs *= factor
                rejected = False
            else:
                e = err
                factor = max(MIN_FACTOR, SAFETY * e**(-1.0 / (ORDER + 1.0))) if (e < math.inf and e > 0.0) else MIN_FACTOR
                habs *= factor
                rejected = True
                if habs < 1e-13 * max(1.0, tau):
                    failed = True
                    break
            if steps >= max_steps:
                failed = True
                break
        o_ld[k] = ld
        o_time[k] = elapsed
        o_escaped[k] = escaped
        o_left[k] = left
        o_failed[k] = failed
        o_steps[k] = steps
        o_face[k] = face
        for i in range(N):
            o_end[k, i] = xv[i]


FLOW_COMPLETED = 0  # as ldpipe.flow's statuses
FLOW_ESCAPED = 1
FLOW_CROSSINGS_FULL = 2
FLOW_STEP_UNDERFLOW = 3


@njit(nogil=True, **JIT)
def vector_field_crossings(
    states, start, stop, t0, direction, tau, rtol, atol, radius, max_steps, sec_index, sec_value, sec_direction,
    o_crossings, o_crossing_times, o_crossing_count, o_status, o_time, o_steps,
):  # fmt: skip
    """Crossings of the surface x[sec_index] = sec_value, increasing (sec_direction +1) or
    decreasing (-1) in forward time, by trajectories start..stop-1 from t0 over |t - t0| <= tau.

    As ``ldpipe.flow``'s Hamiltonian driver: a crossing is a sign change of x_i - value between
    the ends of an accepted step, located on the step's dense output (``refine_root``); the
    trajectory stops at the last crossing kept, at the escape radius (located as the LD's), or
    on a step-size underflow. Times are signed, from t0: direction * |t - t0|.
    """
    K = np.zeros((DENSE_STAGES, N))
    xv = np.zeros(N)
    xs = np.zeros(N)
    xn = np.zeros(N)
    f1 = np.zeros(N)
    QC = np.zeros((NC, N, 1))
    VC = np.zeros((NC, N, 1))
    elo = np.full(N, -radius)
    ehi = np.full(N, radius)
    max_cross = o_crossing_times.shape[1]
    crossing_sign = sec_direction * direction  # the sign change seen in integration order
    for k in range(start, stop):
        finite = True
        for i in range(N):
            xv[i] = states[k, i]
            finite = finite and math.isfinite(xv[i])
        o_crossing_count[k] = 0
        o_time[k] = 0.0
        o_steps[k] = 0
        if not finite:
            o_status[k] = FLOW_STEP_UNDERFLOW
            continue
        if not inside(xv, elo, ehi):
            o_status[k] = FLOW_ESCAPED
            continue
        rhs(xv, t0, K[0])
        habs = initial_step(xv, K[0], t0, direction, tau, rtol, atol, xs, f1)
        elapsed = 0.0
        steps = 0
        crossings = 0
        rejected = False
        status = FLOW_COMPLETED
        while True:
            if habs > tau - elapsed:
                habs = tau - elapsed
            h = direction * habs
            t = t0 + direction * elapsed
            err = attempt(xv, t, h, K, xs, xn, rtol, atol)
            steps += 1
            finite = True
            for i in range(N):
                finite = finite and math.isfinite(xn[i])
            if finite and err <= 1.0:
                dense(xv, t, h, K, xs, QC, VC)
                x_stop = 1.0
                beyond = False
                for i in range(N):
                    beyond = beyond or abs(xn[i]) > radius
                if beyond:
                    x_stop = min(first_exit(QC, 0, NC, N, elo, ehi)[0], 1.0)
                    status = FLOW_ESCAPED
                if max_cross > 0:
                    gp = xv[sec_index] - sec_value
                    g = xn[sec_index] - sec_value
                    if (crossing_sign > 0 and gp < 0.0 and g >= 0.0) or (crossing_sign < 0 and gp > 0.0 and g <= 0.0):
                        xc = 1.0 if g == 0.0 else refine_root(QC, sec_index, 0, NC, sec_value, 0.0, 1.0, gp, g)
                        if xc <= x_stop:
                            for i in range(N):
                                w = QC[NC - 1, i, 0]
                                for kk in range(NC - 2, -1, -1):
                                    w = w * xc + QC[kk, i, 0]
                                o_crossings[k, crossings, i] = w
                            o_crossing_times[k, crossings] = direction * (elapsed + xc * habs)
                            crossings += 1
                            if crossings >= max_cross:
                                x_stop = xc
                                status = FLOW_CROSSINGS_FULL
                if x_stop < 1.0 or status != FLOW_COMPLETED:
                    elapsed += x_stop * habs
                    break
                for i in range(N):
                    xv[i] = xn[i]
                    K[0, i] = K[FSAL, i]
                last = habs >= tau - elapsed
                elapsed = tau if last else elapsed + habs
                if last:
                    break
                factor = min(MAX_FACTOR, SAFETY * err**(-1.0 / (ORDER + 1.0))) if err > 0.0 else MAX_FACTOR
                if rejected:
                    factor = min(1.0, factor)
                habs *= factor
                rejected = False
            else:
                factor = max(MIN_FACTOR, SAFETY * err**(-1.0 / (ORDER + 1.0))) if (err < math.inf and err > 0.0) else MIN_FACTOR
                habs *= factor
                rejected = True
                if habs < 1e-13 * max(1.0, tau):
                    status = FLOW_STEP_UNDERFLOW
                    break
            if steps >= max_steps:
                status = FLOW_STEP_UNDERFLOW
                break
        o_crossing_count[k] = crossings
        o_status[k] = status
        o_time[k] = direction * elapsed
        o_steps[k] = steps
