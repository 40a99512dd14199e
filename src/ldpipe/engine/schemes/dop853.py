"""The ``dop853`` scheme: Dormand–Prince 8(5,3), adaptive, generated as source.

DOP853 is generated as source with the tableau (:mod:`ldpipe.engine.schemes.tableaux`) written in as
literals (zero entries dropped), one fused loop per stage, in Nyström form (the step forms no
stage momenta; see :func:`nystrom_form`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from . import tableaux
from ..stepping import Layout, SchemeSource, lane_loops
from .base import AdaptiveScheme


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
        *lane_loops("qpoly(W)", n, B),
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


@dataclass(frozen=True)
class Dop853(AdaptiveScheme):
    """Dormand–Prince 8(5,3) with per-trajectory step control."""

    def nodes(self, settings) -> int:
        """4 at rtol >= 1e-5, else 8.

        At rtol 1e-4 and 1e-5 the LD error of dop853 is the trajectory's: 4 nodes instead of 8
        left the median and worst errors against the benchmark reference unchanged (within
        3 %) and were 10-15 % faster; at 1e-6 and tighter 6 nodes already raised the errors.
        """
        return 4 if settings.rtol >= 1e-5 else 8

    def source(self, system, lanes: int, order: int | None = None) -> SchemeSource:
        layout = Layout.build(system.n_dof, lanes, 8, 16)
        return SchemeSource(layout, True, self.order, source=dop853_source(layout))


DOP853 = Dop853(
    name="dop853",
    description="adaptive 8th order, per-trajectory step control (rtol, atol)",
    order=tableaux.DOP853_ORDER,
    ladder=(1e-4, 1e-5, 1e-6, 1e-7, 1e-8, 1e-9, 1e-10, 1e-11, 1e-12),
    general_flow=True,  # first-order form: ldpipe.engine.vector_field
)
