"""The transport figure of one study.

(a) Flux over the saddle against excess energy by every method: the orbit's action, the
reactive-island areas, the Monte Carlo reactive flux (with 3 standard errors), the dividing
line's one-way flux and the harmonic estimate. (b) Each method relative to the action, on a
symmetric log scale. (c) The reactive islands (first cuts of the inward stable and unstable
tubes) on the section, with the section's energy boundary at the largest energy. (d) Survival of a
microcanonical ensemble of the well against k_TST t, with exp(−k_TST t). (e) Gap-time survival
of the flux-weighted ensemble entering through the dividing lines, against k_TST t; the legend
gives both sides of the identity Φ E[min(τ, T)] = V (1 − P(T)).
"""

from __future__ import annotations


import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from ..io.contracts import TRANSPORT  # noqa: E402
from ..io.datafile import stage_parameters  # noqa: E402
from ..systems import make_system  # noqa: E402
from . import style  # noqa: E402


def _energy_boundary(ax, data, axis: int, energy: float) -> None:
    """The section's energy boundary p² = 2 (E − V) (the other momentum zero), green, at ``energy``."""
    parameters = stage_parameters(data)
    system = make_system(parameters["system_name"], parameters["system_spec"])
    n = system.n_dof
    fixed = np.zeros(n)
    fixed[list(data.phase.values).index(data.attrs["section_coordinate"])] = data.attrs["section_value"]
    centre = float(np.mean(data.island.values[-1, :, :, axis]))
    width = 4.0 * float(np.ptp(data.island.values[-1, :, :, axis])) + 1.0
    q = np.linspace(centre - width, centre + width, 800)
    values = []
    for v in q:
        fixed[axis] = v
        values.append(system.potential(fixed))
    p = np.sqrt(np.maximum(2.0 * (energy - np.array(values)), 0.0))
    allowed = p > 0
    q, p = q[allowed], p[allowed]
    ax.plot(np.concatenate([q, q[::-1], q[:1]]), np.concatenate([p, -p[::-1], p[:1]]), color=style.BOUNDARY_COLOR,
            lw=0.8, label=rf"energy boundary, $\Delta E$ = {data.excess_energy.values[-1]:g}")


