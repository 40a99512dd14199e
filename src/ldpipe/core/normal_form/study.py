"""A normal-form study at a list of energies: the flux by order, its truncation error and the NHIM points."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .flux import flux, nhim_points
from .saddle import EquilibriumNormalForm


@dataclass(frozen=True)
class FluxTable:
    """``by_order[i, j]``: the flux at ``excess[i]`` from K truncated at degree ``orders[j]``."""

    excess: np.ndarray
    orders: np.ndarray
    by_order: np.ndarray

    @property
    def flux(self) -> np.ndarray:
        return self.by_order[:, -1]

    @property
    def truncation_error(self) -> np.ndarray:
        """|flux at the order − flux at the even order below| (NaN with a single order)."""
        if self.by_order.shape[1] < 2:
            return np.full(len(self.excess), np.nan)
        return np.abs(self.by_order[:, -1] - self.by_order[:, -2])


def flux_table(nf: EquilibriumNormalForm, excess, *, method: str | None = None) -> FluxTable:
    """The flux at every excess energy and every even order ≤ the normal form's (actions for the full
    form, the centre-volume quadrature for the partial one, unless ``method`` says)."""
    method = method or ("actions" if nf.normalization.form == "full" else "volume")
    excess = np.asarray(excess, dtype=np.float64)
    orders = np.arange(2, nf.order + 1, 2)
    values = np.array([[flux(nf, float(e), method=method, order=int(o)) for o in orders] for e in excess])
    return FluxTable(excess=excess, orders=orders, by_order=values)


def nhim_samples(nf: EquilibriumNormalForm, excess, angles: int) -> np.ndarray:
    """NHIM points at each excess energy, shape (energies, points, 2n)."""
    nodes = 4
    return np.stack([nhim_points(nf, float(e), angles=angles, nodes=nodes) for e in np.atleast_1d(excess)])
