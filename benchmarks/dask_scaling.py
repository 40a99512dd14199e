"""An LD map on a Dask LocalCluster: one worker against two, and what a block costs besides its integration.

Two maps (``--system``): the Hénon–Heiles slice of the API's examples (y, p_y; p_x = 0; x solved,
E = 0.125; about 5 µs of integration a point at tau 10), and ldpipe's example currents on the
sphere (the LD both ways and the FTLE by differences, tau in days; about 45 µs a point at tau 4),
on an N x N grid. For each chunk size and worker count the map is computed through
``ldpipe.ld_map(..., chunks=, client=)`` on a fresh ``LocalCluster`` (worker processes of one
thread, the engine's ``threads=1`` in each task), after one small map has loaded the engine in
every worker; the one-process map (``threads=1``) is the baseline, and every cluster map is
checked equal to it bit for bit.

Where the wall time goes, from Dask's task stream:

- layout: the client, before any task (the empty band, the section's allowed mask, attributes);
- blocks: the block tasks' compute time, summed over workers;
- gap a block: the time each worker sat idle between its consecutive blocks (the scheduler's
  round trip, the results' transfer), summed and divided by the blocks: the cost a task adds;
- in a block beyond the map's: the summed block time against the one-process map's integration
  of the same points (each task builds its system, section and band Dataset), per block;
- tail: after the last block (the FTLE by differences over the gathered flow map, the gather).

"cost a task" is the last two per block, as a share of a block's integration. Rounds alternate
the configurations; each row is its fastest round. The machine's load is printed with the table.
"""

from __future__ import annotations

import argparse
import os
import time

import numpy as np


def hh_map(ldpipe, n: int, tau: float, **extra):
    """The Hénon–Heiles map (``--system henon_heiles``)."""
    hh = ldpipe.system(name="henon_heiles", formula="(x**2 + y**2)/2 + x**2*y - y**3/3", coordinates=["x", "y"])
    section = ldpipe.section(y=(-0.45, 0.8, n), py=(-0.5, 0.5, n), fixed={"px": 0.0}, solve="x", root="largest")
    return ldpipe.ld_map(hh, name="hh", section=section, energy=0.125, tau=tau, threads=1, **extra)


def currents_map(ldpipe, n: int, tau: float, **extra):
    """The example currents' map (``--system currents``): the meandering jet by a coast on the sphere,
    ``tau`` days from day 2 + tau, both directions, the LD and the FTLE by grid differences."""
    import xarray as xr

    from ldpipe.data.example import example_dataset

    data = xr.decode_cf(example_dataset(days=2.0 + 2 * tau, resolution=0.5))
    currents = ldpipe.system(name="currents", velocity_data={"dataset": data, "coordinates": "sphere"})
    section = ldpipe.section(lon=(-78.0, -42.0, n), lat=(27.0, 48.0, n))
    return ldpipe.ld_map(currents, name="currents", section=section, t0=2.0 + tau, tau=tau, threads=1,
                         **{"ftle": True, **extra})


MAPS = {"henon_heiles": hh_map, "currents": currents_map}


def one_process(ldpipe, make_map, n: int, tau: float) -> tuple[float, object]:
    """(wall s, the map) of the one-process map without its FTLE by differences: its integration."""
    start = time.perf_counter()
    plain = make_map(ldpipe, n, tau, **({"ftle": False} if make_map is currents_map else {}))
    return time.perf_counter() - start, plain


