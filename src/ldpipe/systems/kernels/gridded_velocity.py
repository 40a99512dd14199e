# Kernel template of a velocity-data system (ldpipe.systems.velocity_data): the velocity at
# (x, y, t) by cubic convolution (Keys 1981, a = -1/2: Catmull-Rom) in x, y and t on the
# data's regular grid, read through ldpipe.systems.data_pointer. Exact for polynomials of degree
# <= 2 in each variable (the boundary nodes are extrapolated by Keys' rule, exact for quadratics),
# third-order accurate in the grid spacing, C1. With header slot 14 set, the same stencil applies
# cubic B-spline weights to coefficients prefiltered from the data (velocity_data/bspline.py):
# exact for cubics in each variable, fourth-order accurate, C2; one kernel and one compiled engine
# serve both.
#
# The bound buffer (ldpipe.systems.velocity_data.DataWindow.buffer): a header of DATA_HEADER
# values, then u and v on the padded grid as (ny + 2, nx + 2, nt + 2, 2): u and v side by side,
# so a node's read serves both, and a node's times together, because a trajectory's calls (the
# stages of a step) sweep several time cells while moving about one cell in space; then the land
# cells (ny + 2, nx + 2): at (j, i) 1.0 where the cell from node (j, i) to (j + 1, i + 1) of the
# window has a land corner (one read a call instead of four). Header: nt, ny, nx, x_first, dx,
# y_first, dy, t_first, dt, sphere (0 or 1), radius, velocity_scale, two slots of the curvilinear
# LD metric, the interpolant (0 cubic convolution of the data, 1 cubic B-spline of coefficients),
# and 0, or where a curvilinear grid's uneven times start (nt + 2 values, padded as
# rectilinear_velocity.py pads an axis; t_first and dt then unused, the time weights that
# kernel's non-uniform cubic).
#
# Boundaries: a point outside the grid's extent, or in a cell with a land corner, has velocity 0,
# so a trajectory stops where it reaches land or the data's edge (the LD stage flags it); times
# outside the window are clamped (the caller refuses a window that leaves the data's times).
# On the sphere x, y are longitude and latitude in degrees, a longitude taken modulo 360 from the
# grid's first (so -170 and 190 are the same point, in a grid of either convention), and
# d lon/dt = u / (R cos lat) * 180/pi, d lat/dt = v / R * 180/pi.
import math

import numba

from ldpipe.systems.data_pointer import velocity_data_pointer
from ldpipe.systems.data_stencil import stencil_velocity

DATA_HEADER = 16
EDGE_SLACK = 1e-9  # cells: how far outside the B-spline's edge a point counts as on it
SIXTH = 1.0 / 6.0  # a product: a division costs several times as much


