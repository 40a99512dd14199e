"""Points of the NHIM on a two-dimensional section: detection on an LD map, refinement below the grid.

On an isoenergetic section through the saddle region, the stable manifold of the
NHIM cuts a curve W^s (where the forward, variable-time LD has a ridge: those
points never leave the saddle region forward in time) and the unstable manifold
a curve W^u (the backward LD's ridge). The NHIM's points on the section are
where the two curves cross; for 2 DoF that is the unstable periodic orbit's
crossing of the section.

* **Detection** (:func:`detect_nhim_cell`). A grid point on W^s that happens to
  lie very close to it carries a spike of forward LD (the LD grows like
  log(1/distance)), and the plain global maximum of ld_forward + ld_backward can
  land on such a spike far from W^u. A point of the NHIM must be high in *both*
  fields, so the criterion is the largest ``min(F / F_ridge, B / B_ridge)``, each
  field in units of its typical ridge height (the median of the per-row maxima,
  which spikes barely move): a spike on one ridge alone scores no more than the
  other field there.
* **Refinement by fates** (:func:`refine_by_fates`). A trajectory that leaves
  the saddle region forward in time does so on the product or the reactant side
  of the saddle (the sign of the reaction coordinate, the saddle's unstable
  direction, at its first exit); that *forward fate* switches across W^s, and
  the backward fate across W^u. Bisection on fates along short segments across
  each curve gives points on it to integration accuracy; two such points per
  curve give its secant, the secants' intersection a new estimate, and the
  segments shrink around it until the estimate moves less than the tolerance.
  This is independent of the LD and converges quadratically in the segment
  spacing.
* **Refinement by zoomed re-gridding** (:func:`refine_by_ld_zoom`), the paper's
  way: recompute both LDs on a small grid around the estimate, take the
  detection criterion's best point, zoom in, repeat until the grid spacing is
  below the tolerance.

Every function takes plain arrays and returns plain arrays or dataclasses, but the stage
products (``*_dataset``), which read their input files (or Datasets) and return the Dataset a
stage writes.

The package, by job: :mod:`.slices` (the section slice and its states), :mod:`.detection` (the
grid cell), :mod:`.fates` (exit fates and their bisection), :mod:`.refinement` (by fates, by LD
zoom), :mod:`.evidence` (the periodic orbit's crossing, residence times), :mod:`.crossings` (every
crossing in a slice's window, each refined, degenerate ones recorded as such), :mod:`.study` (an LD
map's slices, as the NHIM study stage's file records them), :mod:`.orbit_slices` (slices through
periodic-orbit points, as the orbit validation stage's file records them).
"""

from .crossings import CROSSING_STATUS, Crossing, SliceCrossings, find_crossings_together, find_every_crossing
from .detection import (
    Candidate, Detection, crossing_candidates, detect_global_argmax, detect_nhim_cell, nhim_score, ridge_level,
    switch_cells,
)
from .evidence import orbit_section_crossing, orbit_section_residual, residence_evidence
from .batched import bisect_fate_switch
from .fates import Cost, RefinementFailed, RefinementSettings, exit_fates
from .refinement import ManifoldsTangent, Refined, ld_at_points, refine_by_fates, refine_by_ld_zoom
from .slices import (
    SliceProblem, boundary_distance, make_slice_problem, point_slice, section_point_states, slice_transversality,
)
from .orbit_slices import validate_orbit_slice, validate_orbit_slices
from .study import ReferenceOrbit, study_map_slice

__all__ = [
    "CROSSING_STATUS", "Candidate", "boundary_distance", "Crossing", "ManifoldsTangent", "SliceCrossings", "crossing_candidates",
    "find_crossings_together", "find_every_crossing", "point_slice", "slice_transversality", "switch_cells",
    "Cost", "Detection", "RefinementFailed", "RefinementSettings", "Refined", "SliceProblem", "bisect_fate_switch",
    "detect_global_argmax", "detect_nhim_cell", "exit_fates", "ld_at_points", "make_slice_problem", "nhim_score",
    "orbit_section_crossing", "orbit_section_residual", "refine_by_fates", "refine_by_ld_zoom", "residence_evidence",
    "ridge_level", "section_point_states",
    "ReferenceOrbit", "study_map_slice", "validate_orbit_slice", "validate_orbit_slices",
]
