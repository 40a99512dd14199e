"""Maps computed lazily on Dask (``ldpipe.ld_map(..., chunks=...)``) on a two-process LocalCluster.

The expected values are the one-process maps of the same arguments: every trajectory is
integrated on its own, and the blocks are the map's own band computation, so however the map
is cut the gathered Dataset must equal it bit for bit, data, flags and attributes (an
invariant of the tiling, no tolerance). The systems and settings are those other tests compile
already: Hénon–Heiles with DOP853 at rtol 1e-8 (tests/test_api.py, here with its FTLE by
differences too) and the gridded double gyre of tests/data/test_start_times.py (three start times).
"""

import copy
import sys

import numpy as np
import pytest
import xarray as xr

import ldpipe
from ldpipe.errors import ConfigError
from support.double_gyre import double_gyre_velocity
from support.gridded import write_velocity_file
from support.henon_heiles import HENON_HEILES
from support.stage_files import assert_same_file

distributed = pytest.importorskip("distributed")
dask_array = pytest.importorskip("dask.array")

HH_SECTION = {"axes": [{"name": "y", "range": [-0.45, 0.8], "points": 40},
                       {"name": "py", "range": [-0.5, 0.5], "points": 40}], "fixed": {"px": 0.0}, "solve": "x",
              "root": "largest"}
HH_MAP = {"section": HH_SECTION, "energy": 0.125, "tau": 2.0,
          "integrator": {"scheme": "dop853", "rtol": 1e-8, "atol": 1e-8}}
H = 1.0 / 8
GYRE_MAP = {"tau": 1.5, "p": 0.5, "ftle": True, "integrator": {"rtol": 1e-9, "atol": 1e-9},
            "t0": {"first": 2.0, "last": 3.0, "count": 3},
            "section": {"axes": [{"name": "x", "range": [0.1, 1.9], "points": 6},
                                 {"name": "y", "range": [0.1, 0.9], "points": 4}]}}


@pytest.fixture(scope="module")
def client():
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=":0") as cluster:
        with distributed.Client(cluster) as client:
            yield client


@pytest.fixture(scope="module")
def hh():
    return ldpipe.system(name="henon_heiles", **HENON_HEILES)


@pytest.fixture(scope="module")
def hh_eager(hh):
    return {ftle: ldpipe.ld_map(hh, name="hh", ftle=ftle, **copy.deepcopy(HH_MAP)) for ftle in (False, True)}


@pytest.fixture(scope="module")
def gyre(tmp_path_factory):
    x, y, t = np.arange(0, 2 + H / 2, H), np.arange(0, 1 + H / 2, H), np.arange(0.0, 6.0 + H / 2, H)
    path = write_velocity_file(tmp_path_factory.mktemp("gyre") / "gyre.nc", double_gyre_velocity, x, y, t)
    return ldpipe.system(name="gyre", velocity_data={"path": str(path)})


@pytest.mark.parametrize("ftle, chunks, blocks", [(False, 300, 6), (True, {"y": 13}, 4)])
def test_a_lazy_map_computes_to_the_one_process_map_bit_for_bit(client, hh, hh_eager, ftle, chunks, blocks):
    # 300 points are 7 rows of 40 (6 blocks, the last of 5 rows); 13 rows a block: 4 blocks, the last of 1.
    lazy = ldpipe.ld_map(hh, name="hh", ftle=ftle, chunks=chunks, client=client, **copy.deepcopy(HH_MAP))
    assert isinstance(lazy.ld_forward.data, dask_array.Array) and lazy.ld_forward.data.numblocks == (blocks, 1)
    assert isinstance(lazy.allowed.data, np.ndarray)  # known from the section alone, before any block
    futures = distributed.futures_of(lazy)  # the blocks went to this client's cluster (persisted)
    assert futures and all(future.client is client for future in futures)
    assert ("ftle_forward" in lazy) == ftle
    computed = lazy.compute()
    allowed = computed.allowed.values  # every block integrated, none left at the skeleton's zeros
    assert 0 < allowed.sum() < allowed.size and (computed.steps_forward.values[allowed] > 0).all()
    assert_same_file(computed, hh_eager[ftle])


