"""Template: ``flow_process``, the block driver of :func:`ldpipe.core.trajectories.integrate`.

``flow_process(states, start, stop, ...)`` integrates trajectories start..stop-1 with one
block of LANES lanes, on the same step attempt as the LD driver (``attempt``: DOP853 in
Nyström form, per-lane step size), the same step control (``step_control.py``) and the same
loading of a lane (``driver.py``'s ``load_lane``). It releases the GIL, so units run in
parallel threads. As in the LD driver, a lane whose trajectory ends takes the next one of the
range.

Along each trajectory, on every accepted step, from the step's dense output (q(x) from the
configuration polynomials QC, p(x) = q'(x) from the velocity polynomials VC of the q
components, x = (t - t0)/h in [0, 1]):

* samples at the requested times that fall in the step (steps are not shortened for them);
* a crossing of the section, the phase coordinate ``sec_index`` (q_i, or p_i for an index
  n + i) passing ``sec_value``, where the coordinate's values at the two ends of the step
  change sign in the requested direction; the crossing is the root of the coordinate's
  polynomial in (0, 1], located by ``refine_root`` (safeguarded Newton) to machine
  precision; the trajectory stops at the ``max_crossings``-th crossing;
* an escape, max_i |q_i| > radius at the step end, located on QC by ``first_exit`` (as in the
  LD driver); the trajectory stops there. Events after the stopping point are not recorded.

A step attempt that fails (non-finite state or error) is rejected; a step size underflow
(``step_control.py``), or ``max_steps`` attempts, end the trajectory as failed.

Outcomes (``o_status``): the codes of ``flow_status.py``; ``o_time`` is |t| where the
trajectory stopped. Samples after the stopping time are the state there. Header and template
names used: N, LANES, NC, NCOMP, SIZE, NB, the workspace offsets, ``attempt``, ``qpoly``,
``horner``, ``refine_root``, ``first_exit``, ``flag_escapes``, from ``driver.py`` ``load_lane``,
``lane_buffers``, ``workspace_views`` and ``set_lane_steps``, the step control of
``step_control.py`` and the codes of ``flow_status.py``.
"""
# ruff: noqa: F821  (the upper-case constants, njit, JIT, np and the other templates come from the generated module)


@njit(**JIT)
def state_at(QC, VC, qn, pn, j, x, out):
    """out = (q, p) of lane j at x of its step: the dense output, or the step end itself at x >= 1."""
    if x >= 1.0:
        for i in range(N):
            out[i] = qn[i, j]
            out[N + i] = pn[i, j]
    else:
        for i in range(N):
            out[i] = horner(QC, i, j, NC, x)
            out[N + i] = horner(VC, i, j, NC, x)


@njit(**JIT)
def finish(k, status, time, y, steps, n_samples_done, n_cross, o_samples, o_sample_count, o_crossing_count,
           o_status, o_time, o_steps):
    """Write trajectory k's outcome; samples not reached repeat the final state y."""
    for s in range(n_samples_done, o_samples.shape[1]):
        for i in range(NCOMP):
            o_samples[k, s, i] = y[i]
    o_sample_count[k] = n_samples_done
    o_crossing_count[k] = n_cross
    o_status[k] = status
    o_time[k] = time
    o_steps[k] = steps


