"""Discrete maps x_{n+1} = f(x_n): formulas for f and, optionally, for its inverse.

A ``systems:`` entry ``{"map": {"x": "1 - a*x**2 + y", "y": "b*x"}, "inverse": {"x": "y/b", "y":
"x - 1 + a*(y/b)**2"}, "coordinates": ["x", "y"], "parameters": {"a": 1.4, "b": 0.3}}`` names one
formula per coordinate for the image of the state (and for its preimage, if backward iterations
are wanted); the formulas may use the coordinates and the parameters, no time. ``map: henon`` or
``map: standard`` names a built-in (:data:`MAP_BUILTINS`, formulas too): the Hénon map
(x, y) -> (1 - a x^2 + y, b x) and the Chirikov standard map (theta, p) -> (theta + p + K sin
theta, p + K sin theta), each with its inverse in closed form.

``periodic: {theta: 6.283185307179586}`` makes a coordinate an angle of that period: each
iterate keeps it in [0, period), and the LD takes its increments on the circle (the difference
wrapped into [-period/2, period/2)). The standard map's angle is periodic always (2 pi); its
momentum too if ``periodic`` names it (the map on the torus).

Formulas are checked by :mod:`ldpipe.systems.grammar` and parsed by
:func:`ldpipe.systems.formula.parse_formulas` (never evaluated); the kernels

``step(state, out)``, ``inverse(state, out)``
    write f(state) (f^-1(state)) into ``out``, periodic coordinates not yet wrapped;
``jacobian(state, out)``
    writes the tangent map Df(state), ``out[i, k] = df_i/dx_k`` (derived by sympy),

are printed as source, which :mod:`ldpipe.engine.discrete_map` compiles into its iteration
module, and compiled here too (each on its first call) for :meth:`DiscreteMapSystem.step` and
:meth:`DiscreteMapSystem.jacobian`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Callable, ClassVar

import numpy as np

from ..errors import ConfigError
from ..jitcache import njit_functions
from .grammar import check_formulas
from .model import CoordinateState, Unbounded

# sympy (through .formula) is imported where formulas are parsed: the planning reads every
# entry's kind and coordinates without it.

TWO_PI = 2.0 * math.pi
# Names the generated kernels use themselves.
RESERVED_NAMES = {"state", "out", "math", "step", "inverse", "jacobian", "_njit"}

#: The built-in maps: coordinates, formulas of the map and of its inverse, default parameters,
#: and the coordinates that are always periodic.
MAP_BUILTINS: dict[str, dict] = {
    "henon": {
        "coordinates": ("x", "y"),
        "map": {"x": "1 - a*x**2 + y", "y": "b*x"},
        "inverse": {"x": "y/b", "y": "x - 1 + a*(y/b)**2"},
        # Hénon's own values (1976), those of the strange attractor
        "defaults": {"a": 1.4, "b": 0.3},
        "periodic": {},
        "title": "the Hénon map",
    },
    "standard": {
        "coordinates": ("theta", "p"),
        "map": {"theta": "theta + p + K*sin(theta)", "p": "p + K*sin(theta)"},
        "inverse": {"theta": "theta - p", "p": "p - K*sin(theta - p)"},
        # Greene's critical value, where the last invariant circle of rotation number the golden mean breaks
        "defaults": {"K": 0.971635406},
        "periodic": {"theta": TWO_PI},
        "title": "the Chirikov standard map",
    },
}


def _builtin(spec: dict, key: str) -> dict | None:
    """The built-in record a ``map:`` names (None for formulas); ConfigError for an unknown name."""
    given = spec["map"]
    if not isinstance(given, str):
        return None
    if given not in MAP_BUILTINS:
        raise ConfigError(f"config key '{key}.map': unknown built-in map {given!r}; expected one of "
                          f"{sorted(MAP_BUILTINS)}, or a mapping coordinate -> formula")
    return MAP_BUILTINS[given]


def map_coordinates(spec: dict) -> tuple[str, ...]:
    """A map entry's coordinates: a built-in's, or its ``coordinates`` list."""
    builtin = MAP_BUILTINS.get(spec["map"]) if isinstance(spec["map"], str) else None
    return builtin["coordinates"] if builtin else tuple(spec.get("coordinates") or ())


def map_parts(spec: dict, key: str) -> tuple[tuple[str, ...], dict, dict | None, dict[str, float], dict[str, float]]:
    """``(coordinates, map formulas, inverse formulas or None, parameters, periods)`` of a map
    entry (a built-in's formulas and defaults under the entry's parameters), checked as far as
    can be without sympy: the keys each form takes, the formulas' grammar, the periods."""
    builtin = _builtin(spec, key)
    given = dict(spec.get("parameters") or {})
    if builtin is not None:
        refused = [k for k in ("coordinates", "inverse") if k in spec]
        if refused:
            raise ConfigError(f"config key '{key}.{refused[0]}': the built-in map {spec['map']!r} has its own "
                              f"coordinates {list(builtin['coordinates'])} and inverse; leave {refused[0]} out")
        unknown = sorted(set(given) - set(builtin["defaults"]))
        if unknown:
            raise ConfigError(f"config key '{key}.parameters': unknown parameters {unknown} for the map "
                              f"{spec['map']}; allowed are {sorted(builtin['defaults'])}")
        coordinates, forward, inverse = builtin["coordinates"], builtin["map"], builtin["inverse"]
        parameters = {**builtin["defaults"], **given}
        periods = {**builtin["periodic"], **(spec.get("periodic") or {})}
        changed = [c for c, period in builtin["periodic"].items() if periods[c] != period]
        if changed:
            raise ConfigError(f"config key '{key}.periodic.{changed[0]}': the built-in map {spec['map']!r} has "
                              f"{changed[0]} of period {builtin['periodic'][changed[0]]!r}; leave it out")
        if spec["map"] == "henon" and parameters["b"] == 0:
            raise ConfigError(f"config key '{key}.parameters.b': the Hénon map with b = 0 is not invertible "
                              "(it folds the plane onto a line); give b != 0")
    else:
        coordinates = tuple(spec.get("coordinates") or ())
        if not coordinates:
            raise ConfigError(f"config key '{key}.coordinates': a map given by formulas needs its coordinates, "
                              "e.g. [x, y]")
        forward, inverse = spec["map"], spec.get("inverse")
        parameters = given
        periods = dict(spec.get("periodic") or {})
        for place, formulas in (("map", forward), ("inverse", inverse)):
            if formulas is not None and set(formulas) != set(coordinates):
                raise ConfigError(f"config key '{key}.{place}': expected one formula for each coordinate "
                                  f"{list(coordinates)}, got formulas for {list(formulas)}")
    for name, period in periods.items():
        if name not in coordinates:
            raise ConfigError(f"config key '{key}.periodic.{name}': not a coordinate; expected one of {list(coordinates)}")
        if not (isinstance(period, (int, float)) and not isinstance(period, bool) and period > 0):
            raise ConfigError(f"config key '{key}.periodic.{name}': expected a period > 0, got {period!r}")
    texts = {f"map.{c}": forward[c] for c in coordinates}
    texts.update({f"inverse.{c}": inverse[c] for c in coordinates} if inverse is not None else {})
    check_formulas(texts, coordinates, parameters, key)
    return coordinates, forward, inverse, {k: float(v) for k, v in parameters.items()}, \
        {k: float(v) for k, v in periods.items()}


