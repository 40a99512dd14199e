"""A map of 10^7 start points on velocity data streamed to zarr on a Dask LocalCluster: the peak
memory of each worker, against the map's size.

The data are ldpipe's example currents (``python -m ldpipe.data.example``: 0.25 degree, 6-hourly)
written to a netCDF file the workers open themselves; the map is the forward LD (``directions:
forward``, no FTLE by differences, which gathers one start time's whole flow map) over ``--tau``
days on an N x N' grid of the basin, computed with ``chunks="auto"`` (or ``--chunks``) and written
block by block to a zarr store (``store=``). Each worker is a process of one thread; its peak
resident memory is read from the kernel (``VmHWM`` in ``/proc/self/status``) after a small map has
opened the data and loaded the engine in every worker, and again after the map; the client's own
peak beside it. Run once per map size (``--points``), each on a fresh cluster, so
that the peaks are each size's own.
"""

from __future__ import annotations

import argparse
import os
import shutil
import tempfile
import time
from pathlib import Path


def peak_mb() -> float:
    """This process's peak resident memory in MB since it started its program (Linux's VmHWM;
    ``getrusage``'s ``ru_maxrss`` would also count the parent it was forked from)."""
    for line in Path("/proc/self/status").read_text().splitlines():
        if line.startswith("VmHWM:"):
            return int(line.split()[1]) / 1024
    return float("nan")


def run(points: int, tau: float, workers: int, chunks, folder: Path, data: Path) -> dict:
    import distributed

    import ldpipe

    columns = int(round((points * 25 / 40) ** 0.5))  # the basin's aspect: 40 degrees by 25
    rows = points // columns
    currents = ldpipe.system(name="currents", velocity_data={"path": str(data), "coordinates": "sphere"})
    section = ldpipe.section(lon=(-74.0, -41.0, rows), lat=(26.0, 49.0, columns))
    store = folder / f"map_{points}.zarr"
    with distributed.LocalCluster(n_workers=workers, threads_per_worker=1, dashboard_address=":0",
                                  memory_limit="4GB") as cluster, distributed.Client(cluster) as client:
        small = ldpipe.section(lon=(-74.0, -41.0, 8), lat=(26.0, 49.0, 8))
        ldpipe.ld_map(currents, name="warm", section=small, t0=10.0, tau=tau, directions="forward", chunks=8,
                      client=client, threads=1).compute()  # each worker opens the data, loads the engine
        before = client.run(peak_mb)
        start = time.perf_counter()
        stored = ldpipe.ld_map(currents, name="currents", section=section, t0=10.0, tau=tau, directions="forward",
                               chunks=chunks, client=client, store=store, threads=1)
        wall = time.perf_counter() - start
        after = client.run(peak_mb)
        blocks = len(list(Path(str(store) + ".blocks").glob("*.done")))
    assert int(stored.ld_forward.notnull().sum()) > 0.5 * rows * columns  # most of the basin is sea
    stored.close()
    shutil.rmtree(store)
    return {"points": rows * columns, "wall": wall, "blocks": blocks, "peaks": [(after[worker], before[worker]) for worker in sorted(after)],
            "client": peak_mb()}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--points", type=int, nargs="+", default=[1_000_000, 10_000_000])
    parser.add_argument("--tau", type=float, default=1.0, help="days")
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--chunks", type=lambda value: value if value == "auto" else int(value), default="auto")
    args = parser.parse_args()

    from ldpipe.data.example import write_example

    with tempfile.TemporaryDirectory() as name:
        folder = Path(name)
        data = folder / "currents.nc"
        write_example(data, days=20.0)
        rows = [run(points, args.tau, args.workers, args.chunks, folder, data) for points in args.points]
    print(f"forward LD of the example currents, tau {args.tau} days, {args.workers} workers of one thread, "
          f"chunks {args.chunks}; load average {os.getloadavg()[0]:.2f}, {os.cpu_count()} cores")
    print("| start points | blocks | wall s | points a second | each worker's peak MB (before the map) "
          "| client's peak MB |")
    print("| ---: | ---: | ---: | ---: | --- | ---: |")
    for row in rows:
        peaks = ", ".join(f"{after:.0f} ({before:.0f})" for after, before in row["peaks"])
        print(f"| {row['points']} | {row['blocks']} | {row['wall']:.1f} | {row['points'] / row['wall']:.0f} "
              f"| {peaks} | {row['client']:.0f} |")


if __name__ == "__main__":
    main()
