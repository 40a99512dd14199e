"""Template: ``variational_ld``, the arc-length LD of a natural Hamiltonian's trajectory with its
exact gradient with respect to the start, and the trajectory's deviation-vector indicators.

Along x(t) (x = (q, p), f(x) = (W p, -grad V(q)), W = M^-1 the constant ``INV``) the augmented
system

    dx/dt = f(x),   dPhi/dt = Df(x) Phi,   dL/dt = |f(x)|,   dG/dt = f(x)^T Df(x) Phi / |f(x)|

(Df = [[0, W], [-Hess V, 0]], Phi(0) = I, L(0) = 0, G(0) = 0) gives the LD L = int_0^tau |f| dt
and its gradient G = dL/dx_0: the derivative of the integrand |f(x(t; x_0))| by the chain rule
through the tangent map Phi = dx(t)/dx_0. Backward in time L and G grow by |dt| (their rates
take the step's sign). It is integrated by the classical Runge-Kutta method of
order four with ``steps`` equal steps of ``h`` (negative backward in time): a Runge-Kutta method
applied to the augmented system is the same method applied to the trajectory and then
differentiated, so G is the exact gradient of the computed L. The arc length's integrand is
smooth wherever f != 0 (no cusp where one component of f changes sign, unlike |f_i|^p with
p <= 1), which is why the gradient is offered for it.

From the same Phi, with two fixed orthonormal deviation vectors u_1, u_2: the fast Lyapunov
indicator FLI = max over the steps of log10 |Phi u_1| (Froeschle, Lega and Gonczi 1997) and the
smaller alignment index SALI = min over the steps of min(|w_1 + w_2|, |w_1 - w_2|), w_k =
Phi u_k / |Phi u_k| (Skokos 2001). A trajectory whose state leaves the escape ``radius`` (any
|q_i|) or whose augmented state is not finite stops there, flagged; its values are those of the
last step inside.
"""
# ruff: noqa: F821  (the upper-case constants, njit, JIT, np and the kernels come from the generated module)


@njit(**JIT)
def variational_rhs(y, out, grad, hess, df, sense):
    # y = (x [D], Phi [D*D, row major], L, G [D]) with D = 2 N_DOF; ``sense`` the sign of the step, so
    # that L and G grow by |h| |f| backward in time too
    for i in range(N_DOF):
        grad[i] = 0.0
    gradient(y[:N_DOF], grad)
    hessian(y[:N_DOF], hess)
    for i in range(D):
        for j in range(D):
            df[i, j] = 0.0
    for i in range(N_DOF):
        value = 0.0
        for j in range(N_DOF):
            value += INV[i, j] * y[N_DOF + j]
            df[i, N_DOF + j] = INV[i, j]
            df[N_DOF + i, j] = -hess[i, j]
        out[i] = value
        out[N_DOF + i] = -grad[i]
    speed = 0.0
    for i in range(D):
        speed += out[i] * out[i]
    speed = math.sqrt(speed)
    for i in range(D):
        for j in range(D):
            value = 0.0
            for k in range(D):
                value += df[i, k] * y[D + k * D + j]
            out[D + i * D + j] = value
    out[D + D * D] = sense * speed
    for j in range(D):
        out[D + D * D + 1 + j] = 0.0
    if speed > 0.0:
        for k in range(D):
            weight = 0.0
            for i in range(D):
                weight += out[i] * df[i, k]
            weight *= sense / speed
            for j in range(D):
                out[D + D * D + 1 + j] += weight * y[D + k * D + j]


@njit(**JIT)
def deviation_indicators(y, u1, u2):
    """log10 |Phi u1| and min(|w1 + w2|, |w1 - w2|) of the unit vectors w_k along Phi u_k."""
    a = np.zeros(D)
    b = np.zeros(D)
    for i in range(D):
        for j in range(D):
            a[i] += y[D + i * D + j] * u1[j]
            b[i] += y[D + i * D + j] * u2[j]
    n1 = math.sqrt(np.sum(a * a))
    n2 = math.sqrt(np.sum(b * b))
    plus = 0.0
    minus = 0.0
    for i in range(D):
        plus += (a[i] / n1 + b[i] / n2) ** 2
        minus += (a[i] / n1 - b[i] / n2) ** 2
    return math.log10(n1), min(math.sqrt(plus), math.sqrt(minus))


@njit(nogil=True, **JIT)
def variational_ld(states, start, stop, h, steps, radius, u1, u2,
                   o_ld, o_gradient, o_fli, o_sali, o_escaped, o_time):
    size = D + D * D + 1 + D
    y = np.empty(size)
    trial = np.empty(size)
    k1 = np.empty(size)
    k2 = np.empty(size)
    k3 = np.empty(size)
    k4 = np.empty(size)
    grad = np.empty(N_DOF)
    hess = np.empty((N_DOF, N_DOF))
    df = np.empty((D, D))
    sense = 1.0 if h > 0 else -1.0
    for t in range(start, stop):
        for i in range(size):
            y[i] = 0.0
        for i in range(D):
            y[i] = states[t, i]
            y[D + i * D + i] = 1.0
        fli = 0.0
        sali = math.sqrt(2.0)
        escaped = False
        done = 0
        for _ in range(steps):
            variational_rhs(y, k1, grad, hess, df, sense)
            for i in range(size):
                trial[i] = y[i] + 0.5 * h * k1[i]
            variational_rhs(trial, k2, grad, hess, df, sense)
            for i in range(size):
                trial[i] = y[i] + 0.5 * h * k2[i]
            variational_rhs(trial, k3, grad, hess, df, sense)
            for i in range(size):
                trial[i] = y[i] + h * k3[i]
            variational_rhs(trial, k4, grad, hess, df, sense)
            finite = True
            outside = False
            for i in range(size):
                trial[i] = y[i] + h / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i])
                if not math.isfinite(trial[i]):
                    finite = False
            for i in range(N_DOF):
                if abs(trial[i]) > radius:
                    outside = True
            if not finite or outside:
                escaped = True
                break
            for i in range(size):
                y[i] = trial[i]
            done += 1
            growth, alignment = deviation_indicators(y, u1, u2)
            fli = max(fli, growth)
            sali = min(sali, alignment)
        o_ld[t] = y[D + D * D]
        for i in range(D):
            o_gradient[t, i] = y[D + D * D + 1 + i]
        o_fli[t] = fli
        o_sali[t] = sali
        o_escaped[t] = escaped
        o_time[t] = done * abs(h)
