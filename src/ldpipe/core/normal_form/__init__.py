"""The normal form of an equilibrium (an index-1 saddle, or a minimum), by Lie series on dense polynomial arrays.

``polynomials`` (the algebra), ``expansion`` (H's Taylor coefficients and the symplectic normal
modes), ``lie`` (the normalization and its coordinate changes), ``saddle`` (all of them chained
for one equilibrium), ``flux`` (the flux, the NHIM and the dividing surface from a normal form).
"""

from .flux import centre_action_at, dividing_surface_points, flux, lyapunov_orbit_points, nhim_points
from .lie import FORMS, Normalization, normalize
from .polynomials import MonomialBasis
from .saddle import EquilibriumNormalForm, equilibrium_normal_form, system_normal_form

__all__ = [
    "FORMS", "EquilibriumNormalForm", "MonomialBasis", "Normalization", "centre_action_at",
    "dividing_surface_points", "equilibrium_normal_form", "flux", "lyapunov_orbit_points", "nhim_points", "normalize", "system_normal_form",
]
