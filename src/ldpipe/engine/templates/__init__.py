"""Templates of the engine's compiled code.

Each module here is source text, not imported as is (except ``flow_status.py``, constants only).
:mod:`ldpipe.engine.codegen` joins, in this order, the system's kernel source (``potential``,
``gradient``, ``acceleration_block``, ...), a header of compile-time constants (sizes, workspace offsets,
scheme data; upper case), and the templates; it loads the result through
:mod:`ldpipe.jitcache`, so every ``@njit(**JIT)`` function (``JIT`` has ``cache=True``)
keeps its machine code on disk for the next process. The templates that read only header
constants (the quadrature, the block quadrature, the flag checks, the events) are compiled in
common modules that every engine of one shape imports (see :mod:`ldpipe.engine.codegen`): a
template there may read no kernel or scheme function. Module-level names are frozen by numba
as compile-time constants, exactly as closure variables would be.

Template functions call each other as plain ``@njit(**JIT)`` functions: LLVM inlines the small
ones into their callers as it optimizes them (the lane loops still vectorize), while numba's own
``inline="always"`` typed and lowered a function again at every call site, the larger part of a
module's compile time (``benchmarks/compile_time.py``). ``stage_state`` of the vector-field
driver is the one exception, measured faster inlined by numba. Arguments a function passes on
are typed, never literals (``np.int64(0)``, not ``0``): numba compiles a callee once per
argument-type signature, and a literal start value gives it one more.

- ``quadrature.py`` — scalar polynomial helpers and the cusp-aware LD quadrature of one lane;
- ``block_quadrature.py`` — the vectorized LD quadrature passes over a block (``fast``, ``special``);
- ``block_two_roots.py`` — ``special``'s items with two roots in the step, vectorized;
- ``block_dips.py`` — ``special``'s items with a near-touch and no root near an end, vectorized;
- ``block_arclength.py`` — ``fast``'s arc-length pass (four Gauss nodes per pass over the coefficients);
- ``roots.py`` — ``inverse_root``, x ** (-1/m) without ``pow`` (the taylor scheme's step rule);
- ``flag_checks.py`` — the cheap checks that spare the scalar path a false flag of ``fast``;
- ``events.py`` — region exit and escape located on a step's configuration polynomial, and
  whether a configuration is inside a box;
- ``step_control.py`` — the step control of every driver: whether a trajectory starts, Hairer's
  starting step from each state form's norms, the step-size factors after an attempt, underflow;
- ``hermite.py``, ``rk4.py``, ``composition.py`` — the fixed-step schemes (``attempt``,
  ``qpoly``); DOP853 is generated with its tableau as literals by :mod:`ldpipe.engine.schemes.dop853`;
- ``driver.py`` — ``process``, the block driver that the thread pool runs, and the lane
  handling the flow driver shares (``load_lane``, ``workspace_views``, ``set_lane_steps``);
- ``flow_driver.py`` — ``flow_process``, the driver of :func:`ldpipe.core.trajectories.integrate` (samples,
  section crossings and escapes from the step's dense output), on ``driver.py``'s lanes;
- ``vector_field_driver.py`` — the drivers of a general flow dx/dt = f(x, t) (first-order
  DOP853, LDs and section crossings), assembled by :mod:`ldpipe.engine.vector_field`;
- ``flow_status.py`` — the outcome codes of both flow drivers; :mod:`ldpipe.core.trajectories` imports it as
  is, so the codes have one home.
"""
