"""Systems given as a formula for V(q): derivatives by sympy, kernels by code generation.

The generated kernels have exactly the signatures and loop shapes of the
hand-written built-ins (see :mod:`ldpipe.systems.base`), with the parameter
values substituted as literals, and are compiled the same way
(:func:`~ldpipe.systems.base.compile_kernels`).
"""

from __future__ import annotations

import sympy
from sympy.parsing.sympy_parser import parse_expr, standard_transformations
from sympy.printing.codeprinter import PrintMethodNotImplementedError
from sympy.printing.pycode import PythonCodePrinter

from ..errors import ConfigError
from .base import Kernels, System, compile_kernels

# Functions a formula may call; everything else is rejected at parse time.
ALLOWED_FUNCTIONS = {
    name: getattr(sympy, name)
    for name in ("sin", "cos", "tan", "exp", "log", "sqrt", "sinh", "cosh", "tanh", "atan", "Abs")
}
ALLOWED_FUNCTIONS["pi"] = sympy.pi
# parse_expr wraps literals in these; they are all it may reach besides the names above.
SYMPY_LITERALS = ("Integer", "Float", "Rational", "Symbol", "Function")
# Names the generated kernels use themselves.
RESERVED_NAMES = {"q", "out", "count", "j", "math", "value", "_njit", *Kernels._fields}
ALLOWED_FUNCTIONS["E"] = sympy.E


def parse_potential(
    formula: str, coordinates: tuple[str, ...], parameters: dict[str, float], key: str
) -> sympy.Expr:
    """Parse ``formula`` into a sympy expression in the coordinates, parameters substituted.

    ``key`` names the configuration entry in error messages.
    """
    coordinate_symbols = {name: sympy.Symbol(name, real=True) for name in coordinates}
    parameter_symbols = {name: sympy.Symbol(name, real=True) for name in parameters}
    clash = (set(coordinates) | set(parameters)) & (RESERVED_NAMES | set(ALLOWED_FUNCTIONS))
    if clash:
        raise ConfigError(f"config key '{key}': the names {sorted(clash)} are reserved; rename them")
    overlap = set(coordinates) & set(parameters)
    if overlap:
        raise ConfigError(
            f"config key '{key}.parameters': {sorted(overlap)} are also coordinates; a name is one or the other"
        )
    namespace = {**ALLOWED_FUNCTIONS, **coordinate_symbols, **parameter_symbols}
    try:
        expression = parse_expr(
            formula,
            local_dict=namespace,
            global_dict={"__builtins__": {}, **{k: getattr(sympy, k) for k in SYMPY_LITERALS}},
            transformations=standard_transformations,
        )
    except Exception as error:  # sympy raises many types on bad text
        raise ConfigError(f"config key '{key}.formula': cannot parse {formula!r}: {error}") from None
    if not isinstance(expression, sympy.Expr):
        raise ConfigError(f"config key '{key}.formula': {formula!r} is not an expression")
    unknown = {str(s) for s in expression.free_symbols} - set(coordinates) - set(parameters)
    if unknown:
        raise ConfigError(
            f"config key '{key}.formula': unknown names {sorted(unknown)}; expected only the coordinates "
            f"{list(coordinates)} and the parameters {sorted(parameters)}"
        )
    undefined = {f.func.__name__ for f in expression.atoms(sympy.Function)} - set(ALLOWED_FUNCTIONS)
    if undefined:
        raise ConfigError(
            f"config key '{key}.formula': unknown functions {sorted(undefined)}; allowed are "
            f"{sorted(k for k in ALLOWED_FUNCTIONS if k not in ('pi', 'E'))}"
        )
    values = {parameter_symbols[name]: sympy.Float(value, 17) for name, value in parameters.items()}
    return expression.subs(values)


class _KernelPrinter(PythonCodePrinter):
    """Prints math-module calls and full-precision float literals for numba."""

    def _print_Float(self, expr):
        return repr(float(expr))


def _scalar_body(coordinates, outputs, printer, indexer):
    """Lines that load the coordinates, share common subexpressions, then assign outputs."""
    replacements, reduced = sympy.cse([expr for _, expr in outputs], optimizations="basic")
    lines = [f"{name} = {indexer(i)}" for i, name in enumerate(coordinates)]
    lines += [f"{symbol} = {printer.doprint(expr)}" for symbol, expr in replacements]
    lines += [f"{target} = {printer.doprint(expr)}" for (target, _), expr in zip(outputs, reduced)]
    return lines


