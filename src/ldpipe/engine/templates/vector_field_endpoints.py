"""Template: ``vector_field_endpoints``, the flow map of a general flow and nothing else.

A flow map (what the FTLE differentiates) needs only where each trajectory is after the time
tau. This driver runs ``vector_field_process``'s step loop (``trajectory``: the same start,
attempts, acceptance and step control, so the same end states bit for bit) without its LD: no
quadrature, and no dense output (12 evaluations of f per step instead of 15), except on the
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
    buffers = step_buffers(radius)
    xv, elo, ehi = buffers[1], buffers[7], buffers[8]
    for k in range(start, stop):
        # no region (the escape box in its place), no LD, no section
        status, elapsed, steps, _, _, _ = trajectory(states, k, t0, direction, tau, rtol, atol, elo, ehi, False, radius,
                                                     max_steps, buffers, None, None)
        o_status[k] = status
        o_time[k] = elapsed
        o_steps[k] = steps
        for i in range(N):
            o_end[k, i] = xv[i]
