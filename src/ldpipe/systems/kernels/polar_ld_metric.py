# The closing section of the flow engine of velocity data on a global grid reaching a pole
# (ldpipe.systems.velocity_data.polar, appended by ldpipe.engine.vector_field): the state is the
# 3-D position X on the sphere of radius 180/pi, the eastward and northward distances run E, N
# (all in degrees of arc) and the time moved (kernels/polar_velocity.py), but the LD of a sphere map is taken in the
# data's units, as on any sphere grid (kernels/sphere_ld_metric.py). The section rebinds
#
# * ``dense`` to the state's dense output with the velocity's in the data's velocity units
#   (degrees of arc per time unit times R pi/180 / velocity_scale): VC then holds dX/dt, which does
#   not turn with the local basis, and u = dE/dt, v = dN/dt;
# * ``step_ld`` to the arc length from dX/dt (sqrt of its three components squared, in km) and
#   M_p from u and v (|u|^p + |v|^p), each by the quadrature the other sphere grids use.
#
# Only the LD sees VC: the end states and the step control are those of the states.
# ruff: noqa: F821  (the engine's functions, constants and the kernel's pointer come from the generated module)

_state_dense = dense


@njit(**JIT)
def dense(xv, t, h, K, xs, fs, QC, VC):
    _state_dense(xv, t, h, K, xs, fs, QC, VC)
    head = velocity_data_pointer()  # the raw pointer, as the kernels read it
    per_degree = head[LD_RADIUS_AT] * (math.pi / 180.0) / head[LD_SCALE_AT]  # data velocity units per (degree per time unit)
    for k in range(NC - 1):
        for c in range(5):  # the position and the distances run; not the time moved
            VC[k, c, 0] *= per_degree


@njit(**JIT)
def step_ld(VC, theta, kind, p_exp, glx, glw, gjx, gjf, window, roots):
    if kind == KIND_ARCLENGTH:
        head = velocity_data_pointer()  # the raw pointer, as the kernels read it
        return arclength_integral(VC, 3, 0, NC, theta, glx, glw) * head[LD_SCALE_AT] / 1000.0
    total = 0.0
    for c in range(3, 5):
        total += component_integral(VC, c, 0, NC, theta, kind, p_exp, glx, glw, gjx, gjf, window, roots)
    return total
