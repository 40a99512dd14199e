"""The discrete LD of the Hénon map per core: ldpipe's compiled iteration beside ldds' own map code.

ldds (champsproject/ldds, not on PyPI) computes a map's LD with numpy over the whole grid
(``ldds.base_discrete.compute_lagrangian_descriptor``), the forward half with the map and the
backward half with its inverse. Bring a checkout of it (its package folder's parent given by
``--ldds``; its base module imports h5py, which ldpipe does not need: install it anywhere on
PYTHONPATH). Both run the same problem in one process, interleaved round by round: ldds' Hénon
map in its own area-preserving form (x, y) -> (a - x^2 + b y, x) at its default a = 0.298,
b = 1, given to ldpipe as the same formulas, on a grid with p = 1/2 over N iterations each way.
An orbit leaving the box [-R, R]^2 stops there in both (ldds keeps it where it was, adding
nothing, and goes on computing it; ldpipe stops at the escape radius R and moves on), so the
LDs are the same numbers up to rounding (a square root against ldds' power 1/2, amplified along
chaotic orbits): the script prints their largest and median relative difference, the share of
orbits that escape, and CPU seconds per million grid point-iterations (N each way for every
start, both halves), the fastest and slowest of ``--repeat`` interleaved rounds, ldpipe on one
thread (per core) and on all.

    PYTHONPATH=/tmp/ldds_deps python benchmarks/map_ldds.py --ldds /tmp/ldds_src --points 400 --iterations 100
"""

from __future__ import annotations

import argparse
import os
import sys
import time

import numpy as np


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--ldds", required=True, help="the folder holding ldds' package folder ldds/")
    parser.add_argument("--points", type=int, default=400, help="grid points per axis")
    parser.add_argument("--iterations", type=int, default=100, help="N, each way")
    parser.add_argument("--extent", type=float, default=0.8, help="the grid covers [-extent, extent]^2")
    parser.add_argument("--radius", type=float, default=10.0, help="the box [-R, R]^2 an orbit stops at")
    parser.add_argument("--repeat", type=int, default=3)
    args = parser.parse_args()

    sys.path.insert(0, args.ldds)
    import numba
    from ldds.base_discrete import compute_lagrangian_descriptor
    from ldds.discrete_maps import HenonMap, HenonMap_inverse

    import ldpipe
    from ldpipe.engine.discrete_map import iterate_map_ld

    a, b, p, radius = 0.298, 1.0, 0.5, args.radius
    henon = ldpipe.system(name="henon_ldds_form", map={"x": "a - x**2 + b*y", "y": "x"},
                          inverse={"x": "y", "y": "(x - a + y**2)/b"}, coordinates=["x", "y"],
                          parameters={"a": a, "b": b})
    grid = [(-args.extent, args.extent, args.points)] * 2
    axis_x, axis_y = (np.linspace(*limits) for limits in grid)
    mesh_x, mesh_y = np.meshgrid(axis_x, axis_y, indexing="ij")
    states = np.column_stack([mesh_x.ravel(), mesh_y.ravel()])
    box = [(-radius, radius), (-radius, radius)]

    def forward(t, u):
        return HenonMap(t, u, [a, b, 1])

    def backward(t, u):
        return HenonMap_inverse(t, u, [a, b, 1])

    def ldds_total():
        # ldds meshes its grid with the first axis fastest: its array is (y, x); transposed to (x, y)
        halves = [compute_lagrangian_descriptor(grid, step, args.iterations, p, box_boundaries=box)
                  for step in (forward, backward)]
        return (halves[0] + halves[1]).T

    held = {}

    def ldpipe_total():
        halves = [iterate_map_ld(henon, states, args.iterations, p, direction, radius) for direction in (1, -1)]
        held["iterations"] = int(halves[0].iterations.sum() + halves[1].iterations.sum())
        held["escaped"] = float(np.mean(halves[0].escaped | halves[1].escaped))
        return (halves[0].ld + halves[1].ld).reshape(mesh_x.shape)

    ldpipe_total()  # compiled, or loaded from the cache
    threads = numba.get_num_threads()
    times = {"ldds (numpy, whole grid)": [], "ldpipe, 1 thread": [], f"ldpipe, {threads} threads": []}
    results = {}
    load_before = os.getloadavg()
    for _ in range(args.repeat):
        for name in times:
            if name.startswith("ldpipe"):
                numba.set_num_threads(1 if "1 thread" in name else threads)
            start, wall = time.process_time(), time.perf_counter()
            results[name] = ldds_total() if name.startswith("ldds") else ldpipe_total()
            times[name].append((time.process_time() - start, time.perf_counter() - wall))
        numba.set_num_threads(threads)
    reference = results["ldds (numpy, whole grid)"]
    mine = results["ldpipe, 1 thread"]
    relative = np.abs(mine - reference) / np.maximum(np.abs(reference), 1e-300)
    difference = float(np.max(relative))
    typical = float(np.median(relative))
    work = 2 * states.shape[0] * args.iterations / 1e6
    print(f"Hénon map in ldds' form (a = {a}, b = {b}), {args.points}^2 starts of [-{args.extent}, {args.extent}]^2, N = {args.iterations} "
          f"each way, p = {p}, box [-{radius}, {radius}]^2; largest relative LD difference ldpipe - ldds: "
          f"{difference:.2g} (median {typical:.2g}); {held['escaped']:.0%} of the orbits leave the box one way or the "
          f"other, {held['iterations'] / 1e6 / work:.0%} of the point-iterations are inside it; load before {load_before}, after {os.getloadavg()}")
    print("| method | CPU s (best) | CPU s (worst) | wall s (best) | CPU s per 1e6 point-iterations |")
    print("| --- | ---: | ---: | ---: | ---: |")
    for name, runs in times.items():
        cpu = [run[0] for run in runs]
        print(f"| {name} | {min(cpu):.3f} | {max(cpu):.3f} | {min(run[1] for run in runs):.3f} | "
              f"{min(cpu) / work:.4f} |")


if __name__ == "__main__":
    main()
