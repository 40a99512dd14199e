"""Template: ``process``, the block driver that integrates a range of trajectories.

``process(states, start, stop, ...)`` integrates trajectories start..stop-1 with one block
of LANES lanes and writes their results; it releases the GIL, so units run in parallel
threads (see ldpipe.engine.integrator). Every lane carries one trajectory; when it finishes
(time reached, region left, escaped, failed) its results are written out and the next
trajectory of the range is loaded into it, so lanes never idle while work remains.

One iteration advances every active lane by one step attempt with its own h:
``attempt`` (vectorized across lanes) -> ``fast`` LD quadrature (vectorized) -> box/escape
flags (vectorized) -> a short scalar pass per lane for acceptance, the special quadrature
path, event location, commit, step-size control and refill.

Each trajectory's end is written with its results: ``o_end[k]`` the state where it stopped
(the same state its energy error is taken at) and ``o_face[k]`` the region face it left by
(``first_exit``'s; for a start outside the region ``outside_face``'s; else 0).

Header and template names used: N, LANES, NC, NCOMP, SIZE, NB, ADAPTIVE, SELF_SIZED,
KIND_ARCLENGTH, the workspace offsets, the kernels ``potential`` and ``gradient``, and the step
control of ``step_control.py``.
"""
# ruff: noqa: F821  (the upper-case constants, njit, JIT, np and the kernels come from the generated module)


@njit(**JIT)
def step_factors(err, kind, FC, fac_accept, fac_reject, inc):
    """Per lane: the step-size factors after an accepted and after a rejected attempt, from
    the scaled error err (``error_factors``), and the LD integrand of the step summed over
    components (from the quadrature's FC), in loops over lanes outside the scalar pass."""
    for j in range(LANES):
        fac_accept[j], fac_reject[j] = error_factors(err[j])
    if kind == KIND_ARCLENGTH:
        for j in range(LANES):
            inc[j] = FC[0, j]
    else:
        for j in range(LANES):
            inc[j] = 0.0
        for c in range(NCOMP):
            for j in range(LANES):
                inc[j] += FC[c, j]


@njit(**JIT)
def energy(qv, pv):
    kinetic = 0.0
    for i in range(N):
        kinetic += pv[i] * pv[i]
    return 0.5 * kinetic + potential(qv)


@njit(**JIT)
def initial_step(qv, pv, av, direction, tau, rtol, atol, q1, g1):
    """Hairer's starting step (``step_control.py``) for the state (qv, pv), whose derivative
    is (pv, av): the norms of (q, p) and of (q', p') = (p, a(q)) scaled per component."""
    d0 = 0.0
    d1 = 0.0
    for i in range(N):
        sq = atol + rtol * abs(qv[i])
        sp = atol + rtol * abs(pv[i])
        d0 += (qv[i] / sq) ** 2 + (pv[i] / sp) ** 2
        d1 += (pv[i] / sq) ** 2 + (av[i] / sp) ** 2
    d1 = math.sqrt(d1 / NCOMP)
    h0 = trial_step(math.sqrt(d0 / NCOMP), d1, tau)
    for i in range(N):
        q1[i] = qv[i] + direction * h0 * pv[i]
    gradient(q1, g1)
    d2 = 0.0
    for i in range(N):
        sq = atol + rtol * abs(qv[i])
        sp = atol + rtol * abs(pv[i])
        dq = h0 * av[i]  # change of q' = p over the trial step
        dp = -g1[i] - av[i]
        d2 += (dq / sq) ** 2 + (dp / sp) ** 2
    return starting_step(h0, d1, math.sqrt(d2 / NCOMP) / h0, tau)


@njit(**JIT)
def workspace_views(W):
    """The arrays of the block workspace W the drivers read and write: the lanes' state (q, p)
    and acceleration at the step's start and end, the signed steps hh, the scaled errors, and
    the step's velocity and configuration polynomials VC and QC."""
    q = W[OQ : OQ + NB].reshape((N, LANES))
    p = W[OP : OP + NB].reshape((N, LANES))
    acc = W[OA : OA + NB].reshape((N, LANES))
    qn = W[OQN : OQN + NB].reshape((N, LANES))
    pn = W[OPN : OPN + NB].reshape((N, LANES))
    accn = W[OAN : OAN + NB].reshape((N, LANES))
    hh = W[OH : OH + LANES]
    err = W[OERR : OERR + LANES]
    VC = W[OVC : OVC + NC * NCOMP * LANES].reshape((NC, NCOMP, LANES))
    QC = W[OQC : OQC + NC * NB].reshape((NC, N, LANES))
    return q, p, acc, qn, pn, accn, hh, err, VC, QC


@njit(**JIT)
def set_lane_steps(active, habs, t, nsteps, hh, direction, tau, dt, n_fixed):
    """The signed step hh of every lane for the next attempt (0 for an idle lane): |h| cut to
    what remains of tau (adaptive), or dt and the rest of tau last (n_fixed steps of a fixed
    step). Returns how many lanes are active."""
    n_active = 0
    for j in range(LANES):
        if active[j]:
            n_active += 1
            if ADAPTIVE:
                habs[j] = clipped_step(habs[j], t[j], tau)
            else:
                habs[j] = dt if nsteps[j] < n_fixed - 1 else tau - (n_fixed - 1) * dt
            hh[j] = direction * habs[j]
        else:
            hh[j] = 0.0
    return n_active