@njit(nogil=True, **JIT)
def flow_process(
    states, start, stop, direction, tau, rtol, atol, radius, max_steps, sample_times,
    sec_index, sec_value, sec_direction,
    o_samples, o_sample_count, o_crossings, o_crossing_times, o_crossing_count, o_status, o_time, o_steps,
):  # fmt: skip
    """``sample_times``: |t| of the samples, non-decreasing; ``sec_direction``: +1 or -1 in forward time."""
    W = np.zeros(SIZE)  # the block workspace (see ldpipe.engine.stepping.Layout)
    q, p, acc, qn, pn, accn, hh, err, VC, QC = workspace_views(W)
    n_samples = sample_times.shape[0]
    max_cross = o_crossing_times.shape[1]
    on_p = sec_index >= N  # the section is p_row = value, else q_row = value
    row = sec_index - N if on_p else sec_index
    crossing_sign = sec_direction * direction  # the sign change seen in integration order
    habs = np.zeros(LANES)
    t = np.zeros(LANES)
    g_prev = np.zeros(LANES)
    g_new = np.zeros(LANES)
    nsteps = np.zeros(LANES, dtype=np.int64)
    next_sample = np.zeros(LANES, dtype=np.int64)
    n_cross = np.zeros(LANES, dtype=np.int64)
    idx = np.full(LANES, -1, dtype=np.int64)
    active = np.zeros(LANES, dtype=np.bool_)
    was_rejected = np.zeros(LANES, dtype=np.bool_)
    hit = np.zeros(LANES, dtype=np.bool_)
    esc_flag = np.zeros(LANES, dtype=np.bool_)
    qv, pv, av, q1, g1 = lane_buffers()
    y = np.zeros(NCOMP)
    elo = np.full(N, -radius)
    ehi = np.full(N, radius)
    cursor = start

    while True:
        for j in range(LANES):
            # an idle lane (at the start, or whose trajectory ended) takes the next one
            while cursor < stop and not active[j]:
                k = cursor
                cursor += 1
                # no region: the escape box in its place
                outcome, _, first = load_lane(
                    j, k, states, q, p, acc, qv, pv, av, q1, g1, direction, tau, 0.0, rtol, atol, elo, ehi, False, elo, ehi
                )
                for i in range(N):
                    y[i] = qv[i]
                    y[N + i] = pv[i]
                s = 0
                while s < n_samples and sample_times[s] == 0.0:
                    for i in range(NCOMP):
                        o_samples[k, s, i] = y[i]
                    s += 1
                status = FLOW_RUNNING
                if outcome == START_FAILED:
                    status = FLOW_STEP_UNDERFLOW
                elif outcome == START_ESCAPED:
                    status = FLOW_ESCAPED
                elif tau == 0.0:
                    status = FLOW_COMPLETED
                if status != FLOW_RUNNING:
                    finish(k, status, 0.0, y, 0, s, 0, o_samples, o_sample_count, o_crossing_count, o_status, o_time,
                           o_steps)
                else:
                    idx[j] = k
                    active[j] = True
                    habs[j] = first
                    t[j] = 0.0
                    nsteps[j] = 0
                    next_sample[j] = s
                    n_cross[j] = 0
                    was_rejected[j] = False
                    g_prev[j] = y[sec_index] - sec_value
        # dop853 is adaptive: no fixed step (dt, n_fixed)
        if set_lane_steps(active, habs, t, nsteps, hh, direction, tau, 0.0, 1) == 0:
            break

        attempt(W, rtol, atol)
        # The dense output of q is formed (for the whole block) only when an accepted step of
        # some lane holds an event: a sample, a crossing or an escape.
        need_poly = flag_escapes(qn, radius, esc_flag)
        for j in range(LANES):
            hit[j] = False
            if not active[j] or not err[j] <= 1.0:
                continue
            g = (pn[row, j] if on_p else qn[row, j]) - sec_value
            g_new[j] = g
            if max_cross > 0:
                gp = g_prev[j]
                hit[j] = (crossing_sign > 0 and gp < 0.0 and g >= 0.0) or (crossing_sign < 0 and gp > 0.0 and g <= 0.0)
            sample_due = next_sample[j] < n_samples and sample_times[next_sample[j]] <= t[j] + habs[j]
            need_poly = need_poly or hit[j] or sample_due
        if need_poly:
            qpoly(W)

        for j in range(LANES):
            if not active[j]:
                continue
            nsteps[j] += 1
            k = idx[j]
            e = err[j]
            finite = True
            for i in range(N):
                finite = finite and math.isfinite(qn[i, j]) and math.isfinite(pn[i, j])
            status = FLOW_RUNNING
            if finite and e <= 1.0:  # NaN error: not accepted
                t_end, last = advance(t[j], habs[j], tau)
                x_stop = 1.0
                if esc_flag[j]:
                    x_stop = min(first_exit(QC, j, NC, N, elo, ehi)[0], 1.0)
                    status = FLOW_ESCAPED
                if hit[j]:
                    gp = g_prev[j]
                    g = g_new[j]
                    if g == 0.0:
                        xc = 1.0
                    elif on_p:
                        xc = refine_root(VC, row, j, NC, sec_value, 0.0, 1.0, gp, g)
                    else:
                        xc = refine_root(QC, row, j, NC, sec_value, 0.0, 1.0, gp, g)
                    if xc <= x_stop:
                        c = n_cross[j]
                        state_at(QC, VC, qn, pn, j, xc, o_crossings[k, c])
                        o_crossing_times[k, c] = direction * (t_end if xc >= 1.0 else t[j] + xc * habs[j])
                        n_cross[j] = c + 1
                        if c + 1 >= max_cross:
                            x_stop = xc
                            status = FLOW_CROSSINGS_FULL
                t_stop = t_end if x_stop >= 1.0 else t[j] + x_stop * habs[j]
                s = next_sample[j]
                while s < n_samples and sample_times[s] <= t_stop:
                    x = min(max((sample_times[s] - t[j]) / habs[j], 0.0), 1.0)
                    if sample_times[s] == t_end:
                        x = 1.0
                    state_at(QC, VC, qn, pn, j, x, o_samples[k, s])
                    s += 1
                next_sample[j] = s
                if status == FLOW_RUNNING:
                    for i in range(N):
                        q[i, j] = qn[i, j]
                        p[i, j] = pn[i, j]
                        acc[i, j] = accn[i, j]
                    t[j] = t_end
                    g_prev[j] = g_new[j]
                    habs[j] = accepted_step(habs[j], error_factors(e)[0], was_rejected[j])
                    was_rejected[j] = False
                    if last:
                        status = FLOW_COMPLETED
                        x_stop = 1.0
                        t_stop = tau
                if status != FLOW_RUNNING:
                    state_at(QC, VC, qn, pn, j, x_stop, y)
                    finish(k, status, t_stop, y, nsteps[j], next_sample[j], n_cross[j], o_samples, o_sample_count,
                           o_crossing_count, o_status, o_time, o_steps)
                    active[j] = False
                    continue
            else:
                habs[j] *= error_factors(e)[1]
                was_rejected[j] = True
                if underflow(habs[j], tau):
                    status = FLOW_STEP_UNDERFLOW
            if status == FLOW_RUNNING and nsteps[j] >= max_steps:
                status = FLOW_STEP_UNDERFLOW
            if status == FLOW_STEP_UNDERFLOW:
                for i in range(N):
                    y[i] = q[i, j]
                    y[N + i] = p[i, j]
                finish(k, status, t[j], y, nsteps[j], next_sample[j], n_cross[j], o_samples, o_sample_count,
                       o_crossing_count, o_status, o_time, o_steps)
                active[j] = False
