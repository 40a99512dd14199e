"""Only the window a map needs is read: a map over a 60 x 60 corner and a few days of a dataset of
2 x 100 x 4000 x 4000 float32 values (12.8 GB as stored, unwritten chunks taking no disk) runs in
a process whose address space is capped at 2 GB. Reading every time (26 GB as float64) or the
whole grid at the map's times (2.6 GB) would not fit under the cap."""

import subprocess
import sys
import textwrap

import netCDF4
import numpy as np

CAP_MB = 2048  # measured peak of the windowed run: 850 MB of address space, 280 MB resident

RUN = textwrap.dedent("""
    import resource, sys
    resource.setrlimit(resource.RLIMIT_AS, ({cap} * 2**20, {cap} * 2**20))
    from ldpipe.config import validate_config
    from ldpipe.core.maps.assembly import compute_ld_map
    from ldpipe.config.parameters import parameters_from_config
    config = validate_config({{
        "systems": {{"big": {{"velocity_data": {{"path": sys.argv[1], "window": {{"x": [0, 60], "y": [0, 60]}}}}}}}},
        "ld_maps": {{"m": {{"system": "big", "t0": 5.0, "tau": 3.0, "p": 0.5,
                           "section": {{"axes": [{{"name": "x", "range": [10, 40], "points": 4}},
                                                {{"name": "y", "range": [10, 40], "points": 4}}]}}}}}}}})
    dataset = compute_ld_map(parameters_from_config(config, "ld", "m"), None, show_progress=False)
    print(repr(float(dataset.ld_forward.values.max())), repr(float(dataset.ld_forward.values.min())))
""")


def write_large_dataset(path, n=4000, times=100):
    """u = 0.1, v = 0.05 m/s written only over the first 12 times and 64 x 64 nodes."""
    with netCDF4.Dataset(path, "w") as dataset:
        for name, size in (("time", times), ("y", n), ("x", n)):
            dataset.createDimension(name, size)
            dataset.createVariable(name, "f8", (name,))[:] = np.arange(size, dtype=float)
        for name, value in (("u", 0.1), ("v", 0.05)):
            variable = dataset.createVariable(name, "f4", ("time", "y", "x"), chunksizes=(1, 64, 64))
            variable.units = "m/s"
            variable[0:12, 0:64, 0:64] = np.full((12, 64, 64), value, dtype=np.float32)


def test_a_small_window_of_a_large_dataset_is_read_alone(tmp_path):
    path = tmp_path / "large.nc"
    write_large_dataset(path)
    done = subprocess.run([sys.executable, "-c", RUN.format(cap=CAP_MB), str(path)], capture_output=True, text=True,
                          timeout=300)
    assert done.returncode == 0, done.stderr[-2000:]
    # a uniform flow: M_1/2 = tau (|u|^1/2 + |v|^1/2), the same at every point (closed form)
    largest, smallest = map(float, done.stdout.split())
    expected = 3.0 * (0.1**0.5 + 0.05**0.5)
    assert abs(largest - expected) < 1e-6 * expected and abs(smallest - expected) < 1e-6 * expected
