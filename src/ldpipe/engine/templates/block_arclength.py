"""Template: ``arclength_fast``, the vectorized arc-length quadrature over a block workspace.

``arclength_fast(W, glx, glw)`` writes FC[0, j] = the Gauss–Legendre value of
int_0^1 |v(x)| dx, |v|^2 the sum over the NCOMP velocity polynomials of VC, for every lane j
(``fast`` of block_quadrature.py calls it for the arc length; the integrand is smooth, so
there is no special path).

Four nodes at a time: one load of each coefficient feeds four independent Horner chains. One
node at a time, each lane's chain of NC dependent multiply-adds ran at their latency: measured
1.35x the cycles (order 18, 8 nodes; eight chains at a time spilled registers and ran 3x
slower). A node past the last has weight 0. The sums are taken in the node-by-node order, so
the values are the same to the bit as one node at a time.

Header names used: NC, NCOMP, LANES, CS and the offsets OVC, OFC, OACC and the scratch rows
OMIN, OMAX, OPRV, ORAT (here |v|^2 at the four nodes).
"""
# ruff: noqa: F821  (the upper-case constants, njit and JIT come from the generated header)


@njit(**JIT)
def arclength_fast(W, glx, glw):
    n_nodes = glx.shape[0]
    last = n_nodes - 1
    for j in range(LANES):
        W[OACC + j] = 0.0
    for g in range(0, n_nodes, 4):
        x0, x1, x2, x3 = glx[g], glx[min(g + 1, last)], glx[min(g + 2, last)], glx[min(g + 3, last)]
        w0 = glw[g]
        w1 = glw[g + 1] if g + 1 <= last else 0.0
        w2 = glw[g + 2] if g + 2 <= last else 0.0
        w3 = glw[g + 3] if g + 3 <= last else 0.0
        for j in range(LANES):
            W[OMIN + j] = 0.0
            W[OMAX + j] = 0.0
            W[OPRV + j] = 0.0
            W[ORAT + j] = 0.0
        for c in range(NCOMP):
            for j in range(LANES):
                base = OVC + c * LANES + j
                v0 = W[base + (NC - 1) * CS]
                v1 = v0
                v2 = v0
                v3 = v0
                for k in range(NC - 2, -1, -1):
                    a = W[base + k * CS]
                    v0 = v0 * x0 + a
                    v1 = v1 * x1 + a
                    v2 = v2 * x2 + a
                    v3 = v3 * x3 + a
                W[OMIN + j] += v0 * v0
                W[OMAX + j] += v1 * v1
                W[OPRV + j] += v2 * v2
                W[ORAT + j] += v3 * v3
        for j in range(LANES):
            W[OACC + j] += w0 * math.sqrt(W[OMIN + j])
            W[OACC + j] += w1 * math.sqrt(W[OMAX + j])
            W[OACC + j] += w2 * math.sqrt(W[OPRV + j])
            W[OACC + j] += w3 * math.sqrt(W[ORAT + j])
    for j in range(LANES):
        W[OFC + j] = W[OACC + j]
