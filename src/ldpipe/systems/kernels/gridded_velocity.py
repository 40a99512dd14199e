# Kernel template of a velocity-data system (ldpipe.systems.velocity_data): the velocity at
# (x, y, t) by cubic convolution (Keys 1981, a = -1/2: Catmull-Rom) in x, y and t on the
# data's regular grid, read through ldpipe.systems.data_pointer. Exact for polynomials of degree
# <= 2 in each variable (the boundary nodes are extrapolated by Keys' rule, exact for quadratics),
# third-order accurate in the grid spacing.
#
# The bound buffer (ldpipe.systems.velocity_data.DataWindow.buffer): a header of DATA_HEADER
# values, then u, v on the padded grid (nt + 2, ny + 2, nx + 2), then the padded land mask
# (ny + 2, nx + 2), 1.0 where a node is land. Header: nt, ny, nx, x_first, dx, y_first, dy,
# t_first, dt, sphere (0 or 1), radius, velocity_scale.
#
# Boundaries: a point outside the grid's extent, or in a cell with a land corner, has velocity 0,
# so a trajectory stops where it reaches land or the data's edge (the LD stage flags it); times
# outside the window are clamped (the caller refuses a window that leaves the data's times).
# On the sphere x, y are longitude and latitude in degrees, a longitude taken modulo 360 from the
# grid's first (so -170 and 190 are the same point, in a grid of either convention), and
# d lon/dt = u / (R cos lat) * 180/pi, d lat/dt = v / R * 180/pi.
import math

from numba import carray
from ldpipe.systems.data_pointer import velocity_data_pointer

DATA_HEADER = 16


def rhs(state, t, out):
    head = carray(velocity_data_pointer(), (DATA_HEADER,))
    nt = int(head[0])
    ny = int(head[1])
    nx = int(head[2])
    if nt < 2:  # nothing bound
        out[0] = math.nan
        out[1] = math.nan
        return
    east = state[0] - head[3]
    if head[9] > 0.0:  # on the sphere a longitude in either convention, across the dateline too
        east -= 360.0 * math.floor(east / 360.0)
    fx = east / head[4]
    fy = (state[1] - head[5]) / head[6]
    if not (fx >= 0.0 and fx <= nx - 1.0 and fy >= 0.0 and fy <= ny - 1.0):
        out[0] = 0.0
        out[1] = 0.0
        return
    ft = min(max((t - head[7]) / head[8], 0.0), nt - 1.0)
    i = min(int(fx), nx - 2)
    j = min(int(fy), ny - 2)
    k = min(int(ft), nt - 2)
    px = nx + 2
    py = ny + 2
    size = (nt + 2) * py * px
    data = carray(velocity_data_pointer(), (DATA_HEADER + 2 * size + py * px,))
    land = DATA_HEADER + 2 * size
    # the cell's corners are padded nodes (j + 1 .. j + 2, i + 1 .. i + 2)
    if (data[land + (j + 1) * px + i + 1] + data[land + (j + 1) * px + i + 2]
            + data[land + (j + 2) * px + i + 1] + data[land + (j + 2) * px + i + 2]) > 0.0:
        out[0] = 0.0
        out[1] = 0.0
        return
    sx = fx - i
    sy = fy - j
    st = ft - k
    wx0 = ((-0.5 * sx + 1.0) * sx - 0.5) * sx
    wx1 = (1.5 * sx - 2.5) * sx * sx + 1.0
    wx2 = ((-1.5 * sx + 2.0) * sx + 0.5) * sx
    wx3 = (0.5 * sx - 0.5) * sx * sx
    wy = (((-0.5 * sy + 1.0) * sy - 0.5) * sy, (1.5 * sy - 2.5) * sy * sy + 1.0,
          ((-1.5 * sy + 2.0) * sy + 0.5) * sy, (0.5 * sy - 0.5) * sy * sy)
    wt = (((-0.5 * st + 1.0) * st - 0.5) * st, (1.5 * st - 2.5) * st * st + 1.0,
          ((-1.5 * st + 2.0) * st + 0.5) * st, (0.5 * st - 0.5) * st * st)
    u = 0.0
    v = 0.0
    for a in range(4):
        for b in range(4):
            row = DATA_HEADER + ((k + a) * py + j + b) * px + i
            wab = wt[a] * wy[b]
            u += wab * (wx0 * data[row] + wx1 * data[row + 1] + wx2 * data[row + 2] + wx3 * data[row + 3])
            row += size
            v += wab * (wx0 * data[row] + wx1 * data[row + 1] + wx2 * data[row + 2] + wx3 * data[row + 3])
    scale = head[11]
    if head[9] > 0.0:
        degrees = 180.0 / math.pi
        out[0] = u * scale * degrees / (head[10] * math.cos(state[1] / degrees))
        out[1] = v * scale * degrees / head[10]
    else:
        out[0] = u * scale
        out[1] = v * scale