def test_a_worker_killed_after_its_blocks_leaves_the_same_map(client, hh, hh_eager):
    # The worker holding a finished block is killed (its nanny starts another): the scheduler
    # computes the lost block again, elsewhere or on the new worker, and the map is unchanged.
    import os
    import signal
    import time

    lazy = ldpipe.ld_map(hh, name="hh", ftle=False, chunks=200, client=client, **copy.deepcopy(HH_MAP))
    futures = distributed.futures_of(lazy)
    deadline = time.monotonic() + 60
    while not any(f.done() for f in futures) and time.monotonic() < deadline:
        time.sleep(0.05)
    finished = next(f for f in futures if f.done())
    holder = client.who_has([finished])[finished.key][0]
    os.kill(client.run(os.getpid, workers=[holder])[holder], signal.SIGKILL)
    assert_same_file(lazy.compute(), hh_eager[False])
    assert holder not in client.scheduler_info()["workers"]  # the block's worker did die


def test_start_times_with_ftle_equal_the_one_process_map(client, gyre):
    eager = ldpipe.ld_map(gyre, name="g", **copy.deepcopy(GYRE_MAP))
    lazy = ldpipe.ld_map(gyre, name="g", chunks={"x": 4, "y": -1}, client=client, **copy.deepcopy(GYRE_MAP))
    assert lazy.ftle_forward.dims == ("t0", "x", "y") and lazy.ld_forward.data.numblocks == (3, 2, 1)
    assert_same_file(lazy.compute(), eager)


@pytest.mark.parametrize("lazy_data", [False, True], ids=["numpy", "dask-backed"])
def test_velocity_data_in_memory_reach_the_workers(client, gyre, lazy_data):
    # a Dataset held by the notebook (not a file the workers could open): each block's task
    # gets it with the graph (without it, every block fails: no dataset by that hash in the
    # worker); a dask-backed one is read inside the task
    path = gyre.spec["velocity_data"]["path"]
    data = xr.open_dataset(path, chunks={"time": 8}) if lazy_data else xr.load_dataset(path)
    system = ldpipe.system(name="gyre", velocity_data={"dataset": data})
    spec = {**copy.deepcopy(GYRE_MAP), "t0": 2.0}
    eager = ldpipe.ld_map(system, name="g", **copy.deepcopy(spec))
    lazy = ldpipe.ld_map(system, name="g", chunks={"x": 2}, client=client, **copy.deepcopy(spec))
    assert_same_file(lazy.compute(), eager)
    data.close()


def test_a_flow_map_without_its_ld_in_blocks_equals_the_one_process_map(gyre):
    # ld: false (the flow map and its FTLE by the flow driver, tests/data/test_flow_map_only.py's
    # settings), two start times, on this process's threads
    import dask

    spec = {**copy.deepcopy(GYRE_MAP), "ld": False, "t0": [2.0, 2.5]}
    eager = ldpipe.ld_map(gyre, name="g", **copy.deepcopy(spec))
    with dask.config.set(scheduler="threads"):
        lazy = ldpipe.ld_map(gyre, name="g", chunks=8, **copy.deepcopy(spec))  # 8 points: bands of 2 rows
        assert lazy.end_x_forward.data.numblocks == (2, 3, 1) and "ld_forward" not in lazy
        assert_same_file(lazy.compute(), eager)


def test_a_map_of_one_direction_in_blocks_and_streamed_equals_the_one_process_map(hh, tmp_path):
    # directions: backward, with its FTLE by differences: the blocks and the FTLE task hold that
    # direction's variables alone
    import dask

    spec = {**copy.deepcopy(HH_MAP), "ftle": True, "directions": "backward"}
    eager = ldpipe.ld_map(hh, name="hh", **copy.deepcopy(spec))
    assert "ftle_backward" in eager and "ld_forward" not in eager
    with dask.config.set(scheduler="synchronous"):
        assert_same_file(ldpipe.ld_map(hh, name="hh", chunks=500, **copy.deepcopy(spec)).compute(), eager)
        stored_equals(ldpipe.ld_map(hh, name="hh", chunks=500, store=tmp_path / "b.zarr", **copy.deepcopy(spec)),
                      eager)


def test_the_active_scheduler_computes_without_a_client(hh, hh_eager):
    # no client given: the Dataset is computed where dask computes (here the threads of this process)
    import dask

    lazy = ldpipe.ld_map(hh, name="hh", ftle=False, chunks=800, **copy.deepcopy(HH_MAP))
    with dask.config.set(scheduler="threads"):
        assert_same_file(lazy.compute(), hh_eager[False])


