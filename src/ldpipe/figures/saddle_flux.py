"""The saddle-flux figure of one study.

(a) Flux through the dividing surface against excess energy on log–log axes: the Monte Carlo
reactive flux (3 standard errors), the surface's one-way flux and the harmonic estimate
(2π)^{n−1} ΔE^{n−1}/((n−1)! ∏ ω_i). (b) Each relative to the harmonic estimate, |flux/harmonic − 1| on log–log axes
(circles where below the harmonic value), which tends to 0 linearly as ΔE → 0, with the Monte
Carlo's 3 standard errors; the samples not reactive (the recrossing flux) are printed by each.
"""

from __future__ import annotations


import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from ..io.contracts import SADDLE_FLUX  # noqa: E402
from . import style  # noqa: E402


def saddle_flux_figure(data):
    """The figure of a saddle-flux dataset."""
    excess = data.excess_energy.values
    mc, err = data.flux_monte_carlo.values, data.flux_monte_carlo_stderr.values
    one_way, harmonic = data.flux_dividing_surface.values, data.flux_harmonic.values
    n_dof = int(data.attrs["n_dof"])
    label = r"harmonic $2\pi\Delta E/\omega$" if n_dof == 2 else \
        r"harmonic $(2\pi)^2\Delta E^2/(2\omega_1\omega_2)$"
    with style.figure_style():
        figure, axes = plt.subplots(1, 2, figsize=(10.0, 4.0), constrained_layout=True)
        ax = axes[0]
        fine = np.geomspace(excess.min() / 1.5, excess.max() * 1.5, 200)
        scale = harmonic[0] / excess[0] ** (n_dof - 1)
        ax.plot(fine, scale * fine ** (n_dof - 1), "--", color="0.5", label=label)
        ax.plot(excess, one_way, "+", color="tab:orange", ms=9, label="one-way flux through the surface")
        ax.errorbar(excess, mc, yerr=3 * err, fmt="x", color="tab:blue", ms=6,
                    label=r"reactive flux, Monte Carlo ($\pm 3\sigma$)")
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlabel(r"$\Delta E = E - E_c$")
        ax.set_ylabel("flux")
        ax.set_title(f"{data.attrs['system']}: saddle at {style.position_text(data.attrs['saddle_position'])}")
        ax.legend(loc="upper left")
        style.panel_letter(ax, 0)

        ax = axes[1]
        # Log scale of |flux / harmonic − 1|: the anharmonic correction is linear in ΔE and spans decades.
        deviation = {"one-way": (one_way / harmonic - 1, "+", "tab:orange"),
                     "reactive (Monte Carlo)": (mc / harmonic - 1, "x", "tab:blue")}
        for name, (value, marker, color) in deviation.items():
            style.plot_deviation(ax, excess, value, marker, color, name, "harmonic")
        ax.plot(excess, 3 * err / harmonic, "_", color="tab:blue", ms=12, mew=2, label=r"Monte Carlo $3\sigma$")
        samples = data.monte_carlo_samples.values
        reactive = data.monte_carlo_reactive.values
        for x, y, n, r in zip(excess, 3 * err / harmonic, samples, reactive):
            ax.annotate(f"{n - r}/{n}", (x, y), textcoords="offset points", xytext=(4, 4), fontsize=6)
        style.finish_deviation_panel(ax, "|flux / harmonic - 1|",
                                     "relative to the harmonic estimate\n(labels: samples not reactive / samples)", 1)
    return figure


draw_saddle_flux = style.study_drawing(saddle_flux_figure, SADDLE_FLUX, "saddle-flux")