@njit(**JIT)
def lane_buffers():
    """``load_lane``'s scratch: a state (qv, pv), its acceleration av, and the starting step's
    trial configuration q1 and gradient g1."""
    return np.zeros(N), np.zeros(N), np.zeros(N), np.zeros(N), np.zeros(N)


@njit(**JIT)
def load_lane(j, k, states, q, p, acc, qv, pv, av, q1, g1, direction, tau, dt, rtol, atol, lo, hi, has_region, elo, ehi):
    """Put trajectory k into lane j, its start state left in (qv, pv); return (outcome
    (``start_outcome``'s), H0, first |h|), H0 and |h| 0 for a trajectory that does not start."""
    finite = np.bool_(True)  # (typed, not a literal: numba would compile the callees it reaches once more for the literal's type)
    for i in range(N):
        qv[i] = states[k, i]
        pv[i] = states[k, N + i]
        finite = finite and math.isfinite(qv[i]) and math.isfinite(pv[i])
    outcome = start_outcome(finite, qv, lo, hi, has_region, elo, ehi)
    if outcome != START:
        return outcome, 0.0, 0.0
    gradient(qv, g1)
    for i in range(N):
        av[i] = -g1[i]
        q[i, j] = qv[i]
        p[i, j] = pv[i]
        acc[i, j] = av[i]
    if ADAPTIVE:
        first = initial_step(qv, pv, av, direction, tau, rtol, atol, q1, g1)
    else:
        first = min(dt, tau)
    return START, energy(qv, pv), first


