"""The discrete LD of a map: ldpipe's compiled iteration against numpy over the whole grid.

A map's step is a few flops (the Hénon map: five), so the question is whether a compiled loop
over the starts (``ldpipe.engine.discrete_map``, one thread and all of them) is worth it over
numpy doing each operation on the whole grid's arrays once per iteration (escapes masked, the
same definition: the LD's two halves, the iterations before an escape). Both compute the same
numbers; the script checks that the LDs agree to rounding and reports CPU seconds per million
point-iterations (one half of the LD, forward), the fastest of ``--repeat`` interleaved rounds.

    python benchmarks/map_ld.py --points 1000 --iterations 20 --repeat 3
"""

from __future__ import annotations

import argparse
import time

import numpy as np


def numpy_henon_half(x: np.ndarray, y: np.ndarray, a: float, b: float, iterations: int, p: float,
                     radius: float) -> tuple[np.ndarray, np.ndarray]:
    """The forward half of the Hénon map's discrete LD by numpy on whole arrays: (LD, iterations held)."""
    x, y = x.copy(), y.copy()
    total = np.zeros_like(x)
    held = np.zeros(x.shape, dtype=np.int64)
    alive = (np.abs(x) <= radius) & (np.abs(y) <= radius)
    with np.errstate(over="ignore", invalid="ignore"):
        for _ in range(iterations):
            new_x = 1 - a * x * x + y
            new_y = b * x
            inside = alive & np.isfinite(new_x) & np.isfinite(new_y) & (np.abs(new_x) <= radius) \
                & (np.abs(new_y) <= radius)
            if p == 0.5:  # as the engine: a square root, not a power
                increment = np.sqrt(np.abs(new_x - x)) + np.sqrt(np.abs(new_y - y))
            else:
                increment = np.abs(new_x - x) ** p + np.abs(new_y - y) ** p
            total = np.where(inside, total + increment, total)
            held += inside
            x = np.where(inside, new_x, x)
            y = np.where(inside, new_y, y)
            alive = inside
    return total, held


def cpu_time(function) -> tuple[float, object]:
    start = time.process_time()
    result = function()
    return time.process_time() - start, result


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--points", type=int, default=1000, help="grid points per axis")
    parser.add_argument("--iterations", type=int, default=20)
    parser.add_argument("--repeat", type=int, default=3)
    args = parser.parse_args()

    import numba

    import ldpipe
    from ldpipe.engine.discrete_map import iterate_map_ld

    henon = ldpipe.system(map="henon")
    a, b = henon.parameters["a"], henon.parameters["b"]
    axis_x = np.linspace(-1.5, 1.5, args.points)
    axis_y = np.linspace(-0.5, 0.5, args.points)
    grid_x, grid_y = np.meshgrid(axis_x, axis_y, indexing="ij")
    states = np.column_stack([grid_x.ravel(), grid_y.ravel()])
    radius, p = 100.0, 0.5
    iterate_map_ld(henon, states[:10], args.iterations, p, 1, radius)  # compiled, or loaded from the cache
    threads = numba.get_num_threads()
    best = {}
    results = {}
    for _ in range(args.repeat):
        for name, count in (("engine, 1 thread", 1), (f"engine, {threads} threads", threads)):
            numba.set_num_threads(count)
            seconds, result = cpu_time(lambda: iterate_map_ld(henon, states, args.iterations, p, 1, radius))
            wall_start = time.perf_counter()
            iterate_map_ld(henon, states, args.iterations, p, 1, radius)
            wall = time.perf_counter() - wall_start
            best[name] = min(best.get(name, (np.inf, np.inf)), (seconds, wall))
            results[name] = result
        numba.set_num_threads(threads)
        wall_start = time.perf_counter()
        seconds, result = cpu_time(lambda: numpy_henon_half(grid_x.ravel(), grid_y.ravel(), a, b,
                                                            args.iterations, p, radius))
        wall = time.perf_counter() - wall_start
        best["numpy, whole grid"] = min(best.get("numpy, whole grid", (np.inf, np.inf)), (seconds, wall))
        results["numpy, whole grid"] = result
    engine = results["engine, 1 thread"]
    ld, held = results["numpy, whole grid"]
    assert np.array_equal(engine.iterations, held), "the iterations held differ"
    difference = float(np.max(np.abs(engine.ld - ld) / np.maximum(np.abs(ld), 1e-300)))
    work = states.shape[0] * args.iterations / 1e6
    print(f"Hénon map (a = {a}, b = {b}), {args.points}^2 starts, N = {args.iterations} forward, p = {p}, "
          f"escape radius {radius}; {int((engine.escaped).sum())} orbits escape; "
          f"largest relative LD difference engine - numpy: {difference:.2g}")
    print("| method | CPU s | wall s | CPU s per 1e6 point-iterations |")
    print("| --- | ---: | ---: | ---: |")
    for name, (seconds, wall) in best.items():
        print(f"| {name} | {seconds:.3f} | {wall:.3f} | {seconds / work:.4f} |")


if __name__ == "__main__":
    main()
