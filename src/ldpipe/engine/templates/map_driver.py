"""Template: ``map_process``, the discrete LD of orbits of a map x_{n+1} = f(x_n).

For each start x_0 (rows start..stop-1 of ``states``) it iterates the map ``iterations`` times
(``step``, or ``inverse`` when ``backward``) and sums M_p = sum_n sum_i |x^i_{n+1} - x^i_n|^p
(Lopesino et al. 2015), one half of the LD. A periodic coordinate (``PERIODS[i] > 0``) is kept
in [0, period) and its increment is taken on the circle, wrapped into [-period/2, period/2).
An orbit escapes when an iterate is not finite or a coordinate that is not periodic passes the
escape ``radius``: the sum stops at the last iterate inside, and ``o_iterations`` says how many
iterations it holds (a start beyond the radius: none).
"""
# ruff: noqa: F821  (the upper-case constants, njit, JIT, np and the kernels come from the generated module)


@njit(nogil=True, **JIT)
def map_process(states, start, stop, iterations, p, radius, backward, o_ld, o_iterations, o_escaped, o_end):
    x = np.empty(N)
    y = np.empty(N)
    for k in range(start, stop):
        escaped = False
        for i in range(N):
            x[i] = states[k, i]
            if not math.isfinite(x[i]) or (PERIODS[i] == 0.0 and abs(x[i]) > radius):
                escaped = True
        total = 0.0
        done = 0
        while not escaped and done < iterations:
            if backward:
                inverse(x, y)
            else:
                step(x, y)
            increment = 0.0
            for i in range(N):
                value = y[i]
                if not math.isfinite(value):
                    escaped = True
                    break
                period = PERIODS[i]
                if period > 0.0:
                    value -= period * math.floor(value / period)
                    if value >= period:  # a tiny negative value rounds to the period itself
                        value -= period
                    difference = value - x[i]
                    difference -= period * math.floor(difference / period + 0.5)
                elif abs(value) > radius:
                    escaped = True
                    break
                else:
                    difference = value - x[i]
                y[i] = value
                if p == 0.5:  # the default exponent: a square root costs a fraction of a power
                    increment += math.sqrt(abs(difference))
                elif p == 1.0:
                    increment += abs(difference)
                else:
                    increment += abs(difference) ** p
            if escaped:
                break
            total += increment
            done += 1
            for i in range(N):
                x[i] = y[i]
        o_ld[k] = total
        o_iterations[k] = done
        o_escaped[k] = escaped
        for i in range(N):
            o_end[k, i] = x[i]
