"""Block stepping schemes: workspace layout, and the source of one step attempt per scheme.

All per-lane data of a block lives in one flat float64 *workspace* ``W`` whose regions (the
state, the stages, the polynomial coefficients, ...) sit at offsets fixed at compile time;
:class:`Layout` lists them. A region of r rows holds entry (row, lane) at
``offset + row * lanes + lane``. The lane index is innermost in every loop so that LLVM
vectorizes across trajectories, and because every access goes through the same base pointer
with constant offsets, the vectorizer needs no runtime alias checks (with a dozen separate
numpy arrays it gives up and emits scalar code). Each lane has its own signed step
``h[j]``; a lane with ``h[j] == 0`` is idle and its values stay finite and unchanged.

Every scheme provides, as compiled code (:class:`SchemeSource`; assembled and compiled by
:mod:`ldpipe.engine.codegen`):

``attempt(W, rtol, atol)``
    one step from (q, p) with acc = a(q) to (qn, pn), accn = a(qn), the scaled error
    estimate ``err`` (0 for fixed-step schemes), and the velocity polynomials
    ``VC[k, c, j]`` in x = (t - t0)/h of the 2 n_dof phase-space velocity components
    (q', p') = (p, a(q)), k = 0..nc-1.
``qpoly(W)``
    the configuration polynomials ``QC[k, i, j]`` of the same step (for event location),
    from what ``attempt`` left in the workspace.

DOP853 is generated as source with the tableau written in as literals (zero entries dropped),
one fused loop per stage, in Nyström form (the step forms no stage momenta; see
:func:`nystrom_form`). The fixed-step schemes are templates (``templates/rk4.py``,
``templates/composition.py``) and take their dense output from the quintic Hermite
interpolant of q through (q, p, a) at both ends of the step (``templates/hermite.py``).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .. import tableaux
from . import taylor

SCHEMES = ("dop853", "taylor", "rk4", "sym4", "sym6")


@dataclass(frozen=True)
class Layout:
    """Offsets of the regions of the block workspace (see the module docstring).

    The regions are named as the compiled code names their offsets: ``OQ`` (q), ``OP`` (p),
    ``OA`` (acc = a(q)), ``OQN``, ``OPN``, ``OAN`` (the same at the step end), ``OQS`` (stage
    configuration), ``OMQ`` (mean velocity), ``OH`` (signed step), ``OERR``, ``OE3`` (error
    estimates), ``OSP``, ``OSA`` (stage momenta and accelerations, ``stages * n`` rows each),
    ``OVC``, ``OQC`` (velocity and configuration polynomials), ``OFC`` (per-component LD of
    the step) and ``OMIN``, ``OMAX``, ``OACC``, ``OPRV``, ``ORAT``, ``OCRV`` (scratch rows of the quadrature).
    """

    n: int  # degrees of freedom
    lanes: int
    nc: int  # coefficients per polynomial
    stages: int  # rows of OSP and OSA are stages * n
    offsets: dict = field(default_factory=dict)
    size: int = 0

    @classmethod
    def build(cls, n: int, lanes: int, nc: int, stages: int, series: int = 0) -> "Layout":
        rows = {
            "OQ": n, "OP": n, "OA": n, "OQN": n, "OPN": n, "OAN": n, "OQS": n, "OMQ": n,
            "OH": 1, "OERR": 1, "OE3": 1,
            "OSP": stages * n, "OSA": stages * n,
            "OVC": nc * 2 * n, "OQC": nc * n, "OFC": 2 * n,
            "OMIN": 1, "OMAX": 1, "OACC": 1, "OPRV": 1, "ORAT": 1, "OCRV": 1,
            "OTS": series,
        }  # fmt: skip
        offsets = {}
        position = 0
        for name, r in rows.items():
            offsets[name] = position
            position += r * lanes
        return cls(n, lanes, nc, stages, offsets, position)

    def __getattr__(self, name):
        offsets = object.__getattribute__(self, "offsets")
        if name in offsets:
            return offsets[name]
        raise AttributeError(name)

    def constants(self) -> dict[str, int]:
        """The compile-time constants of the layout, by the names the compiled code uses."""
        n, lanes = self.n, self.lanes
        sizes = {
            "N": n,  # degrees of freedom
            "LANES": lanes,
            "NCOMP": 2 * n,  # phase-space velocity components
            "NC": self.nc,  # coefficients per polynomial
            "NB": n * lanes,  # stride of n rows (coefficients in QC, stages in OSP/OSA)
            "CS": 2 * n * lanes,  # stride between coefficients in VC
            "SIZE": self.size,
        }
        return {**sizes, **self.offsets}


@dataclass(frozen=True)
class SchemeSource:
    """What the code generator needs of a scheme.

    ``templates`` are the template modules (``templates/<name>.py``) that define ``attempt``
    and ``qpoly``, ``source`` generated code appended after them, ``constants`` header
    constants beyond the layout's. ``self_sized``: ``attempt`` chooses the step itself (it
    may shorten the requested ``h``, never lengthen it) and never needs a rejection.
    """

    layout: Layout
    adaptive: bool
    order: int
    self_sized: bool = False
    templates: tuple[str, ...] = ()
    source: str = ""
    constants: dict = field(default_factory=dict)


# ---------------------------------------------------------------------------------------------
# DOP853: generated source
# ---------------------------------------------------------------------------------------------
def _combination(coefficients, base: int, stride: int) -> str:
    """sum_m c_m W[base + m * stride + k] over the nonzero c_m, as source."""
    terms = [f"{float(c)!r} * W[{base + m * stride} + k]" for m, c in enumerate(coefficients) if c != 0.0]
    return " + ".join(terms) if terms else "0.0"


def nystrom_form(A: np.ndarray, C: np.ndarray, E3: np.ndarray, E5: np.ndarray) -> dict:
    """DOP853 for q' = p, p' = a(q), rewritten so that the step forms no stage momentum.

    Stage m of the first-order method is Q_m = q + h sum_l A[m,l] P_l, P_l = p + h sum_k
    A[l,k] A_k. With the row sums sum_l A[m,l] = C[m] this is Q_m = q + C[m] h p + h^2
    sum_k (A A)[m,k] A_k: a Runge–Kutta–Nyström form of the same method (Hairer, Nørsett &
    Wanner I, sec. II.14), exact in exact arithmetic, that needs one linear combination per
    stage instead of two. Every other use of the P_l is linear and is rewritten the same way:
    the error estimators sum_l E_l P_l = h sum_k (E A)_k A_k (their weights sum to zero, the
    p term cancels). The weight sums that are zero in exact arithmetic are below 1e-12 in the
    tabulated coefficients (checked here) and dropped. (The dense output of q, used only to
    locate events, keeps the stage momenta: see ``dop853_source``.) The products of
    coefficients are formed exactly and rounded once.
    """
    row_sums = A.sum(axis=1)
    if np.max(np.abs(row_sums - C)) > 1e-14:
        raise ValueError("DOP853 tableau: row sums of A differ from C")
    for name, e in (("E3", E3), ("E5", E5)):
        if abs(e.sum()) > 1e-12:
            raise ValueError(f"DOP853 tableau: the weights of {name} do not sum to zero")
    return {
        "AA": _exact_product(A, A),  # stage configurations
        "C": row_sums,
        "E3A": _exact_product(E3[None, :], A[: len(E3)])[0],  # error estimators of q
        "E5A": _exact_product(E5[None, :], A[: len(E5)])[0],
    }


def _exact_product(left: np.ndarray, right: np.ndarray) -> np.ndarray:
    """left @ right computed exactly from the float entries (fractions), rounded once.

    Exact products keep the generated coefficients independent of the summation order of a
    float64 matrix product.
    """
    from fractions import Fraction

    rows, inner = left.shape
    columns = right.shape[1]
    out = np.zeros((rows, columns))
    left_f = [[Fraction(float(v)) for v in row] for row in left]
    right_f = [[Fraction(float(v)) for v in row] for row in right]
    for i in range(rows):
        for j in range(columns):
            out[i, j] = float(sum((left_f[i][k] * right_f[k][j] for k in range(inner)), Fraction(0)))
    return out


def dop853_source(L: Layout) -> str:
    """Source of ``attempt`` and ``qpoly`` for DOP853 with workspace layout L.

    The method in Nyström form (:func:`nystrom_form`): stage m has the configuration
    Q_m = q + C[m] h p + h^2 sum_k AA[m,k] A_k and the acceleration A_m = a(Q_m), stored as
    rows m*n..m*n+n-1 of the region OSA; stage 12 is the new point (FSAL; its momentum is
    p + h sum_k A[12,k] A_k) and stages 13-15 serve the dense output only. Loops run over the
    rows i and, innermost, the lanes j; k = i * lanes + j. Offsets are written in as numbers.
    """
    A, G = tableaux.A, tableaux.DOP853_DENSE
    nf = nystrom_form(A, tableaux.C, tableaux.E3, tableaux.E5)
    AA, C, E3A, E5A = nf["AA"], nf["C"], nf["E3A"], nf["E5A"]
    n, B = L.n, L.lanes
    NB = n * B
    lines = [
        "@njit(**JIT)",
        "def attempt(W, rtol, atol):",
        f"    for k in range({NB}):",
        f"        W[{L.OSA} + k] = W[{L.OA} + k]",
    ]
    for m in range(1, 16):
        target = L.OQN if m == 12 else L.OQS
        lines += [
            f"    for i in range({n}):",
            f"      for j in range({B}):",
            f"        k = i * {B} + j",
            f"        hj = W[{L.OH} + j]",
            f"        W[{target} + k] = W[{L.OQ} + k] + hj * ({float(C[m])!r} * W[{L.OP} + k] "
            f"+ hj * ({_combination(AA[m, :m], L.OSA, NB)}))",
        ]
        if m == 12:
            lines += [
                f"        W[{L.OPN} + k] = W[{L.OP} + k] + hj * ({_combination(A[12, :12], L.OSA, NB)})",
                f"    acceleration_block(W[{L.OQN}:{L.OQN + NB}].reshape(({n}, {B})), "
                f"W[{L.OSA + 12 * NB}:{L.OSA + 13 * NB}].reshape(({n}, {B})), {B})",
                # Error estimate: Hairer's combination of the 5th- and 3rd-order estimators.
                f"    for j in range({B}):",
                f"        W[{L.OERR} + j] = 0.0",
                f"        W[{L.OE3} + j] = 0.0",
                f"    for i in range({n}):",
                f"      for j in range({B}):",
                f"        k = i * {B} + j",
                f"        hj = W[{L.OH} + j]",
                f"        sq = atol + rtol * max(abs(W[{L.OQ} + k]), abs(W[{L.OQN} + k]))",
                f"        sp = atol + rtol * max(abs(W[{L.OP} + k]), abs(W[{L.OPN} + k]))",
                f"        e5q = hj * ({_combination(E5A, L.OSA, NB)}) / sq",
                f"        e3q = hj * ({_combination(E3A, L.OSA, NB)}) / sq",
                f"        e5p = ({_combination(tableaux.E5, L.OSA, NB)}) / sp",
                f"        e3p = ({_combination(tableaux.E3, L.OSA, NB)}) / sp",
                f"        W[{L.OERR} + j] += e5q * e5q + e5p * e5p",
                f"        W[{L.OE3} + j] += e3q * e3q + e3p * e3p",
                f"    for j in range({B}):",
                f"        e5 = W[{L.OERR} + j]",
                f"        denominator = max(e5 + 0.01 * W[{L.OE3} + j], 1e-300)",
                f"        W[{L.OERR} + j] = abs(W[{L.OH} + j]) * e5 / math.sqrt(denominator * {2 * n}.0)",
            ]
        else:
            lines.append(
                f"    acceleration_block(W[{L.OQS}:{L.OQS + NB}].reshape(({n}, {B})), "
                f"W[{L.OSA + m * NB}:{L.OSA + (m + 1) * NB}].reshape(({n}, {B})), {B})"
            )
    # Velocity polynomials: with s_k = sum_m G[k-1, m] A_m, p(x) = p + h sum_k s_k x^k, and
    # p'(x)/h = sum_k k s_k x^(k-1).
    NCB = 2 * NB  # stride between coefficients of VC
    lines += [
        f"    for i in range({n}):",
        f"      for j in range({B}):",
        f"        k = i * {B} + j",
        f"        W[{L.OAN} + k] = W[{L.OSA + 12 * NB} + k]",
        f"        hj = W[{L.OH} + j]",
        f"        vq = {L.OVC} + k",
        f"        vp = {L.OVC + NB} + k",
        f"        W[vq] = W[{L.OP} + k]",
    ]
    for k in range(1, 8):
        lines += [
            f"        s = {_combination(G[k - 1], L.OSA, NB)}",
            f"        W[vq + {k * NCB}] = hj * s",
            f"        W[vp + {(k - 1) * NCB}] = {k}.0 * s",
        ]
    lines.append(f"        W[vp + {7 * NCB}] = 0.0")
    # Configuration polynomial (for event location only): q(x) = q + h sum_k x^k G[k-1] . P
    # with the stage momenta P_l = p + h sum_m A[l,m] A_m formed here, in region OSP. (The
    # Nyström form h p x + h^2 sum_k (G A)[k-1] . A x^k is the same polynomial, but its
    # coefficients reach ~5000 and its value at x = 1 missed q_n by ~4e-12; this one by ~1e-13.)
    lines += [
        "",
        "",
        "@njit(**JIT)",
        "def qpoly(W):",
        f"    for i in range({n}):",
        f"      for j in range({B}):",
        f"        k = i * {B} + j",
        f"        hj = W[{L.OH} + j]",
        f"        W[{L.OSP} + k] = W[{L.OP} + k]",
    ]
    for m in range(1, 16):
        lines.append(f"        W[{L.OSP + m * NB} + k] = W[{L.OP} + k] + hj * ({_combination(A[m, :m], L.OSA, NB)})")
    lines.append(f"        W[{L.OQC} + k] = W[{L.OQ} + k]")
    for k in range(1, 8):
        lines.append(f"        W[{L.OQC + k * NB} + k] = hj * ({_combination(G[k - 1], L.OSP, NB)})")
    return "\n".join(lines) + "\n"


def scheme_source(scheme: str, system, lanes: int, order: int | None = None) -> SchemeSource:
    """The compiled parts of ``scheme`` for ``system`` and ``lanes`` lanes.

    ``order``: the Taylor scheme's order (required for it, ignored by the others).
    """
    n_dof = system.n_dof
    if scheme == "taylor":
        if order is None:
            raise ValueError("scheme 'taylor': the order must be given")
        acceleration = taylor.acceleration_of(system)
        rows = taylor.series_rows(n_dof, order, len(acceleration.products))
        layout = Layout.build(n_dof, lanes, order + 2, 0, series=rows)
        return SchemeSource(layout, True, order, source=taylor.taylor_source(layout, acceleration, order), self_sized=True)
    if scheme == "dop853":
        layout = Layout.build(n_dof, lanes, 8, 16)
        return SchemeSource(layout, True, tableaux.DOP853_ORDER, source=dop853_source(layout))
    if scheme == "rk4":
        return SchemeSource(Layout.build(n_dof, lanes, 6, 4), False, 4, templates=("hermite", "rk4"))
    if scheme in tableaux.COMPOSITIONS:
        weights = np.array(tableaux.COMPOSITIONS[scheme], dtype=np.float64)
        return SchemeSource(
            Layout.build(n_dof, lanes, 6, 0),
            False,
            tableaux.COMPOSITION_ORDERS[scheme],
            templates=("hermite", "composition"),
            constants={"N_SUB": len(weights), "GAMMAS": weights},
        )
    raise ValueError(f"scheme: unknown scheme {scheme!r}; expected one of {list(SCHEMES)}")