def check_map(spec: dict, key: str) -> None:
    """What the schema cannot say of a map entry, without sympy (:func:`map_parts`)."""
    map_parts(spec, key)


def map_caption(spec: dict) -> str:
    """A map entry in a caption: a built-in's title, or its formulas."""
    if isinstance(spec["map"], str):
        return MAP_BUILTINS[spec["map"]]["title"] if spec["map"] in MAP_BUILTINS else f"map {spec['map']}"
    return "map " + ", ".join(f"{c} -> {f}" for c, f in spec["map"].items())


def _function_source(name: str, coordinates, outputs) -> str:
    from .formula import kernel_lines

    lines = kernel_lines(coordinates, outputs, lambda i: f"state[{i}]")
    return f"def {name}(state, out):\n" + "".join(f"    {line}\n" for line in lines)


def _kernel_source(name: str, coordinates, forward, inverse, key: str) -> str:
    import sympy
    from sympy.printing.codeprinter import PrintMethodNotImplementedError

    symbols = [sympy.Symbol(c, real=True) for c in coordinates]
    functions = [("step", "map", [(f"out[{i}]", f) for i, f in enumerate(forward)])]
    functions += [("inverse", "inverse", [(f"out[{i}]", f) for i, f in enumerate(inverse)])] if inverse is not None else []
    # the tangent map Df, out[i, k] = df_i/dx_k: what the chaos indicators' deviation vectors iterate
    functions.append(("jacobian", "map", [(f"out[{i}, {k}]", sympy.diff(f, s))
                                          for i, f in enumerate(forward) for k, s in enumerate(symbols)]))
    parts = []
    for function, place, outputs in functions:
        try:
            parts.append(_function_source(function, coordinates, outputs))
        except PrintMethodNotImplementedError as error:
            raise ConfigError(f"config key '{key}.{place}': a term of the map or its tangent map cannot be compiled "
                              f"({error}); the map must be differentiable in the allowed functions") from None
    return "import math\n\n\n" + "\n\n".join(parts)


