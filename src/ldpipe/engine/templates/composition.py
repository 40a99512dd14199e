"""Template: one step attempt of a symmetric composition of kick-drift-kick Störmer–Verlet.

Sub-step s has the weight g = W[SIZE + s], the scheme's run-time coefficients that the driver
puts at the end of the workspace (one module serves every set of weights, summing to 1):
kick by g h a / 2, drift by g h p, a = a(q), kick by g h a / 2; the last force of a sub-step is
the first of the next (and, at the end, ``accn``). ``mq`` accumulates the mean velocity
(qn - q)/h for the Hermite dense output (hermite.py). Header names used: N, LANES, NB, SIZE and
the offsets OQ, OP, OA, OQN, OPN, OAN, OMQ, OH, OERR.
"""
# ruff: noqa: F821  (the upper-case constants, njit, JIT and the kernels come from the generated module)


@njit(**JIT)
def attempt(W, rtol, atol):
    for i in range(N):
        for j in range(LANES):
            k = i * LANES + j
            W[OQN + k] = W[OQ + k]
            W[OPN + k] = W[OP + k]
            W[OAN + k] = W[OA + k]
            W[OMQ + k] = 0.0
    qn = W[OQN : OQN + NB].reshape((N, LANES))
    an = W[OAN : OAN + NB].reshape((N, LANES))
    for s in range(SIZE, W.shape[0]):
        g = W[s]
        for i in range(N):
            for j in range(LANES):
                k = i * LANES + j
                kick = W[OPN + k] + 0.5 * g * W[OH + j] * W[OAN + k]
                W[OPN + k] = kick
                W[OQN + k] += g * W[OH + j] * kick
                W[OMQ + k] += g * kick
        acceleration_block(qn, an, LANES)
        for i in range(N):
            for j in range(LANES):
                k = i * LANES + j
                W[OPN + k] += 0.5 * g * W[OH + j] * W[OAN + k]
    for j in range(LANES):
        W[OERR + j] = 0.0
    velocities(W)
