"""What the figures read from stage files, in the shapes the drawing code wants.

Each loader opens one stage file through :func:`ldpipe.io.datafile.open_stage_file` (which names
the file in every error), keeps only what a figure draws, and lets the rest go, so that a
figure of several 1500 x 1500 maps never holds more than one whole file in memory.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import cached_property
from pathlib import Path

import numpy as np
import xarray as xr

from ..io.contracts import EQUILIBRIA, MANIFOLDS, UPO
from ..io.datafile import open_stage_file, stage_parameters
from ..core.equilibria.potential import select_saddle
from ..core.maps.grid import open_map_file
from ..errors import ConfigError
from ..core.sections import Section, section_states
from ..systems import System, make_system

#: The LD fields a figure may draw: forward plus backward (the paper's maps), or one direction.
DESCRIPTORS = ("total", "forward", "backward")


def descriptor_directions(descriptor: str) -> tuple[str, ...]:
    """The directions of time the LD ``descriptor`` (one of :data:`DESCRIPTORS`) adds up."""
    return ("forward", "backward") if descriptor == "total" else (descriptor,)


@dataclass
class LDMap:
    """One LD map as a figure draws it.

    Attributes
    ----------
    name : str
        The map's name under ``ld_maps:``.
    axes : (str, str)
        Phase-space coordinates along the first (horizontal) and second (vertical) axis.
    first, second : ndarray, shapes (n1,), (n2,)
        Grid coordinates.
    values : masked ndarray, shape (n1, n2)
        The descriptor; masked where the point is energetically forbidden (never integrated).
    attrs : dict
        The file's attributes (energy, excess_energy, critical_energy, tau, time_mode, region ...).
    parameters : dict
        The stage parameters the map was computed with (section spec, system_spec ...).
    section : Section
        The section, resolved from ``parameters`` (see :meth:`ldpipe.core.sections.Section.from_spec`).
    """

    name: str
    axes: tuple[str, str]
    first: np.ndarray
    second: np.ndarray
    values: np.ma.MaskedArray
    attrs: dict
    parameters: dict = field(repr=False)

    @cached_property
    def section(self) -> Section:
        """The map's section, resolved from its recorded spec (``'saddle'`` values at the map's saddle)."""
        return Section.from_spec(self.parameters["section"], self.system(), self.attrs.get("saddle_position"),
                                 key=f"ld_maps.{self.name}.section")

    def system(self) -> System:
        return make_system(self.parameters["system_name"], self.parameters["system_spec"])


def load_ld_map(path: str | Path | xr.Dataset, descriptor: str = "total") -> LDMap:
    """An LD map from a file of the ``ld_grid`` stage (``descriptor`` one of :data:`DESCRIPTORS`)."""
    if descriptor not in DESCRIPTORS:
        raise ConfigError(f"descriptor {descriptor!r}: expected one of {list(DESCRIPTORS)}")
    dataset = open_map_file(path, f"a figure of descriptor {descriptor!r}", descriptor_directions(descriptor))
    axes = tuple(dataset.allowed.dims)
    # a map with noise is drawn as its ensemble mean
    fields = {label: dataset[f"ld_{label}"].mean("member") if "member" in dataset[f"ld_{label}"].dims
              else dataset[f"ld_{label}"] for label in descriptor_directions(descriptor)}
    if descriptor == "total":
        values = fields["forward"].values + fields["backward"].values
    else:
        values = fields[descriptor].values
    allowed = dataset.allowed.values.astype(bool)
    return LDMap(
        name=str(dataset.attrs["map"]) if "map" in dataset.attrs else Path(path).stem,
        axes=(str(axes[0]), str(axes[1])),
        first=dataset[axes[0]].values.copy(),
        second=dataset[axes[1]].values.copy(),
        values=np.ma.masked_array(values, mask=~allowed),
        attrs=dict(dataset.attrs),
        parameters=stage_parameters(dataset),
    )


def nearest_index(values: np.ndarray, target: float) -> int:
    """Index of the grid value nearest ``target``."""
    return int(np.argmin(np.abs(np.asarray(values) - target)))


@dataclass
class Orbit:
    """One periodic orbit of a family file.

    Attributes
    ----------
    phase : tuple of str
        Phase-space coordinate names, e.g. ('x', 'y', 'px', 'py').
    trajectory : ndarray, shape (samples, 2 n_dof)
        States along one period, both ends included.
    energy, excess_energy, period : float
    """

    phase: tuple[str, ...]
    trajectory: np.ndarray
    energy: float
    excess_energy: float
    period: float

    def coordinate(self, name: str) -> np.ndarray:
        return self.trajectory[:, self.phase.index(name)]


def _energy_index(dataset, energy: dict, path) -> int:
    (kind, value), = energy.items()
    values = dataset.excess_energy.values if kind == "excess" else dataset.energy.values
    matches = np.flatnonzero(np.abs(values - value) <= 1e-8 * max(1.0, abs(value)))
    if matches.size == 0:
        raise ConfigError(
            f"{path}: no orbit at {kind} energy {value!r}; the family has {kind} energies {np.round(values, 10).tolist()}"
        )
    return int(matches[0])


def load_orbits(path: str | Path | xr.Dataset, energies: list[dict] | None = None) -> list[Orbit]:
    """Orbits of a ``upo`` family file, at the given energies (each {'excess': v} or {'total': v};
    default every orbit of the file), in that order."""
    dataset = open_stage_file(path, stage=UPO, variables=("trajectory", "energy", "excess_energy", "period"))
    indices = range(dataset.sizes["orbit"]) if energies is None else [_energy_index(dataset, e, path) for e in energies]
    phase = tuple(str(p) for p in dataset.phase.values)
    return [
        Orbit(phase=phase, trajectory=dataset.trajectory.values[i].copy(), energy=float(dataset.energy.values[i]),
              excess_energy=float(dataset.excess_energy.values[i]), period=float(dataset.period.values[i]))
        for i in indices
    ]


def orbit_section_points(orbit: Orbit, coordinate: str, value: float, momentum: str, sign: int) -> np.ndarray:
    """Where the orbit pierces the section ``coordinate = value`` with ``sign * momentum > 0``.

    Located by linear interpolation between the stored samples (enough for a marker on a map).

    Returns
    -------
    ndarray, shape (k, 2 n_dof)
    """
    q = orbit.coordinate(coordinate) - value
    p = orbit.coordinate(momentum)
    crossings = np.flatnonzero((q[:-1] * q[1:] < 0) | ((q[:-1] == 0) & (q[1:] != 0)))
    points = []
    for i in crossings:
        weight = q[i] / (q[i] - q[i + 1])
        state = (1 - weight) * orbit.trajectory[i] + weight * orbit.trajectory[i + 1]
        if sign * state[orbit.phase.index(momentum)] > 0 and sign * p[i] > 0:
            points.append(state)
    return np.array(points).reshape(-1, orbit.trajectory.shape[1])


@dataclass
class ManifoldCurves:
    """The curves where the stable and unstable manifolds of one orbit cut a section.

    Attributes
    ----------
    phase : tuple of str
    curves : dict
        {'stable': [array (k, 2 n_dof), ...], 'unstable': [...]}: pieces of curve, each ordered
        along the orbit, split where a crossing is missing or the curve jumps.
    trajectories : dict
        {'stable': array (branch, point, sample, 2 n_dof), 'unstable': ...}, the globalized
        manifolds themselves (only if asked for).
    attrs : dict
    """

    phase: tuple[str, ...]
    curves: dict
    trajectories: dict
    attrs: dict


def _split_curve(points: np.ndarray, valid: np.ndarray, jump_factor: float = 10.0) -> list[np.ndarray]:
    """Pieces of a closed curve sampled around a periodic orbit.

    Parameters
    ----------
    points : ndarray, shape (n, d)
        The curve's points in the orbit's order; the last is followed by the first.
    valid : ndarray of bool, shape (n,)
        Whether each point exists (its trajectory reached the section).
    jump_factor : float
        A step longer than this many times the median step breaks the curve: there the cut
        passes from one sheet of the tube to another, and a line would cross the map.

    Returns
    -------
    list of ndarray, each shape (k, d), k >= 2; a whole curve is returned closed (first point repeated).
    """
    steps = np.linalg.norm(np.roll(points, -1, axis=0) - points, axis=1)  # step i: point i to i + 1
    joined = valid & np.roll(valid, -1)
    if not joined.any():
        return []
    threshold = jump_factor * float(np.median(steps[joined]))
    broken = ~joined | (steps > threshold)
    if not broken.any():
        return [np.vstack([points, points[:1]])]
    start = int(np.flatnonzero(broken)[0]) + 1  # walk from just after a break, so pieces stay whole
    pieces, current = [], []
    for index in np.roll(np.arange(len(points)), -start):
        if valid[index]:
            current.append(points[index])
        if broken[index]:
            if len(current) > 1:
                pieces.append(np.array(current))
            current = []
    if len(current) > 1:
        pieces.append(np.array(current))
    return pieces


def load_manifold_curves(path: str | Path | xr.Dataset, *, trajectories: bool = False) -> ManifoldCurves:
    """Section curves (and optionally trajectories) of a ``manifolds`` stage file."""
    dataset = open_stage_file(path, stage=MANIFOLDS, variables=("section_state", "section_valid"))
    phase = tuple(str(p) for p in dataset.phase.values)
    states = dataset.section_state.values  # (manifold, branch, crossing, point, phase)
    valid = dataset.section_valid.values.astype(bool)
    curves = {}
    for m, manifold in enumerate(dataset.manifold.values):
        pieces = []
        for b in range(states.shape[1]):
            for c in range(states.shape[2]):
                pieces.extend(_split_curve(states[m, b, c], valid[m, b, c]))
        curves[str(manifold)] = pieces
    tubes = {}
    if trajectories:
        for m, manifold in enumerate(dataset.manifold.values):
            tubes[str(manifold)] = dataset.trajectory.values[m].copy()
    return ManifoldCurves(phase=phase, curves=curves, trajectories=tubes, attrs=dict(dataset.attrs))


def allowed_mask(system: System, section: Section, energy: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The energetically allowed points of ``section`` at ``energy``: the axes' grid values,
    shapes (n1,), (n2,), and the mask, shape (n1, n2). Its boundary is the energy boundary of
    the section (the solved momentum is 0 there)."""
    _, allowed, _ = section_states(system, section, energy)
    first, second = section.axis_values()
    return first, second, allowed


