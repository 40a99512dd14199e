"""Block stepping: the workspace layout, and what the code generator needs of a scheme.

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
    (q', p') = (p, a(q)), k = 0..nc-1. (With masses the p carried is M^-1 p, a = -M^-1 grad V,
    and the kinetic section turns the p' rows into M a: :mod:`ldpipe.engine.kinetic`.)
``qpoly(W)``
    the configuration polynomials ``QC[k, i, j]`` of the same step (for event location),
    from what ``attempt`` left in the workspace.

The workspace ends, after its regions (at ``SIZE``), with the scheme's run-time coefficients
(:meth:`ldpipe.engine.schemes.Scheme.coefficients`, which the LD driver appends: a
composition's weights; none for the other schemes).

The schemes themselves, one module each, and the registry that names them are in
:mod:`ldpipe.engine.schemes`.
"""

from __future__ import annotations

from dataclasses import dataclass, field


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


def lane_loops(signature: str, rows: int, lanes: int) -> list[str]:
    """Source lines that open a generated block function ``def SIGNATURE:`` (compiled with the
    engine's ``JIT`` options) with its loops over rows ``i`` and lanes ``j``, the lane innermost so
    that LLVM vectorizes across trajectories; the body follows at eight spaces."""
    return [
        "@njit(**JIT)",
        f"def {signature}:",
        f"    for i in range({rows}):",
        f"      for j in range({lanes}):",
    ]
