"""What a stage file's compression costs: write and read CPU and file size, per setting.

Each stage file given is loaded once (:func:`ldpipe.io.datafile.open_stage_file`) and written
again through :func:`ldpipe.io.datafile.write_stage_file` with each setting in turn (the module's
``COMPRESSION`` swapped for the run), then read back; the settings run interleaved, ``--repeat``
rounds, so a change of load hits all of them. CPU is this process's (``time.process_time``),
the git look-up's child processes left out. Every read-back must equal the loaded data bit for
bit (``numpy.array_equal`` on every variable, values as stored): the script fails otherwise.

Run: ``.venv/bin/python benchmarks/stage_compression.py FILE [FILE ...] [--repeat 3]``; results
by hand in benchmarks/stage_compression.md.
"""

from __future__ import annotations

import argparse
import statistics
import tempfile
import time
from pathlib import Path

import numpy as np
import xarray as xr

from ldpipe.io import datafile

SETTINGS = {
    "none": {},
    "zlib 1": {"zlib": True, "complevel": 1, "shuffle": False},
    "zlib 1 + shuffle": {"zlib": True, "complevel": 1, "shuffle": True},
    "zlib 4": {"zlib": True, "complevel": 4, "shuffle": False},
    "zlib 4 + shuffle": {"zlib": True, "complevel": 4, "shuffle": True},
}


def round_trip(dataset, stage: str, path: Path, setting: dict) -> tuple[float, float, int]:
    """CPU seconds to write ``dataset`` with ``setting`` and read it back, and the file's bytes."""
    original = datafile.COMPRESSION
    datafile.COMPRESSION = setting
    try:
        start = time.process_time()
        datafile.write_stage_file(dataset, path, stage=stage, title=dataset.attrs.get("title", ""),
                                  parameters=datafile.stage_parameters(dataset))
        written = time.process_time()
        back = datafile.open_stage_file(path, stage=stage)
        read = time.process_time()
    finally:
        datafile.COMPRESSION = original
    for name, variable in dataset.variables.items():
        if not np.array_equal(variable.values, back[name].values):
            raise AssertionError(f"{path}: {name} differs after the round trip with {setting}")
    return written - start, read - written, path.stat().st_size


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("files", nargs="+", type=Path)
    parser.add_argument("--repeat", type=int, default=3)
    arguments = parser.parse_args()
    for file in arguments.files:
        stage = xr.open_dataset(file, engine=datafile.ENGINE).attrs[datafile.STAGE_ATTRIBUTE]
        dataset = datafile.open_stage_file(file, stage=stage)
        times = {name: ([], []) for name in SETTINGS}
        sizes = {}
        with tempfile.TemporaryDirectory() as scratch:
            for _ in range(arguments.repeat):
                for name, setting in SETTINGS.items():
                    write, read, size = round_trip(dataset, stage, Path(scratch) / "copy.nc", setting)
                    times[name][0].append(write)
                    times[name][1].append(read)
                    sizes[name] = size
        print(f"\n{file} ({stage}, {dataset.nbytes / 1e6:.1f} MB in memory), {arguments.repeat} rounds; "
              "CPU s median (min-max); every read-back bit-identical")
        print("| setting | write CPU s | read CPU s | file MB |")
        print("| --- | ---: | ---: | ---: |")
        for name in SETTINGS:
            cells = [f"{statistics.median(t):.3f} ({min(t):.3f}-{max(t):.3f})" for t in times[name]]
            print(f"| {name} | {cells[0]} | {cells[1]} | {sizes[name] / 1e6:.2f} |")


if __name__ == "__main__":
    main()
