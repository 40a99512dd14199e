# Kernel of velocity data on a global curvilinear grid joined across its seam and its north fold
# (ldpipe.systems.velocity_data.folded). The state is as the polar kernel's (kernels/polar_velocity.py):
# the 3-D position X on the sphere of radius 180/pi (degrees of arc), the eastward and northward
# distances run E, N, and the time moved M; the LD section is the polar one (polar_ld_metric.py).
#
# The velocity at X: the point's fractional grid indices (i, j) are found, then the velocity's 3-D
# Cartesian components (no sign flips across the fold or a pole: one smooth vector field) are
# interpolated there by cubic convolution (Keys 1981, a = -1/2) in i, j and time, as the regular
# kernel does with u, v. South of the cap's latitude the grid is regular in longitude and latitude and
# (i, j) is its closed form; in the cap (the first row of the cap and north of it) (i, j) is found by
# Gauss-Newton on the cubic convolution of the nodes' 3-D positions, from the node a lookup table of
# the cap's stereographic plane gives. A point Newton does not place (the cap's own poles, where
# the cells shrink to nothing) stops, as on land.
#
# The bound buffer: a header of FOLDED_HEADER values, then the velocities (3-D, in the data's
# units times velocity_scale) on the window's padded nodes (rows, columns, time, 3), the nodes'
# unit positions (rows, columns, 3), the land cells (rows, columns: 1 where the cell from (r, c) to
# (r + 1, c + 1) has a land node) and the lookup table (M, M, 2). The window's rows are the grid's
# rows, 3 more beyond the fold (row F + d is row F - d of column P - i) and, if the grid reaches
# the south pole, 3 beyond it (column i + n / 2), each padded by one; its columns the ring with the
# first column again at its end, padded by the real columns across the seam. Header: 0 nt, 1 the
# window's rows, 2 the grid's columns n, 3 the first column's longitude and 4 the spacing, 5 the
# first row's latitude and 6 the spacing (the regular part), 7 t_first, 8 dt, 9 the window row of
# grid row 0, 10 radius, 11 velocity_scale (the LD section reads both), 12 the cap's first latitude,
# 13 where the positions start, 14 where the land cells start, 15 where the table starts, 16 the
# table's M, 17 its half-width in the stereographic plane, 18 the fold's row F (the last row, or
# half a row beyond it), 19 the pivot P: across the fold column i continues as column P - i (n - 1
# or n).
import math

import numba
import numpy as np

from ldpipe.systems.data_pointer import velocity_data_pointer

FOLDED_HEADER = 24
NEWTON_STEPS = 30
NEWTON_TOLERANCE = 1e-11  # grid indices


@numba.njit(inline="always")
def keys_weights(s, w):
    w[0] = ((-0.5 * s + 1.0) * s - 0.5) * s
    w[1] = (1.5 * s - 2.5) * s * s + 1.0
    w[2] = ((-1.5 * s + 2.0) * s + 0.5) * s
    w[3] = (0.5 * s - 0.5) * s * s


@numba.njit(inline="always")
def keys_slopes(s, d):
    d[0] = (-1.5 * s + 2.0) * s - 0.5
    d[1] = (4.5 * s - 5.0) * s
    d[2] = (-4.5 * s + 4.0) * s + 0.5
    d[3] = (1.5 * s - 1.0) * s


@numba.njit(inline="always")
def folded_cell(data, fi, fj):
    """(fi, fj) brought into the window (i modulo n; past the fold to its mirror): (i, window row)."""
    n = data[2]
    fold = data[18]
    if fj > fold:
        fi = data[19] - fi
        fj = 2.0 * fold - fj
    fi -= n * math.floor(fi / n)
    return fi, fj + data[9]


@numba.njit
def position_and_slopes(data, fi, fr, out):
    """The interpolated position at column fi, window row fr, and its derivatives in i and j: out (3, 3)."""
    rows = int(data[1])
    n = int(data[2])
    px = n + 3
    base = int(data[13])
    i = min(int(fi), n - 1)
    r = min(max(int(fr), 0), rows - 2)
    wx = np.empty(4)
    wy = np.empty(4)
    dx = np.empty(4)
    dy = np.empty(4)
    keys_weights(fi - i, wx)
    keys_weights(fr - r, wy)
    keys_slopes(fi - i, dx)
    keys_slopes(fr - r, dy)
    for c in range(3):
        for k in range(3):
            out[c, k] = 0.0
    for b in range(4):
        for a in range(4):
            node = base + 3 * ((r + b) * px + i + a)
            for k in range(3):
                value = data[node + k]
                out[0, k] += wy[b] * wx[a] * value
                out[1, k] += wy[b] * dx[a] * value
                out[2, k] += dy[b] * wx[a] * value


