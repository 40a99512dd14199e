"""What an LD map's band costs in memory: the workflow asks its jobs for it, and a map whose band
this machine cannot hold is refused before any trajectory is integrated. Imports nothing, so the
workflow's planning can read it without loading the science."""

from __future__ import annotations

import os

#: Bytes a grid point of a band takes while it is computed: its fields and the engine's arrays
#: (measured: 350-460 MB peak for a 1500 x 375 tile).
BYTES_PER_POINT = 200
#: The process before any band: the interpreter, numpy, numba and the engine, in MB.
BASE_MB = 1000


def band_memory_mb(points: int) -> int:
    """The memory, in MB, of computing a band of ``points`` grid points."""
    return BASE_MB + points * BYTES_PER_POINT // 2**20


def machine_memory_mb() -> int | None:
    """This machine's physical memory in MB; None where the system does not say."""
    try:
        return os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES") // 2**20
    except (ValueError, OSError, AttributeError):
        return None


def fewest_tiles(points: int, memory_mb: int) -> int | None:
    """The fewest equal tiles whose bands of ``points`` in all each fit in ``memory_mb``; None if
    not even a band of one point does."""
    per_tile = (memory_mb - BASE_MB) * 2**20 // BYTES_PER_POINT
    return None if per_tile < 1 else -(-points // per_tile)
