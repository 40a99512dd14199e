# Kernel section: the weights in time of a window's uneven times (a curvilinear grid's data,
# ldpipe.systems.velocity_data.curvilinear), put in front of the kernels that read them
# (gridded_velocity.py, staggered_velocity.py). The times' padded values (nt + 2, ghosts on the
# end nodes' parabola at the mirrored spacing) start at data[base]; the weights are the
# non-uniform cubic's (nonuniform_cubic_weights.py, put in front), exact for quadratics in time.
# A function of its own, called only for uneven times: written out in the kernel's rhs, the
# branch slowed the even grids' every call.
import numba


@numba.njit(cache=True, error_model="numpy")
def uneven_time_weights(data, base, nt, t):
    """(k, w0, w1, w2, w3): the cell [t_k, t_k+1] of the real times holding t (clamped to them),
    and the weights of the padded times k .. k + 3."""
    return grid_weights(data, base, nt, min(max(t, data[base + 1]), data[base + nt]))
