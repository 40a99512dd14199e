"""The stochastic engine: ensembles of dx = f(x, t) dt + G(x, t) dW and the LD along each path.

The generated module is assembled by :func:`ldpipe.engine.codegen.assemble`, as the flow engine's
(:mod:`ldpipe.engine.vector_field`) is: the system's ``rhs`` source (the same drift kernel), a
header (the state's and the noise's dimensions, the integrand kinds), the noise's kernels
(:mod:`ldpipe.systems.noise`) and the template ``sde_driver``; the Philox generator
(``templates/philox.py``) reads no system code and is a common module every stochastic engine
imports. The scheme is a run-time argument, so Euler-Maruyama and Milstein share one module.

Reproducibility: a path's increments are Philox draws keyed by the map's seed and the start
time's bits, counted by (draw block, trajectory index in the whole map, member, direction)
(:func:`stream_key`), so a map's values are identical bit for bit whatever its tiling, chunking,
thread count or worker count, and whatever order its starts are given in.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from .codegen import assemble, load_modules
from .integrands import KINDS, integrand_for
from .integrator import kept_runner, run_units

#: The schemes by their run-time code in ``sde_driver``: name -> (code, strong order with
#: multiplicative noise, strong order with additive noise, weak order).
SDE_SCHEMES = {"euler_maruyama": (0, 0.5, 1.0, 1.0), "milstein": (1, 1.0, 1.0, 1.0), "heun": (2, 1.0, 1.0, 1.0)}
#: The schemes that take only diagonal noise (g_i a function of x_i and t alone): their terms need dg_i/dx_i.
DIAGONAL_SCHEMES = ("milstein", "heun")
#: The common module of the Philox generator (a layer of :func:`ldpipe.engine.codegen.common_modules`).
PHILOX_LAYER = (("common_philox", ("philox",)),)
KERNELS = ("rhs",)
# The noise's kernels follow the header in the module (the header wraps only the system's).
NOISE_KERNELS = "diffusion = njit(**JIT)(diffusion)\ndiffusion_slope = njit(**JIT)(diffusion_slope)\n"
#: Direction words of the counter: forward and backward paths of one start draw different noise.
DIRECTION_WORDS = {1: 0, -1: 1}
#: The largest ensemble and trajectory index the counter's words hold without reuse.
MAX_MEMBERS = 1 << 20
#: Faces of land cells a step is followed across before it is given up (not taken): a step a few
#: cells long in a corner of land meets a handful.
MAX_BOUNCES = 64


@dataclass(frozen=True)
class StochasticSettings:
    """The numerical settings of a map's ``noise:`` block (the noise itself: :class:`ldpipe.systems.noise.Noise`).

    ``scheme``: a key of :data:`SDE_SCHEMES`; ``dt``: the largest step (the step used is
    tau / ceil(tau / dt), so the steps end at tau); ``seed``: the key of every path's stream;
    ``members``: paths per start (the ensemble).
    """

    scheme: str = "euler_maruyama"
    dt: float = 0.01
    seed: int = 0
    members: int = 16

    def __post_init__(self):
        if self.scheme not in SDE_SCHEMES:
            raise ValueError(f"scheme: expected one of {sorted(SDE_SCHEMES)}, got {self.scheme!r}")
        if not (isinstance(self.dt, (int, float)) and math.isfinite(self.dt) and self.dt > 0):
            raise ValueError(f"dt: expected a step > 0, got {self.dt!r}")
        if isinstance(self.seed, bool) or not isinstance(self.seed, (int, np.integer)) or not 0 <= self.seed < 2**64:
            raise ValueError(f"seed: expected an integer in [0, 2**64), got {self.seed!r}")
        if isinstance(self.members, bool) or not isinstance(self.members, (int, np.integer)) \
                or not 1 <= self.members <= MAX_MEMBERS:
            raise ValueError(f"members: expected an integer in [1, {MAX_MEMBERS}], got {self.members!r}")

    @classmethod
    def from_config(cls, block: dict) -> StochasticSettings:
        """From a map's ``noise:`` block (defaults filled by the schema, or these)."""
        return cls(**{name: block[name] for name in ("scheme", "dt", "seed", "members") if name in block})

    def steps(self, tau: float) -> tuple[int, float]:
        """(number of steps, step) covering tau with steps of at most ``dt``."""
        count = max(1, math.ceil(tau / self.dt - 1e-12))
        return count, tau / count


