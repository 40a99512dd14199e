# Kernel template of a velocity-data system on a rectilinear grid (ldpipe.systems.
# velocity_data.rectilinear): every axis (x, y, z of 3-D data, time) given by its node values,
# spaced as they come, each increasing. A line GRID_DIMS = 2 (u, v on (t, y, x)) or 3 (u, v, w
# on (t, z, y, x)) is put in front of this text.
#
# Interpolation, per axis, on the cell [x1, x2] of the nodes x0 < x1 < x2 < x3 (h0, h1, h2 the
# three spacings, s = (x - x1) / h1): the cubic Hermite interpolant of the values f1, f2 and of
# the slopes at x1 and x2 of the parabolas through (x0, x1, x2) and (x1, x2, x3)
# (a non-uniform Catmull-Rom spline), i.e. sum_k w_k f_k with, in the Hermite basis
# H00 = 2s^3 - 3s^2 + 1, H10 = s^3 - 2s^2 + s, H01 = -2s^3 + 3s^2, H11 = s^3 - s^2,
#     w0 = -H10 h1^2 / (h0 (h0 + h1))
#     w1 = H00 + H10 (h1 - h0) / h0 - H11 h2 / (h1 + h2)
#     w2 = H01 + H10 h0 / (h0 + h1) + H11 (h2 - h1) / h2
#     w3 = H11 h1^2 / (h2 (h1 + h2)).
# The parabolas' slopes are exact for quadratics, so the interpolant reproduces every polynomial
# of degree <= 2 in each variable exactly; it is C1 across nodes and third-order accurate in the
# largest spacing. On equal spacings the weights are Keys' cubic convolution (a = -1/2), the
# uniform kernel's (gridded_velocity.py). The cell is found by bisection on the node values
# (O(log n)); the product of the axes' weights is the interpolant (tensor product). The weights'
# function, grid_weights, is kernels/nonuniform_cubic_weights.py, put in front of this text.
#
# The bound buffer (ldpipe.systems.velocity_data.rectilinear.read_rectilinear_window): a header
# of GRID_HEADER values (nt, nz (1 in 2-D), ny, nx, sphere (0 or 1), radius, velocity_scale,
# vertical_scale), the padded node values of x (nx + 2), y (ny + 2), z (nz + 2, 3-D only) and
# t (nt + 2), u, v (and w) on the padded grid (nt + 2, pz, ny + 2, nx + 2) with pz = nz + 2 (1 in
# 2-D), then the padded land mask (pz, ny + 2, nx + 2), 1.0 where a node is land. A padding
# node is the real neighbour where the window has one, else a ghost at the mirrored spacing on
# the parabola through the three end nodes (so quadratics stay exact up to the edge).
#
# Boundaries as in the uniform kernel: outside the grid's extent (in z too: the surface and
# bottom levels), or in a cell with a land corner (the sea floor is land: missing values below
# it), the velocity is 0 and a trajectory stops; times are clamped to the window. On the sphere
# x, y are longitude and latitude in degrees (a longitude modulo 360 from the grid's first),
# d lon/dt = u / (R cos lat) * 180/pi, d lat/dt = v / R * 180/pi; z in its own length units.
# dz/dt = vertical_scale * w (w upward; the scale is negative for a depth, positive down).
import math

from numba import carray
from ldpipe.systems.data_pointer import velocity_data_pointer

GRID_HEADER = 16
GRID_ZTAPS = 4 if GRID_DIMS == 3 else 1  # the stencil's levels
GRID_ZCORNERS = 2 if GRID_DIMS == 3 else 1  # the cell's levels


def rhs(state, t, out):
    head = carray(velocity_data_pointer(), (GRID_HEADER,))
    nt = int(head[0])
    nz = int(head[1])
    ny = int(head[2])
    nx = int(head[3])
    if nt < 2:  # nothing bound
        for d in range(GRID_DIMS):
            out[d] = math.nan
        return
    px = nx + 2
    py = ny + 2
    pz = nz + 2 if GRID_DIMS == 3 else 1
    xs = GRID_HEADER
    ys = xs + px
    zs = ys + py
    ts = zs + pz if GRID_DIMS == 3 else zs
    first = ts + nt + 2
    size = (nt + 2) * pz * py * px
    land = first + GRID_DIMS * size
    data = carray(velocity_data_pointer(), (land + pz * py * px,))
    x = state[0]
    if head[4] > 0.0:  # on the sphere a longitude in either convention, across the dateline too
        east = x - data[xs + 1]
        if east < 0.0 or east >= 360.0:  # (unwrapped only when needed: the same bits in any window)
            x = data[xs + 1] + (east - 360.0 * math.floor(east / 360.0))
    y = state[1]
    z = state[2] if GRID_DIMS == 3 else 0.0
    inside = x >= data[xs + 1] and x <= data[xs + nx] and y >= data[ys + 1] and y <= data[ys + ny]
    if GRID_DIMS == 3:
        inside = inside and z >= data[zs + 1] and z <= data[zs + nz]
    if not inside:
        for d in range(GRID_DIMS):
            out[d] = 0.0
        return
    time = min(max(t, data[ts + 1]), data[ts + nt])
    i, wx0, wx1, wx2, wx3 = grid_weights(data, xs, nx, x)
    j, wy0, wy1, wy2, wy3 = grid_weights(data, ys, ny, y)
    k, wt0, wt1, wt2, wt3 = grid_weights(data, ts, nt, time)
    m = 0
    wz = (1.0, 0.0, 0.0, 0.0)
    if GRID_DIMS == 3:
        m, wz0, wz1, wz2, wz3 = grid_weights(data, zs, nz, z)
        wz = (wz0, wz1, wz2, wz3)
    # the cell's corners are padded nodes (m + 1 .. m + 2 in 3-D), j + 1 .. j + 2, i + 1 .. i + 2
    for c in range(GRID_ZCORNERS):
        plane = land + ((m + 1 + c) if GRID_DIMS == 3 else 0) * py * px
        if (data[plane + (j + 1) * px + i + 1] + data[plane + (j + 1) * px + i + 2]
                + data[plane + (j + 2) * px + i + 1] + data[plane + (j + 2) * px + i + 2]) > 0.0:
            for d in range(GRID_DIMS):
                out[d] = 0.0
            return
    wy = (wy0, wy1, wy2, wy3)
    wt = (wt0, wt1, wt2, wt3)
    u = 0.0
    v = 0.0
    w = 0.0
    for a in range(4):
        for c in range(GRID_ZTAPS):
            wac = wt[a] * wz[c]
            for b in range(4):
                row = first + (((k + a) * pz + m + c) * py + j + b) * px + i
                wabc = wac * wy[b]
                u += wabc * (wx0 * data[row] + wx1 * data[row + 1] + wx2 * data[row + 2] + wx3 * data[row + 3])
                row += size
                v += wabc * (wx0 * data[row] + wx1 * data[row + 1] + wx2 * data[row + 2] + wx3 * data[row + 3])
                if GRID_DIMS == 3:
                    row += size
                    w += wabc * (wx0 * data[row] + wx1 * data[row + 1] + wx2 * data[row + 2] + wx3 * data[row + 3])
    out[0], out[1] = velocity_in_state_units(u, v, state[1], head[4], head[5], head[6])
    if GRID_DIMS == 3:
        out[2] = w * head[7]
