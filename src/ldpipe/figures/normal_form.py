"""The normal-form figure of one study.

(a) Flux over the saddle against excess energy (log–log): the normal form's, the Lyapunov orbit's
action (2 DoF, when a transport study is compared), the Monte Carlo reactive flux (3 standard
errors, when a transport or saddle-flux study is compared) and the harmonic estimate.
(b) Each method relative to the normal form, |flux / normal form − 1| (log–log; circles below).
(c) The normal form's flux against its order at each energy: |flux(order) − flux(top order)| / flux,
and the truncation error estimate of the top order (the change from the order below).
"""

from __future__ import annotations


import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.ticker import MaxNLocator  # noqa: E402

from ..io.contracts import NORMAL_FORM  # noqa: E402
from . import style  # noqa: E402


def _at(excess: np.ndarray, values: np.ndarray, targets: np.ndarray) -> np.ndarray:
    """The normal-form flux at ``targets`` (interpolated in log–log between its energies)."""
    return np.exp(np.interp(np.log(targets), np.log(excess), np.log(values)))


def normal_form_figure(data):
    """The figure of a normal-form dataset."""
    excess, flux, harmonic = data.excess_energy.values, data.flux.values, data.flux_harmonic.values
    n_dof = int(data.attrs["n_dof"])
    with style.figure_style():
        figure, axes = plt.subplots(1, 3, figsize=(14.0, 4.2), constrained_layout=True)
        ax = axes[0]
        ax.plot(excess, flux, "o-", color="black", mfc="none", label=f"normal form, order {int(data.order[-1])}")
        ax.plot(excess, harmonic, "--", color="0.5", label="harmonic estimate")
        compared = {}
        if "flux_orbit_action" in data:
            e, v = data.orbit_excess_energy.values, data.flux_orbit_action.values
            ax.plot(e, v, "+", color="tab:red", ms=10, label="Lyapunov orbit's action")
            compared["orbit action"] = (e, v, None, "+", "tab:red")
        if "flux_monte_carlo" in data:
            e, v, s = (data.monte_carlo_excess_energy.values, data.flux_monte_carlo.values,
                       data.flux_monte_carlo_stderr.values)
            ax.errorbar(e, v, yerr=3 * s, fmt="x", color="tab:blue", label=r"Monte Carlo ($\pm 3\sigma$)")
            compared["Monte Carlo"] = (e, v, s, "x", "tab:blue")
        compared["harmonic"] = (excess, harmonic, None, "_", "0.4")
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlabel(r"$\Delta E = E - E_c$")
        ax.set_ylabel("flux")
        ax.set_title(f"{data.attrs['system']} ({n_dof} DoF)\nsaddle at "
                     f"{style.position_text(data.attrs['saddle_position'])}", fontsize=9)
        ax.legend(loc="upper left", fontsize=7)
        style.panel_letter(ax, 0)

        ax = axes[1]
        for name, (e, v, s, marker, color) in compared.items():
            inside = (e >= excess.min()) & (e <= excess.max())
            if not inside.any():
                continue
            reference = _at(excess, flux, e[inside])
            deviation = v[inside] / reference - 1
            style.plot_deviation(ax, e[inside], deviation, marker, color, name)
            if s is not None:
                ax.plot(e[inside], 3 * s[inside] / reference, "_", color=color, ms=12, mew=2,
                        label=r"Monte Carlo $3\sigma$")
        ax.plot(excess, np.maximum(data.flux_truncation_error.values / flux, 1e-17), "s", color="black", mfc="none",
                ms=5, label="normal form's truncation error")
        style.finish_deviation_panel(ax, "|flux / normal form - 1|", "relative to the normal form's flux", 1)

        ax = axes[2]
        orders = data.order.values
        by_order = data.flux_by_order.values
        for i, e in enumerate(excess):
            change = np.abs(by_order[i, :-1] / by_order[i, -1] - 1)
            ax.semilogy(orders[:-1], np.maximum(change, 1e-17), "o-", ms=4, label=rf"$\Delta E$ = {e:.4g}")
        ax.xaxis.set_major_locator(MaxNLocator(integer=True))  # orders are whole numbers
        ax.set_xlabel("order of the normal form")
        ax.set_ylabel(f"|flux(order) / flux(order {orders[-1]}) - 1|")
        ax.set_title("convergence with the order")
        ax.legend(loc="upper right", fontsize=7)
        style.panel_letter(ax, 2)
    return figure


draw_normal_form = style.study_drawing(normal_form_figure, NORMAL_FORM, "normal-form")