class StochasticLDResult(NamedTuple):
    """Per-path results of :func:`compute_stochastic_ld`, arrays of shape (N, members) (``end_state``:
    (N, members, n)).

    ld : the trapezoidal LD of the drift along the path over [0, time];
    time : |t - t0| reached: tau, or 0 for a start outside the escape radius or the reflecting box,
        or the last step's time inside the escape radius;
    escaped : stopped at the escape radius (or a state not finite);
    started : the start was inside the escape radius and the reflecting box;
    end_state : where the path stopped.
    """

    ld: np.ndarray
    time: np.ndarray
    escaped: np.ndarray
    started: np.ndarray
    end_state: np.ndarray


def stream_key(seed: int, t0: float) -> tuple[np.uint64, np.uint64]:
    """The Philox key of a map's paths: the seed, and the start time's bits (-0.0 taken as 0.0)."""
    bits = np.array([float(t0) + 0.0], dtype=np.float64).view(np.uint64)[0]
    return np.uint64(seed), np.uint64(bits)


def stochastic_modules(system, noise):
    """The texts of the stochastic engine's modules for ``system`` with ``noise`` (module docstring)."""
    m = noise.n_noise
    constants = {"N": system.n_state, "M_NOISE": m, "BLOCKS": (m + 3) // 4, "LAST_PAIRS": 2 if m % 4 in (0, 3) else 1,
                 "MAX_BOUNCES": MAX_BOUNCES, **KINDS}
    title = f"ldpipe.engine.stochastic: {system.n_state} state variables, {m} Wiener processes"
    from .codegen import template

    bodies = [("noise kernels (generated by ldpipe.systems.noise)", noise.kernel_source + NOISE_KERNELS),
              ("sde_driver", template("sde_driver"))]
    return assemble(system, f"sde_engine_{system.engine_name}", title, KERNELS, constants, bodies, PHILOX_LAYER)


@functools.cache
def philox_module():
    """The compiled Philox generator (the common module every stochastic engine imports)."""
    from ..jitcache import load_generated_module
    from .codegen import common_modules

    (module,) = common_modules(PHILOX_LAYER, {})
    return load_generated_module(module.text, module.prefix)


def path_normals(seed: int, t0: float, trajectory: int, member: int, direction: int, steps: int,
                 n_noise: int) -> np.ndarray:
    """The standard normal numbers xi a path draws, shape (steps, n_noise): its Brownian increment
    over step s is sqrt(h) xi[s] (tests and benchmarks rebuild a path's noise with it)."""
    blocks = (n_noise + 3) // 4
    out = np.zeros(4 * blocks * steps)
    key0, key1 = stream_key(seed, t0)
    philox_module().stream_normals(key0, key1, np.uint64(0), blocks * steps, np.uint64(trajectory),
                                   np.uint64(member), np.uint64(DIRECTION_WORDS[direction]), out)
    return out.reshape(steps, 4 * blocks)[:, :n_noise]


def brownian_endpoints(seed: int, t0: float, trajectory: int, members: int, direction: int, steps: int,
                       h: float, n_noise: int) -> np.ndarray:
    """W at the end of each member's path (members 0 .. members - 1 of one trajectory), shape
    (members, n_noise): sqrt(h) times the sum of the normal numbers of its ``steps`` steps."""
    out = np.zeros((members, n_noise))
    key0, key1 = stream_key(seed, t0)
    philox_module().stream_sums(key0, key1, np.uint64(trajectory), members, np.uint64(DIRECTION_WORDS[direction]),
                                steps, n_noise, out)
    return math.sqrt(h) * out


class LandWalls(NamedTuple):
    """The land cells a planar data window's paths reflect off (``templates/sde_driver.py``):
    ``cells`` (ny - 1, nx - 1), a cell with a land node at a corner (where the data's kernel has
    no velocity, and a deterministic trajectory stops), between the grid lines ``xs`` and ``ys``."""

    walls: bool
    xs: np.ndarray
    ys: np.ndarray
    cells: np.ndarray


NO_WALLS = LandWalls(False, np.zeros(2), np.zeros(2), np.zeros((1, 1), dtype=np.bool_))


