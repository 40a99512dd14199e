"""The address of the velocity data the compiled kernels read, as a symbol of the process.

The engine calls a system's kernel as ``rhs(state, t, out)``: no argument carries a data array,
and a numba global array would be frozen into the compiled code (and into its disk cache). So
the kernel of a velocity-data system reads its data through a pointer kept in one C-level cell of
this process, exported to the JIT linker under :data:`SYMBOL`; compiled code (fresh or from the
disk cache) loads the cell's current value at each call. :func:`bound_data` points the cell at an
array for the duration of an engine call (one data window at a time per process: the lock).

This module's text is part of every data kernel's cache key (``SOURCE_DIGEST``), so an edit here
recompiles the kernels that inline it.
"""

from __future__ import annotations

import ctypes
import hashlib
import threading
from contextlib import contextmanager
from pathlib import Path

import llvmlite.binding as llvm
import numpy as np
from llvmlite import ir
from numba import types
from numba.extending import intrinsic

SYMBOL = "ldpipe_velocity_data_address"
_CELL = (ctypes.c_int64 * 1)()
# What the cell points at when nothing is bound: a header of zeros, which the kernels read as "no data" (NaN).
UNBOUND = np.zeros(64)
_CELL[0] = UNBOUND.ctypes.data
llvm.add_symbol(SYMBOL, ctypes.addressof(_CELL))
_LOCK = threading.RLock()
SOURCE_DIGEST = hashlib.sha256(Path(__file__).read_bytes()).hexdigest()[:20]


@intrinsic
def velocity_data_pointer(typingctx):
    """A float64 pointer to the bound data (compiled code: a load of the process's cell)."""

    def codegen(context, builder, signature, args):
        module = builder.module
        try:
            cell = module.get_global(SYMBOL)
        except KeyError:
            cell = ir.GlobalVariable(module, ir.IntType(64), name=SYMBOL)
            cell.linkage = "external"
        return builder.inttoptr(builder.load(cell), ir.PointerType(ir.DoubleType()))

    return types.CPointer(types.float64)(), codegen


@contextmanager
def bound_data(buffer: np.ndarray):
    """Within the block, the kernels read ``buffer`` (float64, C-contiguous, kept alive by the caller)."""
    if buffer.dtype != np.float64 or not buffer.flags.c_contiguous:
        raise ValueError("bound_data: expected a C-contiguous float64 array")
    with _LOCK:
        previous = _CELL[0]
        _CELL[0] = buffer.ctypes.data
        try:
            yield
        finally:
            _CELL[0] = previous
