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
The step control is shared with the Hamiltonian drivers (``step_control.py``); this form
gives the starting step its own norms (``initial_step``).

Header and template names used: N (state dimension), NC, KIND_ARCLENGTH, the tableau arrays
A, C, E3, E5, G, the kernel ``rhs(state, t, out)``, the step control of ``step_control.py``
and the outcome codes of ``flow_status.py``.
"""
# ruff: noqa: F821  (the upper-case constants, njit, JIT, np and the kernel come from the generated module)

FSAL = 12  # the stage evaluated at the step's end
DENSE_STAGES = 16
# The LD driver's outcome beside ``flow_status.py``'s: stopped at the region box's first exit
# (or started outside it).
LEFT_REGION = 4


@njit(**JIT)
def initial_step(xv, f0, t, direction, tau, rtol, atol, x1, f1):
    """Hairer's starting step (``step_control.py``) from xv with f0 = f(xv, t): the norms of
    x and of x' = f scaled per component."""
    d0 = 0.0
    d1 = 0.0
    for i in range(N):
        sk = atol + rtol * abs(xv[i])
        d0 += (xv[i] / sk) ** 2
        d1 += (f0[i] / sk) ** 2
    d1 = math.sqrt(d1 / N)
    h0 = trial_step(math.sqrt(d0 / N), d1, tau)
    for i in range(N):
        x1[i] = xv[i] + direction * h0 * f0[i]
    rhs(x1, t + direction * h0, f1)
    d2 = 0.0
    for i in range(N):
        sk = atol + rtol * abs(xv[i])
        d2 += ((f1[i] - f0[i]) / sk) ** 2
    return starting_step(h0, d1, math.sqrt(d2 / N) / h0, tau)


@njit(**JIT)
def load_trajectory(states, k, t0, direction, tau, rtol, atol, lo, hi, has_region, elo, ehi, xv, K, xs, fs):
    """Put trajectory k's start state in xv; return (outcome (``start_outcome``'s), first |h|),
    with K[0] = f(xv, t0) for a trajectory that starts."""
    finite = np.bool_(True)  # (typed, not a literal: numba would compile the callees it reaches once more for the literal's type)
    for i in range(N):
        xv[i] = states[k, i]
        finite = finite and math.isfinite(xv[i])
    outcome = start_outcome(finite, xv, lo, hi, has_region, elo, ehi)
    if outcome != START:
        return outcome, 0.0
    rhs(xv, t0, K[0])
    return START, initial_step(xv, K[0], t0, direction, tau, rtol, atol, xs, fs)


@njit(**JIT)
def step_buffers(radius):
    """The scratch of a trajectory's steps: the stages K, the state xv, a stage's state xs, the
    step's end xn, f at a stage's state fs (before it is stored in K) or at the starting step's
    trial, the dense output QC, VC (one lane), and the escape box [elo, ehi] of ``radius``."""
    return (np.zeros((DENSE_STAGES, N)), np.zeros(N), np.zeros(N), np.zeros(N), np.zeros(N), np.zeros((NC, N, 1)),
            np.zeros((NC, N, 1)), np.full(N, -radius), np.full(N, radius))


# Inlined by numba where it is called (15 times a step): the stage sums then compile in their
# loops in attempt and dense, and a step costs ~25 % less than with calls.
@njit(inline="always", **JIT)
def stage_state(xv, h, K, m, out):
    """out = xv + h sum_{l < m} A[m, l] K_l."""
    for i in range(N):
        s = 0.0
        for l in range(m):
            s += A[m, l] * K[l, i]
        out[i] = xv[i] + h * s


# The stages' f are computed into fs and copied into their row of K: a row passed to rhs is a
# view, whose reference count numba takes and drops around the call (two atomic updates, ~10 % of
# a step of a cheap kernel).
@njit(**JIT)
def attempt(xv, t, h, K, xs, xn, fs, rtol, atol):
    """One DOP853 step of signed length h from (xv, t) with K[0] = f(xv, t): xn, K[1..12]
    (K[12] = f(xn, t + h)) and the scaled error (accept when <= 1)."""
    for m in range(1, FSAL):
        stage_state(xv, h, K, m, xs)
        rhs(xs, t + C[m] * h, fs)
        for i in range(N):
            K[m, i] = fs[i]
    stage_state(xv, h, K, FSAL, xn)
    rhs(xn, t + h, fs)
    for i in range(N):
        K[FSAL, i] = fs[i]
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
def dense(xv, t, h, K, xs, fs, QC, VC):
    """The step's state polynomial QC and velocity polynomial VC (see the module docstring),
    after the three extra stages of the continuous extension."""
    for m in range(FSAL + 1, DENSE_STAGES):
        stage_state(xv, h, K, m, xs)
        rhs(xs, t + C[m] * h, fs)
        for i in range(N):
            K[m, i] = fs[i]
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