def generate_kernel_source(expression: sympy.Expr, coordinates: tuple[str, ...]) -> str:
    """Source of the potential, gradient, Hessian and block kernels of ``expression``."""
    symbols = [sympy.Symbol(name, real=True) for name in coordinates]
    gradient = [sympy.diff(expression, s) for s in symbols]
    hessian = [[sympy.diff(g, s) for s in symbols] for g in gradient]
    printer = _KernelPrinter({"fully_qualified_modules": True, "standard": "python3"})
    n = len(coordinates)
    scalar = lambda i: f"q[{i}]"  # noqa: E731
    column = lambda i: f"q[{i}, j]"  # noqa: E731

    def function(name, args, lines, loop=False):
        indent = "        " if loop else "    "
        head = [f"def {name}({args}):"]
        if loop:
            head.append("    for j in range(count):")
        body = [indent + line for line in lines]
        tail = ["    return value"] if name == "potential" else []
        return "\n".join(head + body + tail) + "\n"

    sources = {
        "potential": function("potential", "q", _scalar_body(coordinates, [("value", expression)], printer, scalar)),
        "gradient": function(
            "gradient", "q, out", _scalar_body(coordinates, [(f"out[{i}]", g) for i, g in enumerate(gradient)], printer, scalar)
        ),
        "hessian": function(
            "hessian",
            "q, out",
            _scalar_body(
                coordinates,
                [(f"out[{i}, {k}]", hessian[i][k]) for i in range(n) for k in range(n)],
                printer,
                scalar,
            ),
        ),
        "acceleration_block": function(
            "acceleration_block",
            "q, out, count",
            _scalar_body(coordinates, [(f"out[{i}, j]", -g) for i, g in enumerate(gradient)], printer, column),
            loop=True,
        ),
        "potential_block": function(
            "potential_block",
            "q, out, count",
            _scalar_body(coordinates, [("out[j]", expression)], printer, column),
            loop=True,
        ),
    }
    return "import math\n\n\n" + "\n\n".join(sources[name] for name in Kernels._fields)


def _uncompilable(name: str, formula: str, expression: sympy.Expr, coordinates: tuple[str, ...], key: str) -> str:
    """Why the kernels of ``expression`` cannot be generated: the first term of V, its gradient
    or its Hessian that has no code (e.g. DiracDelta, the second derivative of Abs)."""
    printer = _KernelPrinter({"fully_qualified_modules": True, "standard": "python3"})
    symbols = [sympy.Symbol(c, real=True) for c in coordinates]
    derivatives = [("V", expression)]
    derivatives += [(f"dV/d{c}", sympy.diff(expression, s)) for c, s in zip(coordinates, symbols)]
    derivatives += [(f"d2V/d{a}d{b}", sympy.diff(expression, s, t))
                    for a, s in zip(coordinates, symbols) for b, t in zip(coordinates, symbols)]
    for where, derivative in derivatives:
        for term in sorted(derivative.atoms(sympy.Function), key=str):
            try:
                printer.doprint(term)
            except PrintMethodNotImplementedError:
                hint = ("; Abs is not (its second derivative is a DiracDelta): write e.g. sqrt(x**2 + c**2) "
                        "for a smooth |x|") if term.func in (sympy.DiracDelta, sympy.sign) else ""
                return (
                    f"config key '{key}.formula': system {name!r}: {where} of {formula!r} contains {term}, which "
                    f"cannot be compiled; the potential must be twice differentiable with derivatives in the "
                    f"allowed functions{hint}"
                )
    return f"config key '{key}.formula': system {name!r}: the derivatives of {formula!r} cannot be compiled"


def make_formula_system(
    name: str, formula: str, coordinates: tuple[str, ...], parameters: dict[str, float], spec: dict, key: str
) -> System:
    expression = parse_potential(formula, coordinates, parameters, key)
    try:
        source = generate_kernel_source(expression, coordinates)
    except PrintMethodNotImplementedError:
        raise ConfigError(_uncompilable(name, formula, expression, coordinates, key)) from None
    return System(
        name=name,
        coordinates=tuple(coordinates),
        parameters=dict(parameters),
        kernels=compile_kernels(source, prefix=f"formula_{name}"),
        kernel_source=source,
        description=f"formula: V = {formula}",
        closed_form_equilibria=None,
        formula=formula,
        spec=spec,
    )