def test_a_lazy_map_goes_to_zarr(client, hh, hh_eager, tmp_path):
    lazy = ldpipe.ld_map(hh, name="hh", ftle=False, chunks=400, client=client, **copy.deepcopy(HH_MAP))
    lazy.to_zarr(tmp_path / "hh.zarr", zarr_format=2)  # format 3 warns on consolidating its metadata
    with xr.open_zarr(tmp_path / "hh.zarr") as stored:
        for name, variable in hh_eager[False].data_vars.items():
            assert stored[name].dtype == variable.dtype, name
            np.testing.assert_array_equal(stored[name].values, variable.values, err_msg=name)
        assert stored.attrs["parameters"] == hh_eager[False].attrs["parameters"]


@pytest.mark.parametrize("chunks, message", [
    (0, "expected a positive number of points per block, got 0"),
    (-40, "expected a positive number of points per block, got -40"),
    (2.5, "expected points per block"),
    ("many", "or 'auto'"),
    (True, "expected points per block"),
    ({"y": 0}, r"argument 'chunks.y': expected a positive number of rows"),
    ({"y": 5, "py": 7}, r"argument 'chunks.py': blocks are bands of whole rows"),
    ({"z": 5}, r"unknown axes \['z'\]"),
])
def test_bad_chunks_are_refused_by_name_before_any_task(client, hh, chunks, message, monkeypatch):
    sent = []
    for method in ("persist", "compute", "submit", "map"):  # every way a graph goes to the cluster
        monkeypatch.setattr(client, method, lambda *args, **kwargs: sent.append(args))
    with pytest.raises(ConfigError, match=r"ldpipe.ld_map: argument 'chunks[.']") as error:
        ldpipe.ld_map(hh, name="hh", chunks=chunks, client=client, **copy.deepcopy(HH_MAP))
    assert error.match(message)
    assert sent == []


def test_a_closed_or_wrong_client_and_a_client_without_chunks_are_refused(hh):
    with distributed.Client(n_workers=1, threads_per_worker=1, processes=False, dashboard_address=":0") as closed:
        pass
    with pytest.raises(ConfigError, match=r"ldpipe.ld_map: argument 'client': the client is closed, not running"):
        ldpipe.ld_map(hh, name="hh", chunks=400, client=closed, **copy.deepcopy(HH_MAP))
    with pytest.raises(ConfigError, match=r"argument 'client': expected a distributed.Client, got str"):
        ldpipe.ld_map(hh, name="hh", chunks=400, client="tcp://localhost:8786", **copy.deepcopy(HH_MAP))
    with pytest.raises(ConfigError, match=r"argument 'client': a map in blocks takes a client; give chunks too"):
        ldpipe.ld_map(hh, name="hh", client=closed, **copy.deepcopy(HH_MAP))


def test_chunks_without_dask_are_refused_naming_the_install(hh, monkeypatch):
    for name in ("dask", "dask.array"):
        monkeypatch.setitem(sys.modules, name, None)  # as if not installed: importing it raises ImportError
    with pytest.raises(ConfigError, match=r"argument 'chunks': a map in blocks \(chunks\) needs dask.*ldpipe\[dask\]"):
        ldpipe.ld_map(hh, name="hh", chunks=400, **copy.deepcopy(HH_MAP))


def stored_equals(store_map: xr.Dataset, eager: xr.Dataset) -> None:
    """The map a store holds equals the one-process map: every variable bit for bit with its
    dtype, the coordinates, and the recorded parameters (zarr keeps attributes as JSON)."""
    assert set(store_map.variables) == set(eager.variables)
    for name, variable in eager.variables.items():
        assert store_map[name].dtype == variable.dtype, name
        np.testing.assert_array_equal(store_map[name].values, variable.values, err_msg=name)
    assert store_map.attrs["parameters"] == eager.attrs["parameters"]