@njit(**JIT)
def acceptable(xn, err):
    """Whether an attempt that ended at xn with scaled error err is accepted (a NaN error is not)."""
    finite = True
    for i in range(N):
        finite = finite and math.isfinite(xn[i])
    return finite and err <= 1.0


@njit(**JIT)
def commit(xv, xn, K):
    """Move to the accepted step's end xn, whose f is the next step's first stage."""
    for i in range(N):
        xv[i] = xn[i]
        K[0, i] = K[FSAL, i]


@njit(**JIT)
def beyond(xn, radius):
    """Whether max_i |x_i| > radius."""
    out = False
    for i in range(N):
        out = out or abs(xn[i]) > radius
    return out


@njit(**JIT)
def trajectory(states, k, t0, direction, tau, rtol, atol, lo, hi, has_region, radius, max_steps, buffers, ld_rule,
               section):
    """Trajectory k of ``states`` from t0 over |t - t0| <= tau, the step loop of the three drivers:
    (status, |t - t0| reached, step attempts, LD, exit face, crossings kept), the end state in
    ``buffers``' xv (``step_buffers(radius)``).

    What an accepted step does besides moving on is given by the arguments, each a tuple or None:
    ``ld_rule`` = (kind, p_exp, glx, glw, gjx, gjf, window, roots), ``step_ld``'s, adds the step's
    LD; ``section`` = (index, value, crossing sign in integration order, o_crossings,
    o_crossing_times) records the crossings of x[index] = value in row k of the outputs, up to
    their width, and stops at the last; the region box [lo, hi] (``has_region``) stops at its
    first exit (status LEFT_REGION, the face in ``face``). The dense output is formed on every
    accepted step for an LD or a section, else only on the step that passes the escape radius,
    to locate the escape. numba compiles a function once per argument type and prunes the
    branches of a None argument, so each driver's copy holds only its own work.
    """
    K, xv, xs, xn, fs, QC, VC, elo, ehi = buffers
    if ld_rule is not None:
        kind, p_exp, glx, glw, gjx, gjf, window, roots = ld_rule
    if section is not None:
        sec_index, sec_value, crossing_sign, o_crossings, o_crossing_times = section
        max_cross = o_crossing_times.shape[1]
    every_dense = ld_rule is not None or section is not None
    outcome, habs = load_trajectory(states, k, t0, direction, tau, rtol, atol, lo, hi, has_region, elo, ehi, xv, K, xs,
                                    fs)
    elapsed = 0.0
    ld = 0.0
    steps = 0
    crossings = 0
    face = 0
    rejected = False
    status = FLOW_RUNNING
    if outcome == START_FAILED:
        status = FLOW_STEP_UNDERFLOW
    elif outcome == START_ESCAPED:
        status = FLOW_ESCAPED
    elif outcome == START_OUTSIDE_REGION:
        status = LEFT_REGION
        face = outside_face(xv, lo, hi)
    while status == FLOW_RUNNING:  # a step attempt a pass
        # The attempt and dense output are called from this loop itself: a helper around them ran
        # 10-15 % slower, even inlined by numba (inline="always"), whose copies of its array
        # arguments cost a reference-count pair each per attempt.
        habs = clipped_step(habs, elapsed, tau)
        h = direction * habs
        t = t0 + direction * elapsed
        err = attempt(xv, t, h, K, xs, xn, fs, rtol, atol)
        steps += 1
        accepted = acceptable(xn, err)
        if accepted:
            escapes = beyond(xn, radius)
            if every_dense or escapes:
                dense(xv, t, h, K, xs, fs, QC, VC)
            theta = NO_EXIT  # where in the step (x units) the trajectory stops, if <= 1
            if has_region:
                theta, face = first_exit(QC, 0, NC, N, lo, hi)
                if theta <= 1.0:
                    status = LEFT_REGION
                else:
                    face = 0
            if escapes:
                theta_e = min(first_exit(QC, 0, NC, N, elo, ehi)[0], 1.0)
                if theta_e < theta:
                    theta = theta_e
                    status = FLOW_ESCAPED
                    face = 0
            if section is not None:
                if max_cross > 0:
                    gp = xv[sec_index] - sec_value
                    g = xn[sec_index] - sec_value
                    if (crossing_sign > 0 and gp < 0.0 and g >= 0.0) or (crossing_sign < 0 and gp > 0.0 and g <= 0.0):
                        xc = 1.0 if g == 0.0 else refine_root(QC, sec_index, 0, NC, sec_value, 0.0, 1.0, gp, g)
                        if xc <= theta:  # (xc <= 1: on the step)
                            for i in range(N):
                                o_crossings[k, crossings, i] = horner(QC, i, 0, NC, xc)
                            o_crossing_times[k, crossings] = direction * (elapsed + xc * habs)
                            crossings += 1
                            if crossings >= max_cross:
                                theta = xc
                                status = FLOW_CROSSINGS_FULL
            if status != FLOW_RUNNING:
                if ld_rule is not None:
                    ld += habs * step_ld(VC, theta, kind, p_exp, glx, glw, gjx, gjf, window, roots)
                elapsed += theta * habs
                for i in range(N):
                    xv[i] = horner(QC, i, 0, NC, theta)
                break
            if ld_rule is not None:
                ld += habs * step_ld(VC, 1.0, kind, p_exp, glx, glw, gjx, gjf, window, roots)
            commit(xv, xn, K)
            elapsed, last = advance(elapsed, habs, tau)
            if last:
                status = FLOW_COMPLETED
                break
        habs, failed = step_after(habs, err, accepted, rejected, tau)
        rejected = not accepted
        if failed or steps >= max_steps:
            status = FLOW_STEP_UNDERFLOW
    return status, elapsed, steps, ld, face, crossings


