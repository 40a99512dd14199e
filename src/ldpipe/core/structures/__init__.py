"""Structures in maps: the LD's singular curves and the FTLE's ridges as polylines (``ridges``,
``curves``), their distance to reference curves (``compare``), and the finite-size Lyapunov
exponent (``fsle``)."""

from .compare import curve_distances, distance_to_polylines
from .curves import curves_of, structures_dataset
from .ridges import Curve, ridge_curves

__all__ = ["Curve", "curve_distances", "curves_of", "distance_to_polylines", "ridge_curves", "structures_dataset"]
