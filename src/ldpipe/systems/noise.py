"""The noise of a stochastic flow dx = f(x, t) dt + G(x, t) dW: its diffusion matrix and walls.

A map's ``noise:`` block (see the schema) gives G in one of two ways:

- ``diffusivity: K`` (a number for every state variable, or one per variable): additive noise,
  G = diag(sqrt(2 K)), so a free particle's variance grows as 2 K t along each axis;
- ``diffusion:`` by formula: a mapping variable -> formula (diagonal G, one Wiener process per
  variable), or a list of rows of formulas (G of n rows and any number m of columns, one Wiener
  process per column). The formulas may use the state variables, the system's parameters and
  the time ``t``, and the block's own ``parameters``; they are checked by :mod:`ldpipe.systems.grammar` and never evaluated.

and ``reflect:`` a closed box (an interval per state variable, some or all of them) whose walls
reflect a path. :func:`parse_noise` makes a :class:`Noise` of them, with the source of its two
kernels, which the stochastic engine compiles into its module:

``diffusion(state, t, out)``
    writes G(state, t) into ``out``, shape ``(n, m)``;
``diffusion_slope(state, t, out)``
    writes dG_ii/dx_i into ``out``, shape ``(n,)``, for Milstein's correction of diagonal noise
    (zeros for any other G, which that scheme refuses).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..errors import ConfigError
from .vector_field import RESERVED_NAMES, TIME

# The names the noise kernels use themselves.
NOISE_RESERVED = RESERVED_NAMES | {"diffusion", "diffusion_slope"}


@dataclass(frozen=True)
class Noise:
    """The diffusion matrix G (n x m) of a stochastic flow and its reflecting box.

    ``expressions``: G's entries as sympy expressions, row by row; ``diagonal``: G is square and
    diagonal with each g_i depending on x_i (and t) alone, so Milstein's scheme needs no
    iterated integrals; ``additive``: G depends on no state variable; ``lower``, ``upper``: the
    reflecting box (-inf, inf where a variable has no wall); ``kernel_source``: the kernels of the
    module docstring, undecorated; ``description``: G in words.
    """

    coordinates: tuple[str, ...]
    expressions: tuple[tuple, ...]
    diagonal: bool
    additive: bool
    lower: tuple[float, ...]
    upper: tuple[float, ...]
    kernel_source: str
    description: str

    @property
    def n_noise(self) -> int:
        """m, the number of independent Wiener processes."""
        return len(self.expressions[0])

    @property
    def constant(self) -> bool:
        """G depends on neither the state nor the time."""
        return all(not e.free_symbols for row in self.expressions for e in row)

    @property
    def reflecting(self) -> np.ndarray:
        """Which state variables have walls."""
        return np.isfinite(np.asarray(self.lower)) | np.isfinite(np.asarray(self.upper))


def _diffusivity_rows(value, coordinates, key: str) -> tuple[list[list[object]], str]:
    """G = diag(sqrt(2 K)) as rows of numbers, from K for every variable or one per variable."""
    if isinstance(value, dict):
        if set(value) != set(coordinates):
            raise ConfigError(f"config key '{key}.diffusivity': expected one diffusivity for each state variable "
                              f"{list(coordinates)}, got {list(value)}")
        values = [value[c] for c in coordinates]
    else:
        values = [value] * len(coordinates)
    for name, k in zip(coordinates, values):
        if isinstance(k, bool) or not isinstance(k, (int, float)) or not math.isfinite(k) or k < 0:
            raise ConfigError(f"config key '{key}.diffusivity': expected a finite number >= 0 for {name!r}, got {k!r}")
    rows = [[math.sqrt(2.0 * float(k)) if i == j else 0.0 for j in range(len(coordinates))]
            for i, k in enumerate(values)]
    text = ", ".join(f"K_{c} = {float(k):g}" for c, k in zip(coordinates, values))
    return rows, f"additive, diffusivity {text} (G = diag(sqrt(2 K)))"


def _formula_rows(value, coordinates, key: str) -> tuple[dict[str, object], int]:
    """The diffusion formulas by their place under ``key``, and m (G's columns)."""
    n = len(coordinates)
    if isinstance(value, dict):
        if set(value) != set(coordinates):
            raise ConfigError(f"config key '{key}.diffusion': expected one formula for each state variable "
                              f"{list(coordinates)} (a diagonal G), got {list(value)}")
        # the diagonal's formulas under their own keys; the zeros off it are never wrong
        return {(f"diffusion.{c}" if i == j else f"diffusion.{c}.{j}"): (value[c] if i == j else 0)
                for i, c in enumerate(coordinates) for j in range(n)}, n
    if (not isinstance(value, list) or len(value) != n or not all(isinstance(r, list) and r for r in value)
            or len({len(r) for r in value}) != 1):
        raise ConfigError(f"config key '{key}.diffusion': expected a mapping variable -> formula, or {n} rows "
                          f"(one per state variable {list(coordinates)}) of formulas of equal length, got {value!r}")
    m = len(value[0])
    return {f"diffusion.{i}.{j}": value[i][j] for i in range(n) for j in range(m)}, m


def check_noise(spec: dict, coordinates, parameters: dict, key: str) -> dict[str, object] | None:
    """Check a ``noise:`` block ``spec`` for a flow of state ``coordinates`` and ``parameters``
    without compiling anything: one of diffusivity and diffusion, formulas in the grammar
    (:func:`ldpipe.systems.grammar.check_formulas`), walls of state variables. Returns the diffusion
    formulas by their place under ``key`` (None for a diffusivity); ConfigErrors name the key."""
    from .grammar import check_formulas

    given = [name for name in ("diffusivity", "diffusion") if spec.get(name) is not None]
    if len(given) != 1:
        raise ConfigError(f"config key '{key}': give exactly one of diffusivity (additive noise) and diffusion "
                          f"(a matrix by formula), got {given or 'neither'}")
    _walls(spec.get("reflect") or {}, coordinates, key)
    if given == ["diffusivity"]:
        _diffusivity_rows(spec["diffusivity"], coordinates, key)
        return None
    formulas, _ = _formula_rows(spec["diffusion"], coordinates, key)
    check_formulas(formulas, coordinates, noise_parameters(spec, parameters, key), key, TIME)
    return formulas


def noise_parameters(spec: dict, parameters: dict, key: str) -> dict[str, float]:
    """The names the diffusion formulas may use: the system's parameters and the block's own."""
    own = dict(spec.get("parameters") or {})
    shared = sorted(set(own) & set(parameters))
    if shared:
        raise ConfigError(f"config key '{key}.parameters': {shared} are parameters of the system already; "
                          "give the noise's own parameters other names")
    return {**parameters, **own}


def parse_noise(spec: dict, system, key: str) -> Noise:
    """The :class:`Noise` of a map's ``noise:`` block ``spec`` for ``system`` (a flow: its state
    variables, parameters and time); ``key`` names the block in error messages."""
    import sympy

    from .formula import kernel_lines, parse_formulas

    coordinates = tuple(system.coordinates)
    n = len(coordinates)
    formulas = check_noise(spec, coordinates, dict(system.parameters), key)
    if formulas is None:
        rows, description = _diffusivity_rows(spec["diffusivity"], coordinates, key)
        expressions = [[sympy.Float(v, 17) if v else sympy.Integer(0) for v in row] for row in rows]
        m = n
    else:
        m = len(formulas) // n
        parsed = parse_formulas({place: str(text) for place, text in formulas.items()}, coordinates,
                                noise_parameters(spec, dict(system.parameters), key), key, NOISE_RESERVED, time=TIME)
        expressions = [parsed[i * m:(i + 1) * m] for i in range(n)]
        description = f"diffusion matrix G = {spec['diffusion']}"
    symbols = [sympy.Symbol(c, real=True) for c in coordinates]
    additive = all(not (e.free_symbols & set(symbols)) for row in expressions for e in row)
    diagonal = m == n and all(expressions[i][j] == 0 for i in range(n) for j in range(m) if i != j) and all(
        not (expressions[i][i].free_symbols & (set(symbols) - {symbols[i]})) for i in range(n))
    lower, upper = _walls(spec.get("reflect") or {}, coordinates, key)
    from sympy.printing.codeprinter import PrintMethodNotImplementedError

    entries = [(f"out[{i}, {j}]", expressions[i][j]) for i in range(n) for j in range(m)]
    slopes = [(f"out[{i}]", sympy.diff(expressions[i][i], symbols[i]) if diagonal else sympy.Integer(0))
              for i in range(n)]
    try:
        source = "import math\n\n\n"
        for name, outputs in (("diffusion", entries), ("diffusion_slope", slopes)):
            lines = kernel_lines(coordinates, outputs, lambda i: f"state[{i}]")
            source += f"def {name}(state, t, out):\n" + "".join(f"    {line}\n" for line in lines) + "\n\n"
    except PrintMethodNotImplementedError as error:
        raise ConfigError(f"config key '{key}.diffusion': a term cannot be compiled ({error})") from None
    return Noise(coordinates=coordinates, expressions=tuple(tuple(row) for row in expressions), diagonal=diagonal,
                 additive=additive, lower=lower, upper=upper, kernel_source=source, description=description)


def _walls(reflect: dict, coordinates, key: str) -> tuple[tuple[float, ...], tuple[float, ...]]:
    """The reflecting box's lower and upper walls per state variable (infinite where none)."""
    unknown = sorted(set(reflect) - set(coordinates))
    if unknown:
        raise ConfigError(f"config key '{key}.reflect': {unknown} are not state variables of the system; "
                          f"expected some of {list(coordinates)}")
    lower, upper = [], []
    for c in coordinates:
        low, high = reflect.get(c, (-math.inf, math.inf))
        if not (math.isfinite(low) and math.isfinite(high) and low < high) and c in reflect:
            raise ConfigError(f"config key '{key}.reflect.{c}': expected an interval [low, high] of finite numbers "
                              f"with low < high, got {reflect[c]}")
        lower.append(float(low))
        upper.append(float(high))
    return tuple(lower), tuple(upper)
