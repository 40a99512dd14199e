"""Template: ``map_fli``, the fast Lyapunov indicator of orbits of a map from its tangent map.

For each start x_0 (rows start..stop-1 of ``states``) a deviation vector w_0 (unit norm, equal
components) is carried along the orbit by the tangent map, w_{n+1} = Df(x_n) w_n, for
``iterations`` iterations, renormalized each time with its growth summed in logarithms; the FLI
is max_{n <= N} log10 |w_n| (Froeschlé, Lega and Gonczi 1997): it grows like log10 N along a
regular orbit (deviations grow linearly) and like N lambda / ln 10 along a chaotic one (lambda
its Lyapunov exponent). An orbit that escapes (``map_process``'s rule: an iterate not finite, or
past the ``radius`` in a coordinate that is not periodic) stops there, flagged.
"""
# ruff: noqa: F821  (the upper-case constants, njit, JIT, np and the kernels come from the generated module)


@njit(nogil=True, **JIT)
def map_fli(states, start, stop, iterations, radius, o_fli, o_escaped):
    x = np.empty(N)
    y = np.empty(N)
    w = np.empty(N)
    tangent = np.empty((N, N))
    for k in range(start, stop):
        for i in range(N):
            x[i] = states[k, i]
            w[i] = 1.0 / math.sqrt(N)
        growth = 0.0
        largest = 0.0
        escaped = False
        for _ in range(iterations):
            jacobian(x, tangent)
            norm = 0.0
            for i in range(N):
                y[i] = 0.0
                for j in range(N):
                    y[i] += tangent[i, j] * w[j]
                norm += y[i] * y[i]
            norm = math.sqrt(norm)
            if not math.isfinite(norm) or norm == 0.0:
                escaped = True
                break
            growth += math.log(norm)
            largest = max(largest, growth)
            for i in range(N):
                w[i] = y[i] / norm
            step(x, y)
            for i in range(N):
                value = y[i]
                if not math.isfinite(value):
                    escaped = True
                elif PERIODS[i] > 0.0:
                    value -= PERIODS[i] * math.floor(value / PERIODS[i])
                elif abs(value) > radius:
                    escaped = True
                x[i] = value
            if escaped:
                break
        o_fli[k] = largest / math.log(10.0)
        o_escaped[k] = escaped