def test_an_interrupted_stream_resumes_its_missing_blocks_to_the_same_map(hh, hh_eager, tmp_path, monkeypatch):
    # In this process (the synchronous scheduler), so that a block can be made to fail: 300 points
    # a block are 6 blocks of the FTLE map, then its FTLE from the stored flow map.
    import dask
    from ldpipe.core.maps import zarr_stream

    store, calls, compute_block = tmp_path / "hh.zarr", [], zarr_stream.compute_block

    def failing_third(*args):
        calls.append(args[2])
        if len(calls) == 3:
            raise RuntimeError("the kernel died")
        return compute_block(*args)

    monkeypatch.setattr(zarr_stream, "compute_block", failing_third)
    with dask.config.set(scheduler="synchronous"), pytest.raises(RuntimeError, match="the kernel died"):
        ldpipe.ld_map(hh, name="hh", ftle=True, chunks=300, store=store, **copy.deepcopy(HH_MAP))
    markers = zarr_stream.markers_folder(store)
    assert sorted(p.name for p in markers.iterdir()) == sorted(zarr_stream.block_name(0, r) for r in calls[:2])
    # a block whose region was written but whose marker was not: written again
    kept, half = calls[0], calls[1]
    (markers / zarr_stream.block_name(0, half)).unlink()
    zeros = {name: np.zeros((half.stop - half.start, 40)) for name in ("ld_forward", "exit_time_forward")}
    zarr_stream.write_region(store, zeros, dict.fromkeys(zeros, ("y", "py")), None, half)
    calls.clear()
    monkeypatch.setattr(zarr_stream, "compute_block", lambda *args: calls.append(args[2]) or compute_block(*args))
    with dask.config.set(scheduler="synchronous"):
        resumed = ldpipe.ld_map(hh, name="hh", ftle=True, chunks=300, store=store, **copy.deepcopy(HH_MAP))
    assert sorted(r.start for r in calls) == [s for s in range(0, 40, 7) if s != kept.start]  # all but the one kept
    stored_equals(resumed, hh_eager[True])
    with dask.config.set(scheduler="synchronous"):  # a finished stream: nothing left to compute
        calls.clear()
        stored_equals(ldpipe.ld_map(hh, name="hh", ftle=True, chunks=300, store=store, **copy.deepcopy(HH_MAP)),
                      hh_eager[True])
        # chunks="auto" resumes a store as it was cut, whatever a new pilot would choose
        stored_equals(ldpipe.ld_map(hh, name="hh", ftle=True, chunks="auto", store=store, **copy.deepcopy(HH_MAP)),
                      hh_eager[True])
        assert calls == []


def test_a_stream_on_the_cluster_writes_start_times_from_the_workers(client, gyre, tmp_path):
    eager = ldpipe.ld_map(gyre, name="g", **copy.deepcopy(GYRE_MAP))
    stored = ldpipe.ld_map(gyre, name="g", chunks={"x": 4}, client=client, store=tmp_path / "g.zarr",
                           **copy.deepcopy(GYRE_MAP))
    stored_equals(stored, eager)
    assert len(list((tmp_path / "g.zarr.blocks").glob("*.done"))) == 3 * 2 + 3  # 2 bands and an FTLE a start time


def test_a_store_of_another_map_or_cut_otherwise_is_refused_by_name(hh, tmp_path):
    import dask

    small = {**copy.deepcopy(HH_MAP), "section": {**HH_SECTION, "axes": [{**HH_SECTION["axes"][0], "points": 6},
                                                                          {**HH_SECTION["axes"][1], "points": 5}]}}
    store = tmp_path / "m.zarr"
    with dask.config.set(scheduler="synchronous"):
        ldpipe.ld_map(hh, name="hh", chunks={"y": 2}, store=store, **copy.deepcopy(small))
        with pytest.raises(ConfigError, match=r"argument 'store': .*m.zarr holds another map"):
            ldpipe.ld_map(hh, name="hh", chunks={"y": 2}, store=store, **{**copy.deepcopy(small), "tau": 1.0})
        with pytest.raises(ConfigError, match=r"argument 'chunks': .*started with blocks of 2 rows, these chunks "
                                              r"give 3; resume it with chunks=\{'y': 2\}"):
            ldpipe.ld_map(hh, name="hh", chunks={"y": 3}, store=store, **copy.deepcopy(small))
    with pytest.raises(ConfigError, match=r"argument 'store': a map in blocks takes a store; give chunks too"):
        ldpipe.ld_map(hh, name="hh", store=store, **copy.deepcopy(small))