@njit(nogil=True, **JIT)
def vector_field_process(
    states, start, stop, t0, direction, tau, rtol, atol, kind, p_exp,
    lo, hi, has_region, radius, max_steps, glx, glw, gjx, gjf, window,
    o_ld, o_time, o_escaped, o_left, o_steps, o_failed, o_end, o_face,
):  # fmt: skip
    buffers = step_buffers(radius)
    xv = buffers[1]
    # component_integral's roots: at most 2 per sample interval and 1 per sample (its docstring)
    roots = np.zeros(6 * SAMPLES_PER_STEP + 16 + int(12 * window * SAMPLES_PER_STEP))
    ld_rule = (kind, p_exp, glx, glw, gjx, gjf, window, roots)
    for k in range(start, stop):
        status, elapsed, steps, ld, face, _ = trajectory(states, k, t0, direction, tau, rtol, atol, lo, hi, has_region,
                                                         radius, max_steps, buffers, ld_rule, None)
        o_ld[k] = ld
        o_time[k] = elapsed
        o_escaped[k] = status == FLOW_ESCAPED
        o_left[k] = status == LEFT_REGION
        o_failed[k] = status == FLOW_STEP_UNDERFLOW
        o_steps[k] = steps
        o_face[k] = face
        for i in range(N):
            o_end[k, i] = xv[i]


@njit(nogil=True, **JIT)
def vector_field_crossings(
    states, start, stop, t0, direction, tau, rtol, atol, radius, max_steps, sec_index, sec_value, sec_direction,
    o_crossings, o_crossing_times, o_crossing_count, o_status, o_time, o_steps,
):  # fmt: skip
    """Crossings of the surface x[sec_index] = sec_value, increasing (sec_direction +1) or
    decreasing (-1) in forward time, by trajectories start..stop-1 from t0 over |t - t0| <= tau.

    As ``ldpipe.core.trajectories``'s Hamiltonian driver: a crossing is a sign change of x_i - value between
    the ends of an accepted step, located on the step's dense output (``refine_root``); the
    trajectory stops at the last crossing kept, at the escape radius (located as the LD's), or
    on a step-size underflow. Times are signed, from t0: direction * |t - t0|. Outcomes
    (``o_status``): the codes of ``flow_status.py``.
    """
    buffers = step_buffers(radius)
    elo, ehi = buffers[7], buffers[8]
    # the sign change seen in integration order
    section = (sec_index, sec_value, sec_direction * direction, o_crossings, o_crossing_times)
    for k in range(start, stop):
        # no region: the escape box in its place
        status, elapsed, steps, _, _, crossings = trajectory(states, k, t0, direction, tau, rtol, atol, elo, ehi, False,
                                                             radius, max_steps, buffers, None, section)
        o_crossing_count[k] = crossings
        o_status[k] = status
        o_time[k] = direction * elapsed if steps > 0 else 0.0  # not started (no attempt): 0.0, not -0.0 backward
        o_steps[k] = steps
