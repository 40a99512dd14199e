# Kernel template of velocity data on an Arakawa C-grid (ldpipe.systems.velocity_data.staggered),
# in the grid's index space: the state is the fractional indices (i, j) of the cells' centres
# (the nodes); U (index velocity along i) lives on the faces i + 1/2 between nodes, V on the faces
# j + 1/2. In the cell round node (i, j), [i - 1/2, i + 1/2] x [j - 1/2, j + 1/2], U is linear in i
# between the cell's west and east faces and does not vary with j; V likewise in j. So the
# velocity normal to a face is the face's own, everywhere on it: a closed face (U = 0, a coast)
# is a wall no trajectory crosses (it approaches it as exp(-t)). In time each face's value is the
# cubic convolution (Keys 1981, Catmull-Rom) of its times. First order in space across the cells
# (a cell's U is one value across it), the interpolant of C-grid particle trackers.
#
# The bound buffer: a header of DATA_HEADER values, then U as (ny, nx - 1, nt + 2), V as
# (ny - 1, nx, nt + 2) (each face's times together, padded by one time on each side), then the
# land nodes (ny, nx) (1.0 on land: its cell is land, its faces closed), then each cell's scale
# (ny, nx): the index velocity is the faces' interpolated values times it (1 / the cell's area
# when U and V are fluxes, from a model's metrics; else 1), then the LD metric's P
# (kernels/curvilinear_ld_metric.py). Faces, land and scales are all the box's: row j, column i
# of each is the whole grid's centre (j0 + j, i0 + i). Header: nt, ny, nx (the centres read),
# i0, 1, j0, 1 (i0, j0 the first centre read: 0, 0 for the whole grid, a window's box elsewhere;
# the state is the whole grid's indices), t_first, dt, 0 or where uneven times start (nt + 2
# values, padded as rectilinear_velocity.py pads an axis), radius, 1, P's offset, the arc
# length's factor, V's offset, the land's offset.
#
# A point within NEAR_WALL of a closed face on its land side (a step overshoots a wall by about the
# integrator's tolerance) takes the water cell's linear velocity, continued: it points back at the
# face, so the wall attracts from both sides and a trajectory stays on it.
#
# Boundaries: only cells with both faces in the data are read (1 <= i <= nx - 2, 1 <= j <= ny - 2,
# the outer half cells of the edge nodes have no outer face); outside them, and in a land cell,
# the velocity is 0, so a trajectory leaving the data stops at its edge (the LD stage flags it).
import math

from ldpipe.systems.data_pointer import velocity_data_pointer

DATA_HEADER = 16
# How far into a land cell (in cells) a point counts as just past its wall (the velocity module's FACE_SLACK).
NEAR_WALL = 1e-3


def rhs(state, t, out):
    data = velocity_data_pointer()  # read as a raw pointer: no array bounds, no negative-index wraparound
    nt = int(data[0])
    ny = int(data[1])
    nx = int(data[2])
    out[0] = 0.0
    out[1] = 0.0
    if nt < 2:  # nothing bound
        out[0] = math.nan
        out[1] = math.nan
        return
    fi = state[0] - data[3]  # from the box's first centre (an integer: exact)
    fj = state[1] - data[5]
    if not (fi >= 0.5 and fi <= nx - 1.5 and fj >= 0.5 and fj <= ny - 1.5):
        return
    i = min(int(fi + 0.5), nx - 2)
    j = min(int(fj + 0.5), ny - 2)
    land = int(data[15])
    if data[land + j * nx + i] > 0.0:
        # Just past a wall (a step's overshoot, to the integrator's tolerance): the water cell's
        # velocity continued, which points back at the wall; deeper in land nothing moves.
        si = -1 if fi - (i - 0.5) < NEAR_WALL and i >= 2 else (1 if (i + 0.5) - fi < NEAR_WALL and i <= nx - 3 else 0)
        sj = -1 if fj - (j - 0.5) < NEAR_WALL and j >= 2 else (1 if (j + 0.5) - fj < NEAR_WALL and j <= ny - 3 else 0)
        if (si != 0 or sj != 0) and data[land + (j + sj) * nx + i + si] == 0.0:
            i += si
            j += sj
        elif si != 0 and data[land + j * nx + i + si] == 0.0:
            i += si
        elif sj != 0 and data[land + (j + sj) * nx + i] == 0.0:
            j += sj
        else:
            return
    ft = min(max((t - data[7]) / data[8], 0.0), nt - 1.0)
    k = min(int(ft), nt - 2)
    st = ft - k
    wt0 = ((-0.5 * st + 1.0) * st - 0.5) * st
    wt1 = (1.5 * st - 2.5) * st * st + 1.0
    wt2 = ((-1.5 * st + 2.0) * st + 0.5) * st
    wt3 = (0.5 * st - 0.5) * st * st
    if data[9] > 0.0:  # uneven times (their padded values at data[9]): kernels/uneven_time_weights.py
        k, wt0, wt1, wt2, wt3 = uneven_time_weights(data, int(data[9]), nt, t)
    qt = nt + 2
    a = fi - (i - 0.5)  # from the west face, 0 .. 1
    west = DATA_HEADER + (j * (nx - 1) + i - 1) * qt + k
    east = west + qt
    u_west = wt0 * data[west] + wt1 * data[west + 1] + wt2 * data[west + 2] + wt3 * data[west + 3]
    u_east = wt0 * data[east] + wt1 * data[east + 1] + wt2 * data[east + 2] + wt3 * data[east + 3]
    b = fj - (j - 0.5)  # from the south face, 0 .. 1
    south = int(data[14]) + ((j - 1) * nx + i) * qt + k
    north = south + nx * qt
    v_south = wt0 * data[south] + wt1 * data[south + 1] + wt2 * data[south + 2] + wt3 * data[south + 3]
    v_north = wt0 * data[north] + wt1 * data[north + 1] + wt2 * data[north + 2] + wt3 * data[north + 3]
    scale = data[land + ny * nx + j * nx + i]
    out[0] = ((1.0 - a) * u_west + a * u_east) * scale
    out[1] = ((1.0 - b) * v_south + b * v_north) * scale
