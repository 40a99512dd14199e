# Kernel section: the weights of the non-uniform cubic (Catmull-Rom) interpolant on an axis given
# by its node values (derived in rectilinear_velocity.py's header), put in front of the kernels
# that interpolate on such an axis: every axis of a rectilinear grid, and the uneven times of a
# curvilinear grid or a C-grid (uneven_time_weights.py).
import numba


@numba.njit(cache=True, error_model="numpy")
def grid_weights(data, start, count, value):
    """(i, w0, w1, w2, w3): the cell [c_i, c_i+1] of the real nodes c_0 .. c_count-1 (at
    data[start + 1 ...], ghosts around them) holding ``value`` (inside them), and the weights
    of the padded nodes i .. i + 3 (the real nodes i - 1 .. i + 2)."""
    low = 0
    high = count - 1
    while high - low > 1:
        middle = (low + high) >> 1
        if data[start + 1 + middle] <= value:
            low = middle
        else:
            high = middle
    x0 = data[start + low]
    x1 = data[start + low + 1]
    x2 = data[start + low + 2]
    x3 = data[start + low + 3]
    h0 = x1 - x0
    h1 = x2 - x1
    h2 = x3 - x2
    s = (value - x1) / h1
    s2 = s * s
    s3 = s2 * s
    h00 = 2.0 * s3 - 3.0 * s2 + 1.0
    h10 = s3 - 2.0 * s2 + s
    h01 = 3.0 * s2 - 2.0 * s3
    h11 = s3 - s2
    w0 = -h10 * h1 * h1 / (h0 * (h0 + h1))
    w1 = h00 + h10 * (h1 - h0) / h0 - h11 * h2 / (h1 + h2)
    w2 = h01 + h10 * h0 / (h0 + h1) + h11 * (h2 - h1) / h2
    w3 = h11 * h1 * h1 / (h2 * (h1 + h2))
    return low, w0, w1, w2, w3
