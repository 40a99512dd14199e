"""A map's numbers do not depend on how its trajectories are batched.

Each trajectory's result must depend only on its own start point and the map's settings: the same
map computed with its start points shuffled inside every engine call, cut into other engine calls
(another chunk size, other tiles) and run on another number of threads must be equal **bit for
bit**: LD, times, flags, steps, end states and FTLE (the identity is the reference: no tolerance).

The engine's lanes share a block, and the quadrature gathers the flagged components of a step
from every lane into shared item buffers; anything computed across them (a convergence test over
all items, a batch-wide maximum) would couple a trajectory to its neighbours. Near-touches of a
velocity component (``one_dip``) are the rare steps where that showed: about 1 trajectory in 10^4
of a bounded Barbanis section at rtol 1e-6, so the Hamiltonian map below has 22,500 points (both
variants failed, 5 forward LDs changed in their last bits, while ``one_dip``'s Newton iteration
ran until every item of a block had converged). The systems and settings are ones other tests
compile (Barbanis with DOP853; the double gyre of tests/data/test_ftle.py).
"""

import copy

import numpy as np
import pytest

import ldpipe
import ldpipe.core.maps.grid as grid
from ldpipe.config import validate_config
from ldpipe.config.parameters import parameters_from_config
from ldpipe.core.maps.assembly import ld_map_dataset
from support.barbanis import E_C
from support.double_gyre import DOUBLE_GYRE

#: A bounded section of Barbanis below the critical energy (every trajectory runs the whole tau,
#: so every step's quadrature counts), with the FTLE of its flow map.
BARBANIS_MAP = {
    "section": {"axes": [{"name": "x", "range": [-2.0, 4.0], "points": 150},
                         {"name": "px", "range": [-2.5, 2.5], "points": 150}],
                "fixed": {"y": 0.0}, "solve": "py"},
    "energy": {"total": E_C - 0.1}, "tau": 20.0, "p": 0.5, "ftle": True,
    "integrator": {"scheme": "dop853", "rtol": 1e-6, "atol": 1e-6},
}
#: The double gyre of tests/data/test_ftle.py (its engine compiled there), with its FTLE.
GYRE_MAP = {
    "system": "double_gyre", "t0": 0.0,
    "section": {"axes": [{"name": "x", "range": [0.0, 2.0], "points": 41},
                         {"name": "y", "range": [0.0, 1.0], "points": 21}]},
    "tau": 10.0, "p": 0.5, "integrator": {"rtol": 1e-9, "atol": 1e-9}, "ftle": True,
}


def shuffling(compute_ld, seed: int):
    """``compute_ld`` that integrates each call's start points in a random order and returns the
    results in the caller's order: every trajectory gets other neighbours in its blocks."""
    rng = np.random.default_rng(seed)

    def shuffled(system, states, direction=1, settings=None, t0=0.0):
        order = rng.permutation(len(states))
        result = compute_ld(system, states[order], direction, settings, t0)
        back = np.argsort(order)
        return type(result)(*(field[back] for field in result))

    return shuffled


def assert_same_bits(found, expected):
    assert sorted(found.data_vars) == sorted(expected.data_vars)
    for name in expected.variables:
        same = np.array_equal(found[name].values, expected[name].values)
        assert same, f"{name}: {np.count_nonzero(found[name].values != expected[name].values)} points differ"


def recut(monkeypatch, chunk: int, seed: int) -> None:
    """A map's engine calls cut into chunks of ``chunk`` points, each shuffled."""
    monkeypatch.setattr(grid, "CHUNK", chunk)
    monkeypatch.setattr(grid, "compute_ld", shuffling(grid.compute_ld, seed))


@pytest.fixture(autouse=True)
def numba_threads():
    """The engine's thread count as it was before a test that sets its own."""
    import numba

    threads = numba.get_num_threads()
    yield
    numba.set_num_threads(threads)


@pytest.fixture(scope="module")
def barbanis_system():
    return ldpipe.system(builtin="barbanis_2dof")


@pytest.fixture(scope="module")
def barbanis_map(barbanis_system):
    return ldpipe.ld_map(barbanis_system, name="m", **copy.deepcopy(BARBANIS_MAP))


@pytest.mark.parametrize("chunk, tiles, threads", [(40_000, 1, 2), (4_099, 3, 1)], ids=["shuffled", "recut"])
def test_hamiltonian_map_is_the_same_however_it_is_batched(monkeypatch, barbanis_system, barbanis_map,
                                                          chunk, tiles, threads):
    assert barbanis_map.ftle_defined_forward.values.any()  # the FTLE is compared where it is a number
    recut(monkeypatch, chunk, seed=tiles)
    found = ldpipe.ld_map(barbanis_system, name="m", tiles=tiles, threads=threads, **copy.deepcopy(BARBANIS_MAP))
    assert_same_bits(found, barbanis_map)


def gyre_map(tiles: int = 1, threads: int | None = None):
    config = validate_config({"systems": {"double_gyre": copy.deepcopy(DOUBLE_GYRE)},
                              "ld_maps": {"g": {**copy.deepcopy(GYRE_MAP), "tiles": tiles}}})
    return ld_map_dataset(parameters_from_config(config, "ld", "g"), None, tiles=tiles, threads=threads,
                          show_progress=False)


def test_vector_field_map_is_the_same_however_it_is_batched(monkeypatch):
    expected = gyre_map()
    assert expected.ftle_defined_forward.values.any()
    recut(monkeypatch, 97, seed=5)
    assert_same_bits(gyre_map(tiles=3, threads=1), expected)