def land_walls(system, window) -> LandWalls:
    """The land walls of ``system``'s data ``window`` (what its ``time_window`` bound): none for a
    flow given by formulas or data without land; a ValueError for land in 3-D data, whose walls
    are not implemented (its noisy paths would cross the sea floor)."""
    land = getattr(window, "land", None)
    if land is None or not np.any(land):
        return NO_WALLS
    if system.n_state != 2:
        raise ValueError(f"system {system.name!r}: noise on 3-D velocity data with land is not supported (its paths "
                         "would cross land and the sea floor); give a map without noise, or data without land")
    if hasattr(window, "nodes"):  # a rectilinear grid: its node values
        xs, ys = (np.asarray(nodes, dtype=np.float64) for nodes in window.nodes[:2])
    else:  # a regular grid: first node, spacing, count
        xs, ys = (first + step * np.arange(count, dtype=np.float64) for first, step, count in (window.x_grid,
                                                                                              window.y_grid))
    cells = land[:-1, :-1] | land[:-1, 1:] | land[1:, :-1] | land[1:, 1:]
    return LandWalls(True, np.ascontiguousarray(xs), np.ascontiguousarray(ys), np.ascontiguousarray(cells))


def compute_stochastic_ld(system, noise, states, direction: int, tau: float, p, settings: StochasticSettings,
                          escape_radius: float, t0: float = 0.0, index=None, threads: int | None = None
                          ) -> StochasticLDResult:
    """``settings.members`` noisy paths from each row of ``states`` (shape (N, n)) over
    [t0, t0 + direction tau] under ``noise``, and the LD of exponent ``p`` (or ``"arclength"``)
    of the drift along each (see ``templates/sde_driver.py``).

    ``index``: each row's trajectory index in its whole map (default 0..N-1), which keys its
    noise: give the same index to the same start, and its paths are the same bits in any call.
    ``escape_radius``: the radius the engine uses (:func:`ldpipe.engine.settings.engine_escape_radius`).
    """
    from numba import get_num_threads

    if isinstance(direction, bool) or direction not in (1, -1):
        raise ValueError(f"direction: expected +1 (forward) or -1 (backward), got {direction!r}")
    if system.hamiltonian:
        raise ValueError(f"system {system.name!r}: noise applies to a vector field or velocity data, not a Hamiltonian")
    code = SDE_SCHEMES[settings.scheme][0]
    if settings.scheme in DIAGONAL_SCHEMES and not noise.diagonal:
        raise ValueError(f"scheme {settings.scheme}: needs diagonal noise (g_i a function of x_i and t alone), got "
                         f"{noise.description}; use euler_maruyama")
    n = system.n_state
    states = np.ascontiguousarray(states, dtype=np.float64)
    if states.ndim != 2 or states.shape[1] != n:
        raise ValueError(f"states: expected shape (N, {n}), got {states.shape}")
    if system.engine_states(states) is not states:  # the noise is of the state variables, not of another form
        raise ValueError(f"system {system.name!r}: noise on a curvilinear grid (integrated in its indices) or on a "
                         "global grid reaching a pole (integrated as 3-D positions) is not supported yet; give a map "
                         "without noise")
    count = states.shape[0]
    index = np.arange(count, dtype=np.int64) if index is None else np.ascontiguousarray(index, dtype=np.int64)
    if index.shape != (count,) or (count and index.min() < 0):
        raise ValueError(f"index: expected {count} trajectory indices >= 0, got shape {index.shape}")
    members = settings.members
    n_steps, h = settings.steps(tau)
    integrand = integrand_for(p)
    items = np.repeat(states, members, axis=0)
    total = items.shape[0]
    outputs = (np.zeros(total), np.zeros(total), np.zeros(total, dtype=np.bool_), np.zeros(total, dtype=np.bool_),
               np.zeros((total, n)))
    if total:
        runner = kept_runner(system, ("stochastic", noise.kernel_source), lambda: load_modules(stochastic_modules(system, noise))
                             .sde_process)
        key0, key1 = stream_key(settings.seed, t0)
        args = (index, members, key0, key1, np.uint64(DIRECTION_WORDS[direction]), float(t0), float(direction), h,
                n_steps, code, integrand.kind, integrand.p_exponent(p), np.asarray(noise.lower, dtype=np.float64),
                np.asarray(noise.upper, dtype=np.float64), noise.reflecting, float(escape_radius), noise.constant)
        threads = threads or get_num_threads()
        with system.time_window(t0, t0 + direction * tau) as window:
            args += tuple(land_walls(system, window))
            run_units(runner, items, max(1, min(256, total // (8 * threads) or 1)), args, outputs, threads)
    ld, time, escaped, started, end = outputs
    time[started & ~escaped] = tau  # the steps' sum can miss tau in the last bit
    shape = (count, members)
    return StochasticLDResult(ld.reshape(shape), time.reshape(shape), escaped.reshape(shape), started.reshape(shape),
                              end.reshape(shape + (n,)))
