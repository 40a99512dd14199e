"""What each stage's file is, for the stages and figures that read it: one contract per stage.

A contract names the stage (the ``ldpipe_stage`` attribute every file of it carries) and the
variables every file of it holds that a later stage or a figure reads. The writing stage
writes with its contract (:func:`ldpipe.io.datafile.write_stage_file`); a reader opens with it
(:func:`ldpipe.io.datafile.open_stage_file`), which checks the stage and the variables, and may
ask for only some of them (never for one the contract does not name). Readers import this
module, never the stage that wrote the file: figures and library modules stay below the stages.
"""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class StageFile:
    """The contract of one stage's files.

    Attributes
    ----------
    stage : str
        The stage's identifier, written as the file's ``ldpipe_stage`` attribute.
    variables : tuple of str
        Variables the stage writes that its readers rely on.
    intermediate : bool
        True for a file read once by the next job and then deleted (a tile of a map): it is
        written uncompressed, which is cheaper to write and to read (:mod:`ldpipe.io.datafile`).
    """

    stage: str
    variables: tuple[str, ...] = ()
    intermediate: bool = False


EQUILIBRIA = StageFile("equilibria", (
    "position", "energy", "type", "morse_index", "eigenvalue_real", "eigenvalue_imag",
    "eigenvector_real", "eigenvector_imag", "critical_energy", "saddle_equilibrium",
))
#: The equilibria of an autonomous vector field (no energy, no saddle selection): roots of f and Df's spectrum.
FLOW_EQUILIBRIA = StageFile("flow_equilibria", (
    "position", "type", "unstable_dimension", "eigenvalue_real", "eigenvalue_imag", "eigenvector_real",
    "eigenvector_imag",
))
#: One tile of an LD map, gathered into the map's file.
LD_TILE = StageFile("ld_tile", ("ld_forward", "ld_backward"), intermediate=True)
LD_GRID = StageFile("ld_grid", ("ld_forward", "ld_backward", "allowed"))
#: A map without its LD (``ld: false``): a file of the same stages holding the flow map and its FTLE.
FLOW_MAP_TILE = StageFile("ld_tile", ("allowed",), intermediate=True)
FLOW_MAP = StageFile("ld_grid", ("ftle_forward", "ftle_backward", "allowed"))
UPO = StageFile("upo", (
    "period", "energy", "excess_energy", "initial_state", "floquet_real", "floquet_imag", "closure_error",
    "trajectory", "monodromy",
))
MANIFOLDS = StageFile("manifolds", ("trajectory", "start_state", "section_state", "section_valid", "orbit_state"))
#: The manifolds of a discrete map's saddle fixed points: per fixed point, manifold and branch, the images of a
#: fundamental segment.
MAP_MANIFOLDS = StageFile("map_manifolds", ("curve", "fixed_point_position", "multiplier", "eigenvector"))
POINCARE = StageFile("poincare", ("initial_state", "crossing_state", "crossing_valid", "crossing_count", "escaped"))
NHIM = StageFile("nhim", ("refined_point", "reference_point", "distance_refined", "residence_forward"))
#: NHIM crossings of slices through periodic-orbit points: per slice, and per refined crossing.
NHIM_ORBITS = StageFile("nhim_orbits", (
    "status", "reason", "family", "energy", "orbit_phase", "axis_names", "solve", "orbit_point", "solved_momentum",
    "transversality", "candidates", "crossings", "distance", "crossing_slice", "crossing_point",
))
#: NHIM points sampled over a family of slices: per slice, and per refined point.
NHIM_SAMPLING = StageFile("nhim_sampling", (
    "fixed_values", "sign", "status", "reason", "slice_of_point", "state", "section_point", "uncertainty",
    "energy_residual",
))
TRANSPORT = StageFile("transport", (
    "excess_energy", "flux_action", "flux_island_area", "flux_monte_carlo", "flux_monte_carlo_stderr",
    "flux_harmonic", "island", "well_volume", "rate_tst",
))
SADDLE_FLUX = StageFile("saddle_flux", (
    "excess_energy", "flux_monte_carlo", "flux_monte_carlo_stderr", "flux_dividing_surface", "flux_harmonic",
))
#: The normal form's flux by energy and by order, its divisors and the NHIM points; the compared
#: studies' values (orbit_*, monte_carlo_*) are there only when the study names them.
NORMAL_FORM = StageFile("normal_form", (
    "excess_energy", "flux", "flux_truncation_error", "flux_by_order", "flux_harmonic", "smallest_divisor",
    "nhim_state",
))
#: Curves extracted from an LD map (a CF contiguous ragged array): per point and per curve.
STRUCTURES = StageFile("structures", ("point_count", "strength", "value", "source", "manifold"))
#: The finite-size Lyapunov exponent of a flow over a grid, forward and backward.
FSLE = StageFile("fsle", ("fsle_forward", "fsle_backward", "fsle_reached_forward", "fsle_reached_backward",
                          "fsle_angle_forward", "fsle_angle_backward"))
#: The LAVD of a flow over a grid and its rotationally coherent vortices (a ragged array of boundaries).
LAVD = StageFile("lavd", ("lavd", "lavd_defined", "point_count", "area", "level", "convexity_deficiency"))
#: The LD, orbit and NHIM parts are each optional; these are the LD and orbit parts' variables.
ACCURACY_COST = StageFile(
    "accuracy_cost", ("wall_time", "ld_error_quantile", "energy_error_quantile", "orbit_wall_time", "orbit_closure_error")
)

#: Every stage file's contract, by stage.
CONTRACTS = {contract.stage: contract for contract in (
    EQUILIBRIA, FLOW_EQUILIBRIA, LD_TILE, LD_GRID, UPO, MANIFOLDS, MAP_MANIFOLDS, POINCARE, NHIM, NHIM_ORBITS, NHIM_SAMPLING,
    TRANSPORT, SADDLE_FLUX, NORMAL_FORM, ACCURACY_COST, STRUCTURES, FSLE, LAVD,
)}