def cluster_run(ldpipe, distributed, make_map, n: int, tau: float, workers: int, chunks: int, eager) -> dict:
    """Where one map's wall time went on a fresh cluster of ``workers`` (see the module's doc)."""
    with distributed.LocalCluster(n_workers=workers, threads_per_worker=1, dashboard_address=":0") as cluster, \
            distributed.Client(cluster) as client:
        make_map(ldpipe, 8, tau, chunks=8, client=client).compute()  # the engine loaded in every worker
        with distributed.get_task_stream(client) as stream:
            start, epoch = time.perf_counter(), time.time()
            lazy = make_map(ldpipe, n, tau, chunks=chunks, client=client)
            layout = time.perf_counter() - start
            result = lazy.compute()
            wall = time.perf_counter() - start
    for name in eager.data_vars:
        assert np.array_equal(result[name].values, eager[name].values, equal_nan=eager[name].dtype.kind == "f"), name
    spans: dict[str, list[tuple[float, float]]] = {}
    for task in stream.data:
        if "compute_block" in str(task["key"]):
            for part in task["startstops"]:
                if part["action"] == "compute":
                    spans.setdefault(task["worker"], []).append((part["start"], part["stop"]))
    blocks = sum(map(len, spans.values()))
    busy = sum(stop - begin for worker in spans.values() for begin, stop in worker)
    gaps = sum(later[0] - earlier[1] for worker in spans.values()
               for earlier, later in zip(sorted(worker), sorted(worker)[1:]))
    last = max(stop for worker in spans.values() for _, stop in worker)
    return {"wall": wall, "layout": layout, "blocks": blocks, "busy": busy, "gaps": gaps,
            "tail": epoch + wall - last}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--system", choices=sorted(MAPS), default="henon_heiles")
    parser.add_argument("--n", type=int, default=300, help="grid points per axis")
    parser.add_argument("--tau", type=float, default=10.0)
    parser.add_argument("--chunks", type=lambda value: value if value == "auto" else int(value), nargs="+",
                        default=["auto"], help="points per block, or auto")
    parser.add_argument("--workers", type=int, nargs="+", default=[1, 2])
    parser.add_argument("--rounds", type=int, default=2)
    args = parser.parse_args()

    import distributed

    import ldpipe

    make_map = MAPS[args.system]
    make_map(ldpipe, 8, args.tau)  # compile or load the engine here
    start = time.perf_counter()
    eager = make_map(ldpipe, args.n, args.tau)
    eager_wall = time.perf_counter() - start
    integration = min(one_process(ldpipe, make_map, args.n, args.tau)[0] for _ in range(args.rounds))
    best: dict[tuple[int, int], dict] = {}
    for _ in range(args.rounds):
        for chunks in args.chunks:
            for workers in args.workers:
                run = cluster_run(ldpipe, distributed, make_map, args.n, args.tau, workers, chunks, eager)
                if (workers, chunks) not in best or run["wall"] < best[workers, chunks]["wall"]:
                    best[workers, chunks] = run
    print(f"{args.system} {args.n} x {args.n} ({int(eager.allowed.sum())} allowed points), tau {args.tau}; "
          f"load average before the table {os.getloadavg()[0]:.2f}, {os.cpu_count()} cores")
    print(f"one process, one thread: {eager_wall:.2f} s; its integration (no FTLE by differences) {integration:.2f} s")
    print("| workers | points a block | blocks | wall s | speed-up vs 1 worker | layout s | block s (summed) "
          "| a block's integration ms | gap a block ms | in a block beyond the map's ms | cost a task % | tail s |")
    print("| ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: |")
    for (workers, chunks), run in sorted(best.items(), key=lambda item: (str(item[0][1]), item[0][0])):
        one = best.get((1, chunks))
        ratio = f"{one['wall'] / run['wall']:.2f}" if one else ""
        blocks = max(run["blocks"], 1)
        integrate = integration / blocks
        gap = run["gaps"] / blocks
        beyond = max(run["busy"] - integration, 0.0) / blocks
        print(f"| {workers} | {chunks} | {run['blocks']} | {run['wall']:.2f} | {ratio} | {run['layout']:.2f} "
              f"| {run['busy']:.2f} | {integrate * 1e3:.0f} | {gap * 1e3:.1f} | {beyond * 1e3:.1f} "
              f"| {100 * (gap + beyond) / integrate:.1f} | {run['tail']:.2f} |")


if __name__ == "__main__":
    main()