def transport_figure(data):
    """The figure of a transport dataset."""
    excess = data.excess_energy.values
    action = data.flux_action.values
    mc, err = data.flux_monte_carlo.values, data.flux_monte_carlo_stderr.values
    with style.figure_style():
        # Two rows: five panels in one row make a strip too wide to read (or to show in the report).
        figure, grid = plt.subplots(2, 3, figsize=(16.0, 8.5), constrained_layout=True)
        axes = grid.ravel()
        figure.delaxes(axes[5])
        ax = axes[0]
        fine = np.linspace(0.0, excess.max() * 1.05, 200)
        scale = data.flux_harmonic.values[0] / excess[0]
        ax.plot(fine, scale * fine, "--", color="0.5", label=r"harmonic $2\pi\Delta E/\omega$")
        ax.plot(excess, action, "-o", color="k", ms=4, label=r"action $\oint p\cdot dq$")
        ax.plot(excess, data.flux_island_area.values[:, 0], "s", mfc="none", color=style.STABLE_COLOR, ms=8,
                label="island area (stable tube)")
        ax.plot(excess, data.flux_island_area.values[:, 1], "D", mfc="none", color=style.UNSTABLE_COLOR, ms=6,
                label="island area (unstable tube)")
        ax.errorbar(excess, mc, yerr=3 * err, fmt="x", color="tab:blue", ms=6, label=r"Monte Carlo ($\pm 3\sigma$)")
        ax.plot(excess, data.flux_dividing_line.values, "+", color="tab:orange", ms=8,
                label="one-way flux through the line")
        ax.set_xlabel(r"$\Delta E$")
        ax.set_ylabel("flux")
        ax.legend(loc="upper left")
        style.panel_letter(ax, 0)

        ax = axes[1]
        rel = {
            "island (stable)": (data.flux_island_area.values[:, 0], "s", style.STABLE_COLOR),
            "island (unstable)": (data.flux_island_area.values[:, 1], "D", style.UNSTABLE_COLOR),
            "one-way line flux": (data.flux_dividing_line.values, "+", "tab:orange"),
            "harmonic": (data.flux_harmonic.values, "v", "0.5"),
            "Monte Carlo": (mc, "x", "tab:blue"),
        }
        for label, (value, marker, color) in rel.items():
            ax.plot(excess, np.maximum(np.abs(value / action - 1), 1e-16), marker, color=color, mfc="none",
                    label=label)
        ax.plot(excess, 3 * err / action, "_", color="tab:blue", ms=12, mew=2, label=r"Monte Carlo $3\sigma$")
        ax.set_yscale("log")
        ax.set_xlabel(r"$\Delta E$")
        ax.set_ylabel("|flux / action - 1|")
        ax.legend(loc="lower right")
        style.panel_letter(ax, 1)

        ax = axes[2]
        phase = list(data.phase.values)
        coordinate = data.attrs["section_coordinate"]
        other = [name for name in phase[: len(phase) // 2] if name != coordinate][0]
        i, j = phase.index(other), phase.index(f"p{other}")
        colors = plt.cm.viridis(np.linspace(0.0, 0.9, len(excess)))
        for e, color in enumerate(colors):
            for k, dashes in ((0, "-"), (1, ":")):
                curve = data.island.values[e, k]
                closed = np.vstack([curve, curve[:1]])
                ax.plot(closed[:, i], closed[:, j], dashes, color=color, lw=1.0,
                        label=rf"$\Delta E$ = {excess[e]:g}" if k == 0 else None)
        _energy_boundary(ax, data, i, float(data.total_energy.values[-1]))
        ax.set_xlabel(style.symbol(other))
        ax.set_ylabel(style.symbol(f"p{other}"))
        ax.set_title(f"reactive islands on {style.section_symbol((other, f'p{other}'), data.attrs['section_direction'])}"
                     f" ({coordinate} = {data.attrs['section_value']:g})\nsolid: stable tube, dotted: unstable tube")
        ax.legend(loc="upper right")
        style.panel_letter(ax, 2)

        ax = axes[3]
        rate = data.rate_tst.values
        for e, color in enumerate(colors):
            scaled = data.survival_time.values[e] * rate[e]
            ax.plot(scaled, data.survival_probability.values[e], color=color,
                    label=rf"$\Delta E$ = {excess[e]:g}: $k_{{TST}}$ = {rate[e]:.3g}, "
                          rf"slope(0) = {data.survival_initial_slope.values[e] / rate[e]:.3f} $k_{{TST}}$, "
                          rf"decay = {data.survival_decay_rate.values[e] / rate[e]:.2f} $k_{{TST}}$")
        top = max(float(np.max(data.survival_time.values[e] * rate[e])) for e in range(len(rate)))
        x = np.linspace(0.0, top, 100)
        ax.plot(x, np.exp(-x), "--", color="k", label=r"$\exp(-k_{TST}\,t)$")
        ax.set_yscale("log")
        ax.set_xlabel(r"$k_{TST}\, t$")
        ax.set_ylabel("survival probability in the well")
        ax.legend(loc="lower left", fontsize=6)
        style.panel_letter(ax, 3)

        ax = axes[4]
        for e, color in enumerate(colors):
            scaled = data.survival_time.values[e] * rate[e]
            ax.plot(scaled, np.maximum(data.gap_time_survival.values[e], 1e-16), color=color,
                    label=rf"$\Delta E$ = {excess[e]:g}: $\Phi\langle\min(\tau,T)\rangle$ = "
                          rf"{data.left_volume_gap_times.values[e]:.4g}, $V(1-P(T))$ = "
                          rf"{data.left_volume_survival.values[e]:.4g} "
                          rf"({data.gap_identity_deviation.values[e]:+.1f}$\sigma$)")
        ax.set_yscale("log")
        ax.set_xlabel(r"$k_{TST}\, t$")
        ax.set_ylabel(r"gap-time survival $G(t) = \Pr(\tau > t)$")
        ax.legend(loc="lower left", fontsize=6)
        style.panel_letter(ax, 4)
    return figure


draw_transport = style.study_drawing(transport_figure, TRANSPORT, "transport")