@numba.njit
def locate(data, px_, py_, pz_):
    """The grid indices (i, window row) of the unit vector p, and whether they were found."""
    lat = math.degrees(math.asin(min(max(pz_, -1.0), 1.0)))
    if lat < data[12]:  # the regular part: its closed form
        fi = (math.degrees(math.atan2(py_, px_)) - data[3]) / data[4]
        n = data[2]
        fi -= n * math.floor(fi / n)
        return fi, (lat - data[5]) / data[6] + data[9], True
    size = int(data[16])
    half = data[17]
    table = int(data[15])
    a = min(max(int((px_ / (1.0 + pz_) + half) / (2.0 * half) * size), 0), size - 1)
    b = min(max(int((py_ / (1.0 + pz_) + half) / (2.0 * half) * size), 0), size - 1)
    fi = data[table + 2 * (b * size + a)]
    fj = data[table + 2 * (b * size + a) + 1]
    slopes = np.empty((3, 3))
    for _ in range(NEWTON_STEPS):
        ci, cr = folded_cell(data, fi, fj)
        position_and_slopes(data, ci, cr, slopes)
        rx = slopes[0, 0] - px_
        ry = slopes[0, 1] - py_
        rz = slopes[0, 2] - pz_
        aa = slopes[1, 0] * slopes[1, 0] + slopes[1, 1] * slopes[1, 1] + slopes[1, 2] * slopes[1, 2]
        ab = slopes[1, 0] * slopes[2, 0] + slopes[1, 1] * slopes[2, 1] + slopes[1, 2] * slopes[2, 2]
        bb = slopes[2, 0] * slopes[2, 0] + slopes[2, 1] * slopes[2, 1] + slopes[2, 2] * slopes[2, 2]
        ga = slopes[1, 0] * rx + slopes[1, 1] * ry + slopes[1, 2] * rz
        gb = slopes[2, 0] * rx + slopes[2, 1] * ry + slopes[2, 2] * rz
        det = aa * bb - ab * ab
        if not det > 0.0:
            return 0.0, 0.0, False
        si = min(max((bb * ga - ab * gb) / det, -1.5), 1.5)
        sj = min(max((aa * gb - ab * ga) / det, -1.5), 1.5)
        # Newton runs in the window's chart about the cell it is in (the fold's mirror continues it)
        fi = ci - si
        fj = cr - data[9] - sj
        if abs(si) < NEWTON_TOLERANCE and abs(sj) < NEWTON_TOLERANCE:
            ci, cr = folded_cell(data, fi, fj)
            return ci, cr, True
    return 0.0, 0.0, False


def rhs(state, t, out):
    data = velocity_data_pointer()
    x = state[0]
    y = state[1]
    z = state[2]
    rho = math.sqrt(x * x + y * y)
    r = math.sqrt(rho * rho + z * z)
    for k in range(6):
        out[k] = 0.0
    nt = int(data[0])
    if nt < 2 or not r > 0.0:
        return
    fi, fr, found = locate(data, x / r, y / r, z / r)
    rows = int(data[1])
    n = int(data[2])
    if not found or not (fr >= 0.0 and fr <= rows - 1.0):  # the cap's poles, or past the grid's southern edge
        return
    i = min(int(fi), n - 1)
    row = min(int(fr), rows - 2)
    if data[int(data[14]) + row * n + i] > 0.0:  # a land cell
        return
    ft = min(max((t - data[7]) / data[8], 0.0), nt - 1.0)
    k = min(int(ft), nt - 2)
    wx = np.empty(4)
    wy = np.empty(4)
    wt = np.empty(4)
    keys_weights(fi - i, wx)
    keys_weights(fr - row, wy)
    keys_weights(ft - k, wt)
    px = n + 3
    qt = nt + 2
    vx = 0.0
    vy = 0.0
    vz = 0.0
    for b in range(4):
        for a in range(4):
            node = FOLDED_HEADER + 3 * (((row + b) * px + i + a) * qt + k)
            w = wy[b] * wx[a]
            for c in range(4):
                wc = w * wt[c]
                vx += wc * data[node + 3 * c]
                vy += wc * data[node + 3 * c + 1]
                vz += wc * data[node + 3 * c + 2]
    if rho > 0.0:
        cos_lon = x / rho
        sin_lon = y / rho
    else:
        cos_lon = 1.0
        sin_lon = 0.0
    sin_lat = z / r
    cos_lat = rho / r
    factor = (180.0 / math.pi) / data[10]
    u = (-vx * sin_lon + vy * cos_lon) * factor  # the tangent components: the interpolant's radial part dropped
    v = (-(vx * cos_lon + vy * sin_lon) * sin_lat + vz * cos_lat) * factor
    out[0] = -u * sin_lon - v * sin_lat * cos_lon
    out[1] = u * cos_lon - v * sin_lat * sin_lon
    out[2] = v * cos_lat
    out[3] = u
    out[4] = v
    out[5] = 0.0 if u == 0.0 and v == 0.0 else 1.0