def plane_view(view: dict | None, coordinates: tuple[str, str], first: np.ndarray, second: np.ndarray,
               margin: float, min_span: float = 0.0) -> list[tuple[float, float]]:
    """Ranges of a configuration-space panel: the configured ``view`` if given, else the box of
    the points (``first``, ``second``) padded by ``margin`` times its larger side (at least ``min_span``)."""
    if view:
        return [tuple(view[coordinates[0]]), tuple(view[coordinates[1]])]
    pad = margin * max(np.ptp(first), np.ptp(second), min_span)
    return [(first.min() - pad, first.max() + pad), (second.min() - pad, second.max() + pad)]


def potential_on_plane(system: System, axes: tuple[str, str], ranges, points: int,
                       fixed: dict[str, float]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """V on a grid of a configuration plane, the other coordinates fixed.

    Returns
    -------
    first : ndarray, shape (points,)
    second : ndarray, shape (points,)
    potential : ndarray, shape (points, points), indexed [first, second]
    """
    first = np.linspace(*ranges[0], points)
    second = np.linspace(*ranges[1], points)
    grid_first, grid_second = np.meshgrid(first, second, indexing="ij")
    q = np.zeros((system.n_dof, grid_first.size))
    q[system.coordinates.index(axes[0])] = grid_first.ravel()
    q[system.coordinates.index(axes[1])] = grid_second.ravel()
    for name, value in fixed.items():
        q[system.coordinates.index(name)] = value
    potential = np.empty(grid_first.size)
    system.kernels.potential_block(np.ascontiguousarray(q), potential, grid_first.size)
    return first, second, potential.reshape(grid_first.shape)


def saddles(path: str | Path, near: list[float] | None = None
            ) -> tuple[np.ndarray, np.ndarray, float, tuple[str, ...], dict]:
    """Index-1 saddles of an ``equilibria`` file: positions (k, n_dof), the one nearest ``near``
    (:func:`ldpipe.core.equilibria.potential.select_saddle`) and its critical energy, the coordinate names, and
    the stage parameters (with the system's spec)."""
    dataset = open_stage_file(path, stage=EQUILIBRIA, variables=("position", "saddle_equilibrium", "critical_energy"))
    indices = dataset.saddle_equilibrium.values
    coordinates = tuple(str(c) for c in dataset.coordinate.values)
    saddle, critical_energy = select_saddle(dataset, near)
    return (dataset.position.values[indices].copy(), saddle.copy(), critical_energy, coordinates,
            stage_parameters(dataset))
