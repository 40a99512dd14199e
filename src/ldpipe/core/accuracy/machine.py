"""What a timing depends on: the machine, its load, the library versions."""

from __future__ import annotations

import os
import platform

import numba
import numpy as np
import scipy


def cpu_model() -> str:
    """The CPU model named in /proc/cpuinfo, or the platform's processor string."""
    try:
        with open("/proc/cpuinfo") as handle:
            for line in handle:
                if line.startswith("model name"):
                    return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or "unknown"


def machine_attributes() -> dict:
    """What a timing depends on, as netCDF attributes: CPU, cores, threads used, load, versions."""
    return {
        "machine_cpu_model": cpu_model(),
        "machine_cores": os.cpu_count() or 0,
        "machine_threads_used": numba.get_num_threads(),
        "machine_platform": platform.platform(),
        "python_version": platform.python_version(),
        "numba_version": numba.__version__,
        "numpy_version": np.__version__,
        "scipy_version": scipy.__version__,
    }


def load_average() -> np.ndarray:
    """The 1, 5 and 15 minute load averages (zeros where the platform has none)."""
    try:
        return np.array(os.getloadavg())
    except OSError:
        return np.zeros(3)