@numba.njit(inline="always")  # compiled into rhs, with the engine's options
def grid_velocity(x, y, t):
    """(dx/dt, dy/dt) at (x, y) and time t."""
    data = velocity_data_pointer()  # read as a raw pointer: no array bounds, no negative-index wraparound
    nt = int(data[0])
    ny = int(data[1])
    nx = int(data[2])
    if nt < 2:  # nothing bound
        return math.nan, math.nan
    east = x - data[3]
    if data[9] > 0.0:  # on the sphere a longitude in either convention, across the dateline too
        east -= 360.0 * math.floor(east / 360.0)
    fx = east / data[4]
    fy = (y - data[5]) / data[6]
    if data[14] > 0.0:
        # the B-spline's value on the edge is a sum of three coefficients: a velocity the data make
        # zero there (a wall) comes out as rounding, which would carry a trajectory sliding along the
        # wall a hair outside, where it stops; within EDGE_SLACK cells it stays on the edge
        fx = min(max(fx, 0.0), nx - 1.0) if fx > -EDGE_SLACK and fx < nx - 1.0 + EDGE_SLACK else fx
        fy = min(max(fy, 0.0), ny - 1.0) if fy > -EDGE_SLACK and fy < ny - 1.0 + EDGE_SLACK else fy
    if not (fx >= 0.0 and fx <= nx - 1.0 and fy >= 0.0 and fy <= ny - 1.0):
        return 0.0, 0.0
    ft = min(max((t - data[7]) / data[8], 0.0), nt - 1.0)
    i = min(int(fx), nx - 2)
    j = min(int(fy), ny - 2)
    k = min(int(ft), nt - 2)
    px = nx + 2
    py = ny + 2
    nodes = (nt + 2) * py * px
    if data[DATA_HEADER + 2 * nodes + j * px + i] > 0.0:  # a land cell
        return 0.0, 0.0
    sx = fx - i
    sy = fy - j
    st = ft - k
    if data[14] > 0.0:  # cubic B-spline weights on prefiltered coefficients: C2
        rx = 1.0 - sx
        ry = 1.0 - sy
        rt = 1.0 - st
        wx0 = rx * rx * rx * SIXTH
        wx1 = ((0.5 * sx - 1.0) * sx * sx) + 2.0 / 3.0
        wx2 = ((0.5 * rx - 1.0) * rx * rx) + 2.0 / 3.0
        wx3 = sx * sx * sx * SIXTH
        wy0 = ry * ry * ry * SIXTH
        wy1 = ((0.5 * sy - 1.0) * sy * sy) + 2.0 / 3.0
        wy2 = ((0.5 * ry - 1.0) * ry * ry) + 2.0 / 3.0
        wy3 = sy * sy * sy * SIXTH
        wt0 = rt * rt * rt * SIXTH
        wt1 = ((0.5 * st - 1.0) * st * st) + 2.0 / 3.0
        wt2 = ((0.5 * rt - 1.0) * rt * rt) + 2.0 / 3.0
        wt3 = st * st * st * SIXTH
    else:  # cubic convolution on the data
        wx0 = ((-0.5 * sx + 1.0) * sx - 0.5) * sx
        wx1 = (1.5 * sx - 2.5) * sx * sx + 1.0
        wx2 = ((-1.5 * sx + 2.0) * sx + 0.5) * sx
        wx3 = (0.5 * sx - 0.5) * sx * sx
        wy0 = ((-0.5 * sy + 1.0) * sy - 0.5) * sy
        wy1 = (1.5 * sy - 2.5) * sy * sy + 1.0
        wy2 = ((-1.5 * sy + 2.0) * sy + 0.5) * sy
        wy3 = (0.5 * sy - 0.5) * sy * sy
        wt0 = ((-0.5 * st + 1.0) * st - 0.5) * st
        wt1 = (1.5 * st - 2.5) * st * st + 1.0
        wt2 = ((-1.5 * st + 2.0) * st + 0.5) * st
        wt3 = (0.5 * st - 0.5) * st * st
    if data[15] > 0.0:  # uneven times (a curvilinear grid's): kernels/uneven_time_weights.py
        k, wt0, wt1, wt2, wt3 = uneven_time_weights(data, int(data[15]), nt, t)
    qt = nt + 2
    # the 4 x 4 nodes from (i, j) at the time levels k .. k + 3: a node's (u, v) at the 4 levels are
    # 8 doubles side by side, its x neighbour's 2 qt further, its y neighbour's 2 qt px
    u, v = stencil_velocity(data, DATA_HEADER + 2 * ((j * px + i) * qt + k), 2 * qt, 2 * qt * px,
                            (wx0, wx1, wx2, wx3), (wy0, wy1, wy2, wy3), (wt0, wt1, wt2, wt3))
    return velocity_in_state_units(u, v, y, data[9], data[10], data[11])


def rhs(state, t, out):
    # the returns above lead to one exit here, where numba drops the reference counts of state and
    # out it takes on entry (with a return for each case it kept them: four atomic updates a call)
    out[0], out[1] = grid_velocity(state[0], state[1], t)
