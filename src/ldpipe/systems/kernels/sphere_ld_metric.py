# The closing section of the flow engine of a velocity-data system on the sphere
# (ldpipe.systems.velocity_data, appended by ldpipe.engine.vector_field after the driver's
# templates; a plane system's engine has none, so its text is unchanged). The state is
# (lon, lat) in degrees, but the LD of a sphere map is taken in physical units: the section
# rebinds
#
# * ``dense`` to the state's dense output followed by the physical velocity's: VC then holds
#   u = R cos(lat) d lon/dt and v = R d lat/dt (angles in radians) in the data's velocity units,
#   as the dense output of DOP853 (Hairer, Norsett & Wanner I, sec. II.6) gives them from the
#   stages' u, v: each stage's u is its d lon/dt times cos of its own latitude (the stage state
#   the kernel saw, recomputed by ``stage_state`` with the same operations), so the LD quadrature
#   integrates |u|^p + |v|^p (M_p) or sqrt(u^2 + v^2) with the order of the state's dense output;
# * ``step_ld`` to the quadrature of that velocity, converted to kilometres for the arc length
#   (velocity_scale: the data's velocity unit in metres per time unit of the integration).
#
# Only the LD sees VC: the end states, exits and step control are those of the degrees' engine.
# Header values read: radius (metres) and velocity_scale, as the kernel reads them.
# ruff: noqa: F821  (the engine's functions, constants and the kernel's pointer come from the generated module)

_state_dense = dense
_coordinate_step_ld = step_ld


@njit(**JIT)
def dense(xv, t, h, K, xs, fs, QC, VC):
    _state_dense(xv, t, h, K, xs, fs, QC, VC)
    head = velocity_data_pointer()  # the raw pointer, as the kernels read it
    per_degree = head[LD_RADIUS_AT] * (math.pi / 180.0) / head[LD_SCALE_AT]  # data velocity units per (degree per time unit)
    east = np.empty(DENSE_STAGES)
    for m in range(DENSE_STAGES):
        stage_state(xv, h, K, m, xs)
        east[m] = K[m, 0] * math.cos(xs[1] * (math.pi / 180.0)) * per_degree
    for k in range(1, NC):
        s = 0.0
        for m in range(DENSE_STAGES):
            s += G[k - 1, m] * east[m]
        VC[k - 1, 0, 0] = k * s
        VC[k - 1, 1, 0] *= per_degree


@njit(**JIT)
def step_ld(VC, theta, kind, p_exp, glx, glw, gjx, gjf, window, roots):
    value = _coordinate_step_ld(VC, theta, kind, p_exp, glx, glw, gjx, gjf, window, roots)
    if kind == KIND_ARCLENGTH:
        head = velocity_data_pointer()  # the raw pointer, as the kernels read it
        return value * head[LD_SCALE_AT] / 1000.0
    return value
