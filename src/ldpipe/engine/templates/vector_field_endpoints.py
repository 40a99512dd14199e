"""Template: ``vector_field_endpoints``, the flow map of a general flow and nothing else.

A flow map (what the FTLE differentiates) needs only where each trajectory is after the time
tau. This driver takes ``vector_field_process``'s steps (the same ``load_trajectory``,
``attempt``, acceptance and step control, so the same end states bit for bit) without its LD:
no quadrature, and no dense output (12 evaluations of f per step instead of 15), except on the
step that passes the escape radius, where the escape is located on it as there.

It is assembled after the templates of ``ldpipe.engine.vector_field`` into a module of its
own, so the LD engine's text (and its compiled cache) is unchanged.
"""
# ruff: noqa: F821  (the upper-case constants, njit, JIT, np and the templates' functions come from the generated module)


@njit(nogil=True, **JIT)
def vector_field_endpoints(
    states, start, stop, t0, direction, tau, rtol, atol, radius, max_steps,
    o_end, o_status, o_time, o_steps,
):  # fmt: skip
    """End states of trajectories start..stop-1 from t0 over |t - t0| <= tau, with how each
    ended (``flow_status.py``'s codes), the time |t - t0| reached and the step attempts."""
    K, xv, xs, xn, f1, QC, VC = step_buffers()
    elo = np.full(N, -radius)
    ehi = np.full(N, radius)
    for k in range(start, stop):
        outcome, habs = load_trajectory(states, k, t0, direction, tau, rtol, atol, elo, ehi, False, elo, ehi, xv, K,
                                        xs, f1)
        elapsed = 0.0
        steps = 0
        rejected = False
        status = FLOW_RUNNING
        if outcome == START_FAILED:
            status = FLOW_STEP_UNDERFLOW
        elif outcome == START_ESCAPED:
            status = FLOW_ESCAPED
        while status == FLOW_RUNNING:  # a step attempt a pass
            habs = clipped_step(habs, elapsed, tau)
            h = direction * habs
            t = t0 + direction * elapsed
            err = attempt(xv, t, h, K, xs, xn, rtol, atol)
            steps += 1
            accepted = acceptable(xn, err)
            if accepted:
                if beyond(xn, radius):
                    dense(xv, t, h, K, xs, QC, VC)
                    theta = min(first_exit(QC, 0, NC, N, elo, ehi)[0], 1.0)
                    elapsed += theta * habs
                    for i in range(N):
                        xv[i] = horner(QC, i, 0, NC, theta)
                    status = FLOW_ESCAPED
                    break
                commit(xv, xn, K)
                elapsed, last = advance(elapsed, habs, tau)
                if last:
                    status = FLOW_COMPLETED
                    break
            habs, failed = step_after(habs, err, accepted, rejected, tau)
            rejected = not accepted
            if failed or steps >= max_steps:
                status = FLOW_STEP_UNDERFLOW
        o_status[k] = status
        o_time[k] = elapsed
        o_steps[k] = steps
        for i in range(N):
            o_end[k, i] = xv[i]
