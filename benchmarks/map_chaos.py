"""LD chaos indicators beside the fast Lyapunov indicator on the standard map: maps and agreement.

On a grid of starts of the Chirikov standard map (theta, p in [0, 2 pi)) this computes the LD
indicators of ``ldpipe.core.maps.chaos`` (D_L, S_L of Hillebrand et al. 2022; the Laplacian of
Daquin et al. 2022) at several N, and the FLI over ``--reference`` iterations, and prints the
agreement of each indicator's ordered/chaotic classification with the FLI's, with the CPU time
of each. ``--figure PATH`` draws the FLI and the three indicators side by side (log10 scales).

    python benchmarks/map_chaos.py --points 300 --iterations 50 100 200 --figure benchmarks/results/map_chaos.png
"""

from __future__ import annotations

import argparse
import time

import numpy as np


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--points", type=int, default=300, help="grid points per axis")
    parser.add_argument("--iterations", type=int, nargs="+", default=[50, 100, 200], help="N of the LD")
    parser.add_argument("--reference", type=int, default=1000, help="iterations of the FLI")
    parser.add_argument("--sigma", type=float, default=1e-5, help="distance of the neighbouring starts")
    parser.add_argument("--K", type=float, default=0.971635406)
    parser.add_argument("--figure", default=None)
    args = parser.parse_args()

    import ldpipe
    from ldpipe.core.maps.chaos import INDICATORS, chaos_indicators

    standard = ldpipe.system(name="standard", map="standard", parameters={"K": args.K})
    axis = np.linspace(0, 2 * np.pi, args.points, endpoint=False)
    theta, momentum = np.meshgrid(axis, axis, indexing="ij")
    starts = np.column_stack([theta.ravel(), momentum.ravel()])
    chaos_indicators(standard, starts[:10], iterations=2, sigma=args.sigma, reference_iterations=2)  # compiled
    print(f"standard map K = {args.K}, {args.points}^2 starts, sigma = {args.sigma}, FLI over {args.reference} "
          "iterations (chaotic above 2 log10 N')")
    print("| N | " + " | ".join(f"agreement {name}" for name in INDICATORS) + " | CPU s |")
    print("| ---: | " + " | ".join("---:" for _ in INDICATORS) + " | ---: |")
    found = None
    for iterations in args.iterations:
        start = time.process_time()
        found = chaos_indicators(standard, starts, iterations=iterations, sigma=args.sigma,
                                 reference_iterations=args.reference)
        seconds = time.process_time() - start
        agreements = " | ".join(f"{found.attrs[f'agreement_{name}']:.3f}" for name in INDICATORS)
        print(f"| {iterations} | {agreements} | {seconds:.2f} |")
    print(f"chaotic by the FLI: {float(found.chaotic_fli.mean()):.3f} of the starts; "
          f"{len(starts) - found.attrs['defined_starts']} starts undefined (L = 0 at a fixed point, or escaped)")
    if args.figure:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        defined = found.defined.values
        fields = {"FLI": np.where(defined, found.fli.values, np.nan),
                  **{name: np.log10(np.where(defined & (found[name].values > 0), found[name].values, np.nan))
                     for name in INDICATORS}}
        figure, axes = plt.subplots(1, len(fields), figsize=(4.2 * len(fields), 4), constrained_layout=True)
        for ax, (name, values) in zip(axes, fields.items()):
            low, high = np.nanpercentile(values, [1, 99])
            image = ax.pcolormesh(axis, axis, values.reshape(theta.shape).T, shading="auto", vmin=low, vmax=high)
            title = name if name == "FLI" else (f"log10 {name}, agreement "
                                                f"{found.attrs[f'agreement_{name}']:.2f}")
            ax.set_title(title, fontsize=9)
            ax.set_xlabel("theta")
            ax.set_ylabel("p")
            figure.colorbar(image, ax=ax)
        figure.savefig(args.figure, dpi=100)
        print(f"wrote {args.figure}")


if __name__ == "__main__":
    main()
