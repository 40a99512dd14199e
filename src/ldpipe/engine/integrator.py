"""The batched driver's Python side: compiled runners per system, and the thread pool.

A *unit* is a contiguous range of trajectories handled by one thread with one block of
``lanes`` lanes, by ``process`` (``templates/driver.py``: lane refill, per-lane step control,
LD quadrature, events). Units are spread over the cores by a pool of threads running the
compiled, GIL-free ``process`` (one thread per numba thread, each taking the next unit when
free). Not ``prange``: a parfor around ``process`` re-optimized the whole inlined kernel and
cost ~13 s more JIT per system and scheme (measured); the thread pool gives the same
parallelism, with dynamic scheduling.

``process`` is compiled once per (system, scheme, lanes) and kept twice: in this process
(:func:`get_runner`; :func:`kept_runner` keeps the flow engine's runners too), and on disk by
numba's cache for the next process (:mod:`ldpipe.engine.codegen`, :mod:`ldpipe.jitcache`).
"""

from __future__ import annotations

import threading
import weakref
from concurrent.futures import ThreadPoolExecutor
from typing import Callable

from .codegen import load_engine

# Compiled runners, per live system object and key (scheme, block size, ... of the runner). Keyed
# by id() with a weak reference (systems are unhashable frozen dataclasses); an entry dies with its system.
_RUNNERS: dict[tuple[int, tuple], tuple[weakref.ref, object]] = {}
_LOCK = threading.Lock()


def kept_runner(system, key: tuple, build: Callable[[], object]):
    """The runner ``build()`` returns for ``system``, built once per live system and ``key``.

    Every engine's runners are kept here: the Hamiltonian engine's (:func:`get_runner`) and the
    flow engine's (:func:`ldpipe.engine.vector_field.get_vector_field_runner`).
    """
    cache_key = (id(system), key)
    with _LOCK:
        cached = _RUNNERS.get(cache_key)
        if cached is not None and cached[0]() is system:
            return cached[1]
        runner = build()
        _RUNNERS[cache_key] = (weakref.ref(system, lambda _ref: _RUNNERS.pop(cache_key, None)), runner)
        return runner


def build_runner(system, scheme: str, lanes: int, order: int | None = None, entry: str = "process"):
    """The kernel ``entry`` of ``scheme`` for ``system`` (compiled lazily or loaded from disk).

    ``process(states, start, stop, ...)`` (the LD driver) and ``flow_process`` (the driver of
    :mod:`ldpipe.core.trajectories`) integrate trajectories start..stop-1 with one block of lanes and write
    their results; they release the GIL, so units run in parallel threads.
    """
    return getattr(load_engine(system, scheme, lanes, order, entry), entry)


def get_runner(system, scheme: str, lanes: int, order: int | None = None, entry: str = "process"):
    """``build_runner``'s kernel, kept per live system; ``order``: the Taylor scheme's."""
    return kept_runner(system, (scheme, lanes, order, entry), lambda: build_runner(system, scheme, lanes, order, entry))


def run_units(process, states, unit, args, outputs, threads: int) -> None:
    """Run ``process`` over the units of ``states`` on ``threads`` threads.

    ``process`` is compiled with ``nogil=True``; each thread takes the next unit from a shared
    counter as soon as it is free (dynamic scheduling), so uneven units (escapes, exits) do
    not leave a core idle.
    """
    n_states = states.shape[0]
    n_units = (n_states + unit - 1) // unit
    counter = iter(range(n_units))
    lock = threading.Lock()

    def worker():
        while True:
            with lock:
                u = next(counter, None)
            if u is None:
                return
            start = u * unit
            process(states, start, min(n_states, start + unit), *args, *outputs)

    threads = max(1, min(threads, n_units))
    if threads == 1:
        worker()
        return
    with ThreadPoolExecutor(max_workers=threads) as pool:
        futures = [pool.submit(worker) for _ in range(threads)]
        for future in futures:
            future.result()
