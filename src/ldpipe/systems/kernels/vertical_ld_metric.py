# The closing section of the flow engine of 3-D velocity data on the sphere (ldpipe.systems.
# velocity_data.rectilinear, appended after kernels/sphere_ld_metric.py): the state is (lon, lat,
# z), and that section leaves the third component of VC as dz/dt in z units per time unit. This
# one rebinds ``dense`` to convert it to the vertical speed in the units of the data's u (header
# value 8: metres per z unit; 6: velocity_scale, metres per time unit per unit of u), so M_p sums
# |u|^p + |v|^p + |w|^p in one velocity unit and the arc length is sqrt(u^2 + v^2 + w^2), in km.
# ruff: noqa: F821  (the engine's functions, constants and the kernel's pointer come from the generated module)

_horizontal_dense = dense


@njit(**JIT)
def dense(xv, t, h, K, xs, fs, QC, VC):
    _horizontal_dense(xv, t, h, K, xs, fs, QC, VC)
    head = carray(velocity_data_pointer(), (GRID_HEADER,))
    per_z = head[8] / head[6]  # u's units per (z unit per time unit)
    for k in range(1, NC):
        VC[k - 1, 2, 0] *= per_z
