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


class GraphsSent(distributed.diagnostics.plugin.SchedulerPlugin):
    """Counts the graphs clients send to the scheduler (a map's blocks arrive as one)."""

    def __init__(self):
        self.count = 0

    def update_graph(self, scheduler, **kwargs):
        self.count += 1


@pytest.fixture(scope="module")
def client():
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=":0") as cluster:
        cluster.scheduler.add_plugin(GraphsSent(), name="graphs-sent")  # the scheduler runs in this process
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


def graphs_sent(client) -> int:
    return client.cluster.scheduler.plugins["graphs-sent"].count


@pytest.mark.parametrize("ftle, chunks, blocks", [(False, 300, 6), (True, {"y": 13}, 4)])
def test_a_lazy_map_computes_to_the_one_process_map_bit_for_bit(client, hh, hh_eager, ftle, chunks, blocks):
    # 300 points are 7 rows of 40 (6 blocks, the last of 5 rows); 13 rows a block: 4 blocks, the last of 1.
    sent = graphs_sent(client)
    lazy = ldpipe.ld_map(hh, name="hh", ftle=ftle, chunks=chunks, client=client, **copy.deepcopy(HH_MAP))
    assert isinstance(lazy.ld_forward.data, dask_array.Array) and lazy.ld_forward.data.numblocks == (blocks, 1)
    assert isinstance(lazy.allowed.data, np.ndarray)  # known from the section alone, before any block
    assert graphs_sent(client) > sent  # the blocks went to the cluster (persisted), not computed here
    assert ("ftle_forward" in lazy) == ftle
    computed = lazy.compute()
    allowed = computed.allowed.values  # every block integrated, none left at the skeleton's zeros
    assert 0 < allowed.sum() < allowed.size and (computed.steps_forward.values[allowed] > 0).all()
    assert_same_file(computed, hh_eager[ftle])


def test_start_times_with_ftle_equal_the_one_process_map(client, gyre):
    eager = ldpipe.ld_map(gyre, name="g", **copy.deepcopy(GYRE_MAP))
    lazy = ldpipe.ld_map(gyre, name="g", chunks={"x": 4, "y": -1}, client=client, **copy.deepcopy(GYRE_MAP))
    assert lazy.ftle_forward.dims == ("t0", "x", "y") and lazy.ld_forward.data.numblocks == (3, 2, 1)
    assert_same_file(lazy.compute(), eager)


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
    ("auto", "expected points per block"),
    (True, "expected points per block"),
    ({"y": 0}, r"argument 'chunks.y': expected a positive number of rows"),
    ({"y": 5, "py": 7}, r"argument 'chunks.py': blocks are bands of whole rows"),
    ({"z": 5}, r"unknown axes \['z'\]"),
])
def test_bad_chunks_are_refused_by_name_before_any_task(client, hh, chunks, message):
    before = graphs_sent(client)
    with pytest.raises(ConfigError, match=r"ldpipe.ld_map: argument 'chunks[.']") as error:
        ldpipe.ld_map(hh, name="hh", chunks=chunks, client=client, **copy.deepcopy(HH_MAP))
    assert error.match(message)
    assert graphs_sent(client) == before


def test_a_closed_or_wrong_client_and_a_client_without_chunks_are_refused(hh):
    with distributed.Client(n_workers=1, threads_per_worker=1, processes=False, dashboard_address=":0") as closed:
        pass
    with pytest.raises(ConfigError, match=r"ldpipe.ld_map: argument 'client': the client is closed, not running"):
        ldpipe.ld_map(hh, name="hh", chunks=400, client=closed, **copy.deepcopy(HH_MAP))
    with pytest.raises(ConfigError, match=r"argument 'client': expected a distributed.Client, got str"):
        ldpipe.ld_map(hh, name="hh", chunks=400, client="tcp://localhost:8786", **copy.deepcopy(HH_MAP))
    with pytest.raises(ConfigError, match=r"argument 'client': a client computes a map in blocks; give chunks too"):
        ldpipe.ld_map(hh, name="hh", client=closed, **copy.deepcopy(HH_MAP))


def test_chunks_without_dask_are_refused_naming_the_install(hh, monkeypatch):
    for name in ("dask", "dask.array"):
        monkeypatch.setitem(sys.modules, name, None)  # as if not installed: importing it raises ImportError
    with pytest.raises(ConfigError, match=r"argument 'chunks': a map in blocks \(chunks\) needs dask.*ldpipe\[dask\]"):
        ldpipe.ld_map(hh, name="hh", chunks=400, **copy.deepcopy(HH_MAP))
