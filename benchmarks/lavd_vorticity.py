"""CPU seconds of the LAVD's data vorticity (``ldpipe.core.structures.lavd.data_vorticity``) on a
200 x 200 grid of points, the translating Gaussian vortex of tests/structures/test_lavd_data.py
sampled every 0.05: one call per check of the LAVD's trajectories.

    PYTHONPATH=src .venv/bin/python benchmarks/lavd_vorticity.py [--repeat 5]

Prints the fastest of ``--repeat`` calls in CPU seconds of this process (one thread: the vorticity
runs in Python and the kernel, no thread pool) and the vorticity's checksum, so two trees'
results can be compared for identity.
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

import numpy as np
import xarray as xr

R, W0, U, T = 0.3, 1.0, 0.5, 4.0  # the vortex of tests/structures/test_lavd_data.py


def vortex_system(folder: Path, cell: float = 0.05, step: float = 0.1):
    """The vortex sampled every ``cell`` in x, y and ``step`` in time, as a velocity data system."""
    import ldpipe

    x, y = np.arange(-1.5, 3.7 + cell / 2, cell), np.arange(-1.4, 1.4 + cell / 2, cell)
    t = np.arange(-step, T + 2 * step, step)
    tt, yy, xx = np.meshgrid(t, y, x, indexing="ij")
    dx = xx - U * tt
    r2 = dx**2 + yy**2
    g = np.where(r2 > 0, -np.expm1(-r2 / R**2) / np.where(r2 > 0, r2, 1.0), 1 / R**2)
    k = W0 * R**2 / 2
    dims = ("time", "y", "x")
    xr.Dataset({"u": (dims, U - k * g * yy, {"units": "m/s"}), "v": (dims, k * g * dx, {"units": "m/s"})},
               coords={"x": x, "y": y, "time": ("time", t, {"units": "s"})}).to_netcdf(folder / "vortex.nc")
    return ldpipe.system(name="vortex_data", velocity_data={"path": str(folder / "vortex.nc")})


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=5)
    parser.add_argument("--points", type=int, default=200)
    args = parser.parse_args()
    from ldpipe.core.structures.lavd import data_vorticity

    with tempfile.TemporaryDirectory() as folder:
        system = vortex_system(Path(folder))
        x, y = np.meshgrid(np.linspace(-1.0, 1.03, args.points), np.linspace(-0.98, 1.0, args.points), indexing="ij")
        points = np.column_stack([x.ravel(), y.ravel()])
        data_vorticity(system, points[:10], 1.0)  # load the kernel and the data before timing
        best = np.inf
        for _ in range(args.repeat):
            start = time.process_time()
            omega = data_vorticity(system, points, 1.0)
            best = min(best, time.process_time() - start)
    print(f"points {len(points)} cpu_s {best:.4f} per_point_us {1e6 * best / len(points):.2f} "
          f"checksum {float(np.sum(omega)):.17g}")


if __name__ == "__main__":
    main()