@njit(nogil=True, **JIT)
def process(
    states, start, stop, direction, tau, dt, n_fixed, rtol, atol, kind, p_exp,
    lo, hi, has_region, radius, max_steps, glx, glw, gjx, gjf, window, coefficients,
    o_ld, o_time, o_escaped, o_left, o_eerr, o_steps, o_failed, o_end, o_face,
):  # fmt: skip
    lanes = LANES
    # the block workspace (see ldpipe.engine.stepping.Layout), the scheme's run-time coefficients at its end
    W = np.zeros(SIZE + coefficients.shape[0])
    W[SIZE:] = coefficients
    q, p, acc, qn, pn, accn, hh, err, VC, QC = workspace_views(W)
    FC = W[OFC : OFC + NCOMP * LANES].reshape((NCOMP, LANES))
    SP = np.zeros((NCOMP, LANES), dtype=np.int8)  # SP_* codes of block_quadrature.py
    fac_accept = np.zeros(LANES)
    fac_reject = np.zeros(LANES)
    inc_step = np.zeros(LANES)
    CB = np.zeros(CB_ROWS * NCOMP * LANES)  # the special path's item buffer (block_quadrature.py)
    ITEM = np.zeros(NCOMP * LANES, dtype=np.int64)
    habs = np.zeros(lanes)
    t = np.zeros(lanes)
    ld = np.zeros(lanes)
    H0 = np.zeros(lanes)
    nsteps = np.zeros(lanes, dtype=np.int64)
    idx = np.full(lanes, -1, dtype=np.int64)
    active = np.zeros(lanes, dtype=np.bool_)
    was_rejected = np.zeros(lanes, dtype=np.bool_)
    esc_flag = np.zeros(lanes, dtype=np.bool_)
    reg_flag = np.zeros(lanes, dtype=np.bool_)
    # component_integral's roots: at most 2 per sample interval and 1 per sample (its docstring)
    roots = np.zeros(6 * SAMPLES_PER_STEP + 16 + int(12 * window * SAMPLES_PER_STEP))
    qv, pv, av, q1, g1 = lane_buffers()
    elo = np.full(N, -radius)
    ehi = np.full(N, radius)
    cursor = start

    while True:
        for j in range(lanes):
            # an idle lane (at the start, or whose trajectory ended) takes the next one
            while cursor < stop and not active[j]:
                k = cursor
                cursor += 1
                outcome, h_start, first = load_lane(
                    j, k, states, q, p, acc, qv, pv, av, q1, g1, direction, tau, dt, rtol, atol, lo, hi, has_region, elo, ehi
                )
                if outcome == START:
                    idx[j] = k
                    active[j] = True
                    H0[j] = h_start
                    habs[j] = first
                    t[j] = 0.0
                    ld[j] = 0.0
                    nsteps[j] = 0
                    was_rejected[j] = False
                else:
                    o_ld[k] = 0.0
                    o_time[k] = 0.0
                    o_left[k] = outcome == START_OUTSIDE_REGION
                    o_escaped[k] = outcome == START_ESCAPED
                    o_failed[k] = outcome == START_FAILED
                    o_eerr[k] = 0.0
                    o_steps[k] = 0
                    for i in range(N):  # load_lane left the start state in (qv, pv)
                        o_end[k, i] = qv[i]
                        o_end[k, N + i] = pv[i]
                    o_face[k] = outside_face(qv, lo, hi) if outcome == START_OUTSIDE_REGION else 0
        n_active = set_lane_steps(active, habs, t, nsteps, hh, direction, tau, dt, n_fixed)
        if n_active == 0:
            break

        attempt(W, rtol, atol)
        if SELF_SIZED:  # the scheme chose the step: what the lanes integrate is hh
            for j in range(lanes):
                habs[j] = abs(hh[j])
        fast(W, kind, p_exp, glx, glw, window, SP)
        if kind != KIND_ARCLENGTH:
            special(W, SP, kind, p_exp, glx, glw, gjx, gjf, window, CB, ITEM, roots)
        any_escape = flag_escapes(qn, radius, esc_flag)
        if has_region:
            qpoly(W)
            flag_box_exits(QC, NC, qn, lo, hi, reg_flag)
        elif any_escape and ADAPTIVE:
            qpoly(W)
        step_factors(err, kind, FC, fac_accept, fac_reject, inc_step)

        for j in range(lanes):
            if not active[j]:
                continue
            nsteps[j] += 1
            e = err[j]
            finite = True
            for i in range(N):
                finite = finite and math.isfinite(qn[i, j]) and math.isfinite(pn[i, j])
            accepted = finite and (e <= 1.0)  # NaN error: not accepted
            done = False
            failed = False
            escaped = False
            left = False
            face = 0
            if not ADAPTIVE and (esc_flag[j] or not finite):
                # A fixed step that leaves the escape radius (or overflows) is not trusted: its
                # end and interpolant can be off by orders of magnitude (|q| 1e30 from |q| 50 at
                # dt 0.4), and an LD or energy taken on it can overflow. The trajectory stops at
                # the step's start, the last state inside the radius, flagged escaped.
                escaped = True
                done = True
                for i in range(N):
                    qv[i] = q[i, j]
                    pv[i] = p[i, j]
            elif accepted:
                theta = NO_EXIT
                if has_region and reg_flag[j]:
                    theta, face = first_exit(QC, j, NC, N, lo, hi)
                    theta = min(theta, 1.0)
                    left = True
                if esc_flag[j]:
                    theta_e = min(first_exit(QC, j, NC, N, elo, ehi)[0], 1.0)
                    if theta_e < theta:
                        theta = theta_e
                        left = False
                        escaped = True
                        face = 0
                if left or escaped:
                    if kind == KIND_ARCLENGTH:
                        inc = arclength_integral(VC, NCOMP, j, NC, theta, glx, glw)
                    else:
                        inc = 0.0
                        for c in range(NCOMP):
                            inc += component_integral(VC, c, j, NC, theta, kind, p_exp, glx, glw, gjx, gjf, window, roots)
                    ld[j] += habs[j] * inc
                    t[j] += theta * habs[j]
                    for i in range(N):
                        qv[i] = horner(QC, i, j, NC, theta)
                        pv[i] = horner(VC, i, j, NC, theta)
                    if left and face == 0:
                        # flagged, but the polynomial inside at the samples by rounding (theta = 1):
                        # the face nearest the end state
                        nearest = math.inf
                        for i in range(N):
                            if qv[i] - lo[i] < nearest:
                                nearest = qv[i] - lo[i]
                                face = -(i + 1)
                            if hi[i] - qv[i] < nearest:
                                nearest = hi[i] - qv[i]
                                face = i + 1
                    done = True
                else:
                    ld[j] += habs[j] * inc_step[j]
                    for i in range(N):
                        q[i, j] = qn[i, j]
                        p[i, j] = pn[i, j]
                        acc[i, j] = accn[i, j]
                        qv[i] = qn[i, j]
                        pv[i] = pn[i, j]
                    if ADAPTIVE:
                        t[j], last = advance(t[j], habs[j], tau)
                        habs[j] = accepted_step(habs[j], fac_accept[j], was_rejected[j])
                        was_rejected[j] = False
                    else:
                        last = nsteps[j] >= n_fixed
                        t[j] = tau if last else nsteps[j] * dt
                    done = last
            else:
                if ADAPTIVE:
                    habs[j] *= fac_reject[j]
                    was_rejected[j] = True
                    failed = underflow(habs[j], tau)
            if not done and not failed and nsteps[j] >= max_steps:
                failed = True
            if failed:
                for i in range(N):
                    qv[i] = q[i, j]
                    pv[i] = p[i, j]
            if done or failed:
                k = idx[j]
                o_ld[k] = ld[j]
                o_time[k] = t[j]
                o_escaped[k] = escaped
                o_left[k] = left
                o_failed[k] = failed
                o_eerr[k] = abs(energy(qv, pv) - H0[j])
                o_steps[k] = nsteps[j]
                for i in range(N):
                    o_end[k, i] = qv[i]
                    o_end[k, N + i] = pv[i]
                o_face[k] = face
                active[j] = False
