"""Template: the counter-based random numbers of the stochastic engine, Philox4x64-10.

Philox (Salmon, Moraes, Dror and Shaw, "Parallel random numbers: as easy as 1, 2, 3", SC11) is
a keyed bijection of a 256-bit counter: the numbers of a draw depend on its key and counter
alone, never on which draws came before, so a trajectory's noise is the same whatever thread,
batch or tile computes it. This is the variant numpy names ``numpy.random.Philox`` (four
64-bit words, ten rounds); its raw output for a key and counter equals numpy's for that key and
the counter one before (numpy increments its counter before each block of four).

``normals(key0, key1, c0, c1, c2, c3, out, pairs)`` writes four (or two) standard normal
numbers: the four words made uniforms on the open interval (0, 1) with 53 bits each, then the
Box-Muller transform on two pairs (or the first). Header names used: njit, JIT, math, np.
"""
# ruff: noqa: F821  (njit, JIT, math and np come from the generated header)

PHILOX_M0 = np.uint64(0xD2E7470EE14C6C93)
PHILOX_M1 = np.uint64(0xCA5A826395121157)
PHILOX_W0 = np.uint64(0x9E3779B97F4A7C15)
PHILOX_W1 = np.uint64(0xBB67AE8584CAA73B)
LOW32 = np.uint64(0xFFFFFFFF)
SHIFT32 = np.uint64(32)
SHIFT11 = np.uint64(11)
TWO_TO_MINUS_53 = 1.0 / 9007199254740992.0
TWO_PI = 2.0 * math.pi


@njit(**JIT)
def mulhilo64(a, b):
    """The high and low 64-bit words of the 128-bit product a * b (in 32-bit halves: numba has no
    128-bit integers)."""
    a_lo = a & LOW32
    a_hi = a >> SHIFT32
    b_lo = b & LOW32
    b_hi = b >> SHIFT32
    lo_lo = a_lo * b_lo
    lo_hi = a_lo * b_hi
    hi_lo = a_hi * b_lo
    middle = (lo_lo >> SHIFT32) + (lo_hi & LOW32) + (hi_lo & LOW32)
    high = a_hi * b_hi + (lo_hi >> SHIFT32) + (hi_lo >> SHIFT32) + (middle >> SHIFT32)
    return high, a * b


@njit(**JIT)
def philox4x64(key0, key1, c0, c1, c2, c3):
    """Philox4x64 with ten rounds: the four words of counter (c0, c1, c2, c3) under key (key0, key1)."""
    for r in range(10):
        if r > 0:
            key0 = key0 + PHILOX_W0
            key1 = key1 + PHILOX_W1
        hi0, lo0 = mulhilo64(PHILOX_M0, c0)
        hi1, lo1 = mulhilo64(PHILOX_M1, c2)
        c0, c1, c2, c3 = hi1 ^ c1 ^ key0, lo1, hi0 ^ c3 ^ key1, lo0
    return c0, c1, c2, c3


@njit(**JIT)
def open_uniform(word):
    """The top 53 bits of ``word`` as a number in (0, 1): never 0, so its logarithm is finite."""
    return (float(word >> SHIFT11) + 0.5) * TWO_TO_MINUS_53


@njit(**JIT)
def normals(key0, key1, c0, c1, c2, c3, out, pairs):
    """Independent standard normal numbers into ``out[0:2 pairs]`` (``pairs`` 1 or 2) from one
    Philox block: the first pair from its words 0 and 1, the second from 2 and 3 (a caller that
    needs two numbers skips the second transform; the first two are the same either way)."""
    w0, w1, w2, w3 = philox4x64(key0, key1, c0, c1, c2, c3)
    r = math.sqrt(-2.0 * math.log(open_uniform(w0)))
    angle = TWO_PI * open_uniform(w1)
    out[0] = r * math.cos(angle)
    out[1] = r * math.sin(angle)
    if pairs > 1:
        r = math.sqrt(-2.0 * math.log(open_uniform(w2)))
        angle = TWO_PI * open_uniform(w3)
        out[2] = r * math.cos(angle)
        out[3] = r * math.sin(angle)


@njit(nogil=True, **JIT)
def stream_normals(key0, key1, block0, blocks, c1, c2, c3, out):
    """``4 * blocks`` normal numbers of counters (block0 + b, c1, c2, c3), b = 0 .. blocks - 1, into
    ``out`` (tests and benchmarks read a trajectory's stream with it)."""
    for b in range(blocks):
        normals(key0, key1, block0 + np.uint64(b), c1, c2, c3, out[4 * b:4 * b + 4], 2)


@njit(nogil=True, **JIT)
def stream_sums(key0, key1, c1, members, c3, steps, n_noise, out):
    """The sum over ``steps`` steps of each of a path's ``n_noise`` normal numbers, for members
    0 .. members - 1 of trajectory c1 in direction word c3, into ``out[member, 0:n_noise]``: a path's
    Brownian motion at its end is sqrt(h) times it."""
    blocks = (n_noise + 3) // 4
    xi = np.zeros(4 * blocks)
    for m in range(members):
        for j in range(n_noise):
            out[m, j] = 0.0
        for s in range(steps):
            for b in range(blocks):
                normals(key0, key1, np.uint64(s * blocks + b), c1, np.uint64(m), c3, xi[4 * b:4 * b + 4], 2)
            for j in range(n_noise):
                out[m, j] += xi[j]


@njit(nogil=True, **JIT)
def raw_blocks(key0, key1, block0, blocks, c1, c2, c3, out):
    """The raw Philox words of counters (block0 + b, c1, c2, c3) into ``out[b, 0:4]``."""
    for b in range(blocks):
        w0, w1, w2, w3 = philox4x64(key0, key1, block0 + np.uint64(b), c1, c2, c3)
        out[b, 0] = w0
        out[b, 1] = w1
        out[b, 2] = w2
        out[b, 3] = w3
