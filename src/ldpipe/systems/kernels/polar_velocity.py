

# The velocity of a global grid reaching a pole as the engine integrates it
# (ldpipe.systems.velocity_data.polar): the state is the 3-D position X on the sphere of radius
# 180/pi (degrees of arc), then the eastward and northward distances run, E and N (degrees of arc).
# The data's u, v (eastward, northward) are interpolated by the regular kernel above (its rhs
# renamed polar_grid_velocity; the header's sphere flag 0, so it returns u and v times the velocity
# scale, in metres per time unit) at X's longitude, brought to the grid's first turn, and latitude;
# dX/dt = (180/pi) / R (u e_east + v e_north), dE/dt = (180/pi) / R u, dN/dt = (180/pi) / R v (N is
# the latitude's change: started at the start's latitude it is the latitude), and the time moved
# M, dM/dt = 1 while the kernel gives a velocity (not 0 exactly: land, or past the data's edge).
# E and N are for the LD's M_p (u and v in the local basis, which turns fast near a pole): as
# states they make the step control follow that turning; M stops growing where the trajectory
# stops, and the step control locates that instant as any kink. At the pole itself (x = y = 0) the longitude is 0 and
# e_east (0, 1, 0), u and v read along that meridian, which the rows across the pole make consistent.
# ruff: noqa: F821  (numba, math and polar_grid_velocity come from the kernel text before this one)
polar_grid_velocity = numba.njit(inline="always")(polar_grid_velocity)


def rhs(state, t, out):
    data = velocity_data_pointer()
    x = state[0]
    y = state[1]
    z = state[2]
    rho = math.sqrt(x * x + y * y)
    r = math.sqrt(rho * rho + z * z)
    if rho > 0.0:
        cos_lon = x / rho
        sin_lon = y / rho
    else:
        cos_lon = 1.0
        sin_lon = 0.0
    east = math.atan2(y, x) * (180.0 / math.pi) - data[3]
    east -= 360.0 * math.floor(east / 360.0)
    polar_grid_velocity((data[3] + east, math.atan2(z, rho) * (180.0 / math.pi)), t, out)
    out[5] = 0.0 if out[0] == 0.0 and out[1] == 0.0 else 1.0
    factor = (180.0 / math.pi) / data[10]
    u = out[0] * factor
    v = out[1] * factor
    sin_lat = z / r
    cos_lat = rho / r
    out[0] = -u * sin_lon - v * sin_lat * cos_lon
    out[1] = u * cos_lon - v * sin_lat * sin_lon
    out[2] = v * cos_lat
    out[3] = u
    out[4] = v
