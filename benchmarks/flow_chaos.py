"""LD chaos indicators of the Hénon–Heiles flow beside the SALI: agreement and cost.

On the section x = 0 of Hénon–Heiles at E = 1/8 (p_x > 0 solved), a grid of starts: for each
tau the indicators of ``ldpipe.core.flow_chaos`` (D_L, S_L, the Laplacian from the LDs of the
four neighbours at sigma; the exact gradient of the LD along the section from the variational
equations) and the SALI over ``--reference``; prints each indicator's agreement with the SALI's
classification, and the CPU time of the two ways to the indicators on the same starts, side by
side: the ten DOP853 LD runs of the finite differences (a start and four neighbours, each way)
and the two variational runs (fourth-order Runge-Kutta on the trajectory and its 4 x 4
transition matrix, each way). ``--figure PATH`` draws the SALI and the four indicators.

    python benchmarks/flow_chaos.py --points 40 --tau 100 200 500 --reference 5000
"""

from __future__ import annotations

import argparse
import os
import time

import numpy as np


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--points", type=int, default=40, help="grid points per axis")
    parser.add_argument("--tau", type=float, nargs="+", default=[100.0, 200.0, 500.0], help="LD time each way")
    parser.add_argument("--reference", type=float, default=5000.0, help="the SALI's time")
    parser.add_argument("--sigma", type=float, default=1e-5, help="distance of the neighbouring starts")
    parser.add_argument("--dt", type=float, default=0.02, help="Runge-Kutta step of the variational runs")
    parser.add_argument("--figure", default=None)
    args = parser.parse_args()

    import ldpipe
    from ldpipe.core.flow_chaos import FLOW_INDICATORS, flow_chaos_indicators, total_flow_ld
    from ldpipe.core.sections import Section, section_states
    from ldpipe.engine.settings import LDSettings
    from ldpipe.engine.variational_ld import variational_ld

    system = ldpipe.system(name="henon_heiles", formula="(x**2 + y**2)/2 + x**2*y - y**3/3", coordinates=["x", "y"])
    spec = {"axes": [{"name": "y", "range": [-0.45, 0.65], "points": args.points},
                     {"name": "py", "range": [-0.5, 0.5], "points": args.points}], "fixed": {"x": 0.0}, "solve": "px"}
    section = Section.from_spec(spec, system)
    states, _, _ = section_states(system, section, 0.125)
    flow_chaos_indicators(system, {**spec, "axes": [{**a, "points": 3} for a in spec["axes"]]}, 0.125, tau=1.0,
                          sigma=args.sigma, reference_tau=1.0)  # compiled
    print(f"Hénon–Heiles E = 1/8, section x = 0, {args.points}^2 grid ({len(states)} starts on the surface), "
          f"sigma = {args.sigma}, SALI over t = {args.reference:g} (chaotic below 1e-8); load {os.getloadavg()}")
    print("| tau | " + " | ".join(f"agreement {name}" for name in FLOW_INDICATORS)
          + " | chaotic by SALI | CPU s, 10 LD runs (differences) | CPU s, 2 variational runs (gradient) |")
    print("| ---: | " + " | ".join("---:" for _ in FLOW_INDICATORS) + " | ---: | ---: | ---: |")
    found = None
    for tau in args.tau:
        found = flow_chaos_indicators(system, spec, 0.125, tau=tau, sigma=args.sigma, reference_tau=args.reference,
                                      dt=args.dt)
        settings = LDSettings(tau=tau, p="arclength", scheme="dop853", rtol=1e-10, atol=1e-10)
        start = time.process_time()
        for _ in range(5):  # the start and its four neighbours (the same starts: the cost is alike)
            total_flow_ld(system, states, settings)
        differences = time.process_time() - start
        start = time.process_time()
        for direction in (1, -1):
            variational_ld(system, states, tau, args.dt, direction)
        gradient = time.process_time() - start
        agreements = " | ".join(f"{found.attrs[f'agreement_{name}']:.3f}" for name in FLOW_INDICATORS)
        print(f"| {tau:g} | {agreements} | {found.attrs['chaotic_fraction_sali']:.3f} | {differences:.1f} | "
              f"{gradient:.1f} |")
    print(f"defined starts: {found.attrs['defined_starts']} of {len(states)}; load {os.getloadavg()}")
    if args.figure:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        defined = found.defined.values
        fields = {"sali": np.maximum(found.sali.values, 1e-16), **{name: found[name].values for name in FLOW_INDICATORS}}
        figure, axes = plt.subplots(1, len(fields), figsize=(4.2 * len(fields), 4), constrained_layout=True)
        for ax, (name, values) in zip(axes, fields.items()):
            shown = np.log10(np.where(defined & (values > 0), values, np.nan))
            image = ax.pcolormesh(found.y, found.py, shown.T, shading="nearest",
                                  cmap="viridis_r" if name == "sali" else "viridis")
            title = "log10 SALI" if name == "sali" else (f"log10 {name}, agreement "
                                                         f"{found.attrs[f'agreement_{name}']:.2f}")
            ax.set_title(title, fontsize=9)
            ax.set_xlabel("y")
            ax.set_ylabel("py")
            figure.colorbar(image, ax=ax)
        figure.savefig(args.figure, dpi=100)
        print(f"wrote {args.figure}")


if __name__ == "__main__":
    main()
