"""Figure kind ``orbit_family``: a family of periodic orbits, and the manifolds of some of them.

The paper's appendix figure: (a) the Lyapunov orbits around the bottom saddle at ΔE = 0.125,
0.375, ..., 2.125 in configuration space, coloured by ΔE, over the isopotential V = E_c; (b)
the stable (cyan) and unstable (magenta) manifolds of the orbit at ΔE = 2.25, globalized from
the orbit, in a three-dimensional projection of phase space.
"""

from __future__ import annotations

from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np
from matplotlib.cm import ScalarMappable
from matplotlib.colors import Normalize

from ..io.contracts import UPO
from ..io.datafile import open_stage_file, stage_parameters
from ..logs import get_logger
from ..systems import make_system
from . import style
from .data import load_manifold_curves, load_orbits, plane_view, potential_on_plane

log = get_logger(__name__)

#: Grid of the potential behind the orbits.
POTENTIAL_POINTS = 300
#: Colour map of the orbits' excess energies.
ENERGY_COLORMAP = "plasma"


def _family_system(path: str | Path):
    dataset = open_stage_file(path, stage=UPO, variables=("trajectory",))
    parameters = stage_parameters(dataset)
    return make_system(parameters["system_name"], parameters["system_spec"]), dict(dataset.attrs)


def _view_box(limits: dict, axes3: tuple[str, str, str], configuration: dict, orbits) -> np.ndarray:
    """Limits (3, 2) of the 3D view: as configured, else the configuration panel's ranges for
    positions and three times the orbits' span for momenta."""
    box = []
    for axis in axes3:
        if axis in limits:
            box.append(limits[axis])
        elif axis in configuration:
            box.append(configuration[axis])
        else:
            values = np.concatenate([orbit.coordinate(axis) for orbit in orbits])
            middle, half = 0.5 * (values.max() + values.min()), 1.5 * max(np.ptp(values), 1e-3)
            box.append((middle - half, middle + half))
    return np.array(box, dtype=float)


def draw_orbit_family(settings: dict, *, upo: str | Path, manifolds: list[str | Path] = ()) -> plt.Figure:
    """Orbits of one family in configuration space, and the manifolds of chosen orbits in 3D.

    Parameters
    ----------
    settings : dict
        The figure's entry under ``figures:`` (kind ``orbit_family``), defaults filled.
    upo : path
        The family's ``upo`` stage file.
    manifolds : list of paths
        ``manifolds`` stage files drawn in the 3D panel (none: no such panel).
    """
    energies = settings.get("energies")
    requested = None if energies is None else [{kind: v} for kind, values in energies.items() for v in values]
    orbits = load_orbits(upo, requested)
    system, attrs = _family_system(upo)
    coordinates = system.coordinates
    saddle = np.asarray(attrs["saddle_position"])
    critical_energy = float(attrs["critical_energy"])
    panels = 1 + bool(manifolds)
    figure = plt.figure(figsize=(4.6 * panels + 0.6, 4.4))

    ax = figure.add_subplot(1, panels, 1)
    excess = np.array([orbit.excess_energy for orbit in orbits])
    norm = Normalize(excess.min(), excess.max() if excess.max() > excess.min() else excess.min() + 1)
    colormap = plt.get_cmap(ENERGY_COLORMAP)
    q0 = np.concatenate([orbit.coordinate(coordinates[0]) for orbit in orbits])
    q1 = np.concatenate([orbit.coordinate(coordinates[1]) for orbit in orbits])
    ranges = plane_view(settings.get("configuration"), coordinates[:2], q0, q1, margin=0.4, min_span=0.5)
    fixed_rest = {c: float(saddle[i]) for i, c in enumerate(coordinates[2:], start=2)}
    first, second, potential = potential_on_plane(system, coordinates[:2], ranges, POTENTIAL_POINTS, fixed_rest)
    top = critical_energy + float(excess.max())
    ax.contourf(first, second, (potential <= top).T.astype(float), levels=[0.5, 1.5], colors=[style.HILL_COLOR])
    ax.contour(first, second, potential.T, levels=[critical_energy], colors="black", linewidths=0.8, linestyles="--")
    for orbit in sorted(orbits, key=lambda o: -o.excess_energy):  # the smaller ones on top
        ax.plot(orbit.coordinate(coordinates[0]), orbit.coordinate(coordinates[1]),
                color=colormap(norm(orbit.excess_energy)), linewidth=1.2)
    ax.plot(saddle[0], saddle[1], "x", color=style.SADDLE_COLOR, markersize=8, mew=2)
    colorbar = figure.colorbar(ScalarMappable(norm=norm, cmap=colormap), ax=ax, fraction=0.046, pad=0.03)
    colorbar.set_label(r"$\Delta E$")
    ax.set_xlim(ranges[0])
    ax.set_ylim(ranges[1])
    ax.set_aspect("equal", adjustable="box")
    style.label_axes(ax, *coordinates[:2])
    style.panel_letter(ax, 0, rf"{len(orbits)} orbits, $\Delta E$ = {excess.min():.3g} to {excess.max():.3g}")
    log.info("family %s: %d orbits, periods %s", upo, len(orbits), [round(o.period, 6) for o in orbits])

    if manifolds:
        ax3 = figure.add_subplot(1, panels, 2, projection="3d")
        axes3 = tuple(settings["view3d_axes"])
        box = _view_box(settings.get("view3d_limits") or {}, axes3, dict(zip(coordinates, ranges)), orbits)
        for path in manifolds:
            tubes = load_manifold_curves(path, trajectories=True)
            phase = tubes.phase
            for kind, color in (("stable", style.STABLE_COLOR), ("unstable", style.UNSTABLE_COLOR)):
                trajectories = tubes.trajectories[kind]  # (branch, point, sample, phase)
                step = max(1, trajectories.shape[1] // settings["trajectories_per_branch"])
                for branch in trajectories:
                    for trajectory in branch[::step]:
                        points = np.stack([trajectory[:, phase.index(a)] for a in axes3], axis=1)
                        # Cut where the trajectory leaves the box (it may escape far), so it does not
                        # run across the picture: matplotlib draws 3D lines beyond the axes' limits.
                        inside = np.all((points >= box[:, 0]) & (points <= box[:, 1]), axis=1)
                        for piece in np.split(points, np.flatnonzero(np.diff(inside.astype(int))) + 1):
                            if len(piece) > 1 and np.all((piece >= box[:, 0]) & (piece <= box[:, 1])):
                                ax3.plot(*piece.T, color=color, linewidth=0.4, alpha=0.7, rasterized=True)
            orbit = load_orbits(upo, [{"excess": float(tubes.attrs["excess_energy"])}])[0]
            ax3.plot(*(orbit.coordinate(a) for a in axes3), color=style.ORBIT_COLOR, linewidth=1.5)
            title = rf"manifolds at $\Delta E$ = {float(tubes.attrs['excess_energy']):.3g}"
        for limits, setter in zip(box, (ax3.set_xlim, ax3.set_ylim, ax3.set_zlim)):
            setter(limits)
        ax3.set_xlabel(style.symbol(axes3[0]))
        ax3.set_ylabel(style.symbol(axes3[1]))
        ax3.set_zlabel(style.symbol(axes3[2]))
        ax3.view_init(elev=settings["view"][0], azim=settings["view"][1])
        style.panel_letter(ax3, 1, title)
    figure.tight_layout()
    return figure
