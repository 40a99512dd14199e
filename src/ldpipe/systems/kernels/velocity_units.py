# Put in front of the velocity-data kernel templates' text (gridded_velocity.py,
# rectilinear_velocity.py), which call it: the interpolated data velocity (u, v) in the state's
# units. Inlined into its caller, so the compiled arithmetic is the caller's own.
import math

import numba


@numba.njit(inline="always")
def velocity_in_state_units(u, v, latitude, sphere, radius, scale):
    # (dx/dt, dy/dt): (u, v) times the data's velocity scale; on the sphere (sphere > 0, x and y
    # longitude and latitude in degrees) d lon/dt = u / (R cos lat) * 180/pi, d lat/dt = v / R * 180/pi
    if sphere > 0.0:
        degrees = 180.0 / math.pi
        return u * scale * degrees / (radius * math.cos(latitude / degrees)), v * scale * degrees / radius
    return u * scale, v * scale