@dataclass(frozen=True)
class DiscreteMapSystem(Unbounded, CoordinateState):
    """A map x_{n+1} = f(x_n) with compiled kernels (see the module docstring).

    ``expressions`` are the components of f (parameters substituted), ``inverse_expressions``
    those of f^-1 (None: no inverse given); ``periods`` one per coordinate (0: not periodic);
    ``kernel_source`` the source of ``step`` (and ``inverse``) and ``jacobian``, undecorated;
    ``kernels`` those functions compiled, in that order.
    """

    name: str
    coordinates: tuple[str, ...]
    parameters: dict[str, float]
    expressions: tuple
    inverse_expressions: tuple | None
    periods: tuple[float, ...]
    kernel_source: str
    kernels: tuple[Callable, ...]
    description: str = ""
    spec: dict = field(default_factory=dict)

    #: No Hamiltonian, no energy.
    hamiltonian: ClassVar[bool] = False
    #: Iterated, not integrated.
    discrete: ClassVar[bool] = True

    @property
    def has_inverse(self) -> bool:
        return self.inverse_expressions is not None

    @property
    def engine_name(self) -> str:
        return self.name

    def check_times(self, start: float, end: float, key: str | None = None) -> None:
        """A map holds at every step: nothing to refuse."""

    def require_inverse(self, what: str) -> None:
        if not self.has_inverse:
            raise ConfigError(f"config key 'systems.{self.name}.inverse': {what} iterates the map backward, and "
                              f"system {self.name!r} gives no inverse; give one formula per coordinate for "
                              "x_n in terms of x_{n+1}")

    def wrap(self, state: np.ndarray) -> np.ndarray:
        """``state`` (any leading shape) with its periodic coordinates in [0, period)."""
        state = np.array(state, dtype=float)
        for i, period in enumerate(self.periods):
            if period:
                state[..., i] = np.mod(state[..., i], period)
        return state

    def step(self, state: np.ndarray, direction: int = 1) -> np.ndarray:
        """f(state) (``direction`` 1) or f^-1(state) (-1) of one state, periodic coordinates wrapped."""
        if direction not in (1, -1):
            raise ValueError(f"direction: expected 1 or -1, got {direction!r}")
        if direction == -1:
            self.require_inverse("a backward step")
        out = np.empty(self.n_state)
        self.kernels[0 if direction == 1 else 1](np.ascontiguousarray(state, dtype=np.float64), out)
        return self.wrap(out)

    def jacobian(self, state: np.ndarray) -> np.ndarray:
        """Df at ``state`` (the tangent map), ``out[i, k] = df_i/dx_k``."""
        out = np.empty((self.n_state, self.n_state))
        self.kernels[-1](np.ascontiguousarray(state, dtype=np.float64), out)
        return out


def make_discrete_map_system(name: str, spec: dict, key: str) -> DiscreteMapSystem:
    """The map of one ``systems:`` entry (see the module docstring), its kernels compiled lazily."""
    from .formula import parse_formulas

    coordinates, forward, inverse, parameters, periods = map_parts(spec, key)
    expressions = parse_formulas({f"map.{c}": forward[c] for c in coordinates}, coordinates, parameters, key,
                                 RESERVED_NAMES)
    inverse_expressions = None
    if inverse is not None:
        inverse_expressions = parse_formulas({f"inverse.{c}": inverse[c] for c in coordinates}, coordinates,
                                             parameters, key, RESERVED_NAMES)
    source = _kernel_source(name, coordinates, expressions, inverse_expressions, key)
    names = ("step", "inverse", "jacobian") if inverse is not None else ("step", "jacobian")
    kernels = tuple(njit_functions(source, names, f"map_{name}"))
    if isinstance(spec["map"], str):
        text = MAP_BUILTINS[spec["map"]]["title"]
    else:
        text = "map " + ", ".join(f"{c} -> {forward[c]}" for c in coordinates)
    torus = [c for c in coordinates if c in periods]
    if torus:
        text += " (periodic: " + ", ".join(f"{c} mod {periods[c]:.6g}" for c in torus) + ")"
    return DiscreteMapSystem(
        name=name,
        coordinates=tuple(coordinates),
        parameters=dict(parameters),
        expressions=tuple(expressions),
        inverse_expressions=None if inverse_expressions is None else tuple(inverse_expressions),
        periods=tuple(periods.get(c, 0.0) for c in coordinates),
        kernel_source=source,
        kernels=kernels,
        description=text,
        spec=spec,
    )
