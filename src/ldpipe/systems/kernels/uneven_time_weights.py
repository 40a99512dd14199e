# Kernel section: the weights in time of a window's uneven times (a curvilinear grid's data,
# ldpipe.systems.velocity_data.curvilinear), put in front of the kernels that read them
# (gridded_velocity.py, staggered_velocity.py). The times' padded values (nt + 2, ghosts on the
# end nodes' parabola at the mirrored spacing) start at data[base]; the weights are the
# non-uniform cubic's of rectilinear_velocity.py (its grid_weights), exact for quadratics in time.
# A function of its own, called only for uneven times: written out in the kernel's rhs, the
# branch slowed the even grids' every call.
import numba


@numba.njit(cache=True, error_model="numpy")
def uneven_time_weights(data, base, nt, t):
    """(k, w0, w1, w2, w3): the cell [t_k, t_k+1] of the real times holding t (clamped to them),
    and the weights of the padded times k .. k + 3."""
    tc = min(max(t, data[base + 1]), data[base + nt])
    low = 0
    high = nt - 1
    while high - low > 1:
        middle = (low + high) >> 1
        if data[base + 1 + middle] <= tc:
            low = middle
        else:
            high = middle
    h0 = data[base + low + 1] - data[base + low]
    h1 = data[base + low + 2] - data[base + low + 1]
    h2 = data[base + low + 3] - data[base + low + 2]
    s = (tc - data[base + low + 1]) / h1
    s2 = s * s
    s3 = s2 * s
    h00 = 2.0 * s3 - 3.0 * s2 + 1.0
    h10 = s3 - 2.0 * s2 + s
    h01 = 3.0 * s2 - 2.0 * s3
    h11 = s3 - s2
    return (low, -h10 * h1 * h1 / (h0 * (h0 + h1)), h00 + h10 * (h1 - h0) / h0 - h11 * h2 / (h1 + h2),
            h01 + h10 * h0 / (h0 + h1) + h11 * (h2 - h1) / h2, h11 * h1 * h1 / (h2 * (h1 + h2)))