def test_auto_chunks_give_blocks_of_about_a_second_and_the_same_map(hh, hh_eager, monkeypatch):
    # chunks="auto" sizes blocks by a pilot of the map's own trajectories; a block's integration
    # is made small here (and a call's fixed cost let be any share of it) so that this small map
    # is cut into several
    import dask

    from ldpipe.core.maps import lazy

    monkeypatch.setattr(lazy, "AUTO_BLOCK_SECONDS", 1e-4)
    monkeypatch.setattr(lazy, "AUTO_FIXED_SHARE", 1e9)
    auto = ldpipe.ld_map(hh, name="hh", ftle=False, chunks="auto", **copy.deepcopy(HH_MAP))
    assert auto.ld_forward.data.numblocks[0] > 2
    with dask.config.set(scheduler="synchronous"):
        assert_same_file(auto.compute(), hh_eager[False])


def test_a_noisy_map_in_blocks_and_streamed_equals_the_one_process_map(client, tmp_path):
    # A map with noise (tests/stages/test_stochastic_map.py's system and noise, so its compiled
    # engine serves): each path's random stream is keyed by its point's index in the whole grid,
    # so bands on two worker processes give the one-process bits; the member dimension is whole
    # in every block, and in the zarr store
    system = ldpipe.system(name="sde_ou_gbm", vector_field={"x": "-theta*x", "y": "mu*y"}, coordinates=["x", "y"],
                           parameters={"theta": 1.0, "mu": 1.0})
    noise = {"diffusion": {"x": "sigma", "y": "beta*y"}, "parameters": {"sigma": 0.5, "beta": 1.0}, "members": 3,
             "seed": 42, "dt": 0.05, "scheme": "milstein"}
    spec = {"section": ldpipe.section(x=(-1, 1, 6), y=(0.5, 1.5, 4)), "tau": 0.5, "p": 0.5, "noise": noise}
    eager = ldpipe.ld_map(system, **copy.deepcopy(spec))
    lazy = ldpipe.ld_map(system, chunks={"x": 2}, client=client, **copy.deepcopy(spec))
    assert lazy.ld_forward.dims == ("member", "x", "y") and lazy.ld_forward.data.numblocks == (1, 3, 1)
    assert_same_file(lazy.compute(), eager)
    stored_equals(ldpipe.ld_map(system, chunks={"x": 4}, client=client, store=tmp_path / "noisy.zarr",
                                **copy.deepcopy(spec)), eager)
    with pytest.raises(ConfigError, match=r"'auto' sizes blocks by a pilot of the deterministic flow"):
        ldpipe.ld_map(system, chunks="auto", **copy.deepcopy(spec))


def test_a_worker_killed_during_a_stream_loses_nothing_written(client, hh, tmp_path):
    # A worker is killed once the first blocks are in the store (its nanny starts another): the
    # scheduler runs its blocks again, the running one and the finished ones whose results (the
    # markers' names) it held; a finished block is in the store and is not written again, and
    # the store equals the one-process map. 40 blocks of one row over tau 2000 (the engine of
    # the other Hénon–Heiles tests: tau changes no compiled code) keep the map running meanwhile.
    import os
    import signal
    import threading
    import time

    from ldpipe.core.maps import zarr_stream

    spec = {**copy.deepcopy(HH_MAP), "tau": 2000.0}
    eager = ldpipe.ld_map(hh, name="hh", **copy.deepcopy(spec))
    store = tmp_path / "hh.zarr"
    markers, seen = zarr_stream.markers_folder(store), {}

    def kill_a_worker_once_blocks_are_in():
        deadline = time.monotonic() + 300
        while time.monotonic() < deadline:
            done = list(markers.glob("*.done")) if markers.exists() else []
            if len(done) >= 2:
                seen["written"] = {path.name: path.stat().st_mtime_ns for path in done}
                worker = sorted(client.scheduler_info()["workers"])[0]
                os.kill(client.run(os.getpid, workers=[worker])[worker], signal.SIGKILL)
                return
            time.sleep(0.005)

    killer = threading.Thread(target=kill_a_worker_once_blocks_are_in)
    killer.start()
    stored = ldpipe.ld_map(hh, name="hh", chunks=40, client=client, store=store, **copy.deepcopy(spec))
    killer.join()
    assert 2 <= len(seen["written"]) < 40  # killed in the middle of the map
    stored_equals(stored, eager)
    assert len(list(markers.glob("*.done"))) == 40
    for name, written in seen["written"].items():  # nothing written before the kill was written again
        assert (markers / name).stat().st_mtime_ns == written, name
