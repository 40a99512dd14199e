"""Systems given as a formula for V(q): derivatives by sympy, kernels by code generation.

The generated kernels have exactly the signatures and loop shapes of the
hand-written built-ins (see :mod:`ldpipe.systems.base`), with the parameter
values substituted as literals, and are compiled the same way
(:func:`~ldpipe.systems.base.compile_kernels`). The formula parser (:func:`parse_formulas`)
and the kernel printer (:func:`kernel_lines`) serve vector fields too
(:mod:`ldpipe.systems.vector_field`): one set of rules for names, parameters and functions.
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


def parse_formulas(
    formulas: dict[str, object],
    coordinates: tuple[str, ...],
    parameters: dict[str, float],
    key: str,
    reserved: set[str],
    time: str | None = None,
) -> list[sympy.Expr]:
    """Parse each formula into a sympy expression in the coordinates (and ``time``), parameters substituted.

    ``formulas`` maps where each formula sits under the configuration entry ``key`` (e.g.
    ``"formula"``, ``"vector_field.x"``) to its text; error messages name that key. ``reserved``:
    the names the generated kernels use themselves, which no coordinate or parameter may take.
    ``time``: the name of the time, if the formulas may use it.
    """
    clash = (set(coordinates) | set(parameters)) & (reserved | set(ALLOWED_FUNCTIONS))
    if clash:
        raise ConfigError(f"config key '{key}': the names {sorted(clash)} are reserved; rename them")
    overlap = set(coordinates) & set(parameters)
    if overlap:
        raise ConfigError(
            f"config key '{key}.parameters': {sorted(overlap)} are also coordinates; a name is one or the other"
        )
    names = (*coordinates, *parameters, *((time,) if time else ()))
    symbols = {name: sympy.Symbol(name, real=True) for name in names}
    namespace = {**ALLOWED_FUNCTIONS, **symbols}
    values = {symbols[name]: sympy.Float(value, 17) for name, value in parameters.items()}
    expected = [f"the coordinates {list(coordinates)}", f"the parameters {sorted(parameters)}"]
    expected += [f"the time '{time}'"] if time else []
    expected_text = ", ".join(expected[:-1]) + " and " + expected[-1]
    expressions = []
    for place, text in formulas.items():
        where = f"config key '{key}.{place}'"
        if isinstance(text, bool) or not isinstance(text, (str, int, float)):
            raise ConfigError(f"{where}: expected a formula (text), got {text!r}")
        try:
            expression = parse_expr(
                str(text),
                local_dict=namespace,
                global_dict={"__builtins__": {}, **{k: getattr(sympy, k) for k in SYMPY_LITERALS}},
                transformations=standard_transformations,
            )
        except Exception as error:  # sympy raises many types on bad text
            raise ConfigError(f"{where}: cannot parse {text!r}: {error}") from None
        if not isinstance(expression, sympy.Expr):
            raise ConfigError(f"{where}: {text!r} is not an expression")
        unknown = {str(s) for s in expression.free_symbols} - set(symbols)
        if unknown:
            raise ConfigError(f"{where}: unknown names {sorted(unknown)}; expected only {expected_text}")
        undefined = {f.func.__name__ for f in expression.atoms(sympy.Function)} - set(ALLOWED_FUNCTIONS)
        if undefined:
            raise ConfigError(
                f"{where}: unknown functions {sorted(undefined)}; allowed are "
                f"{sorted(k for k in ALLOWED_FUNCTIONS if k not in ('pi', 'E'))}"
            )
        expressions.append(expression.subs(values))
    return expressions


def parse_potential(
    formula: str, coordinates: tuple[str, ...], parameters: dict[str, float], key: str
) -> sympy.Expr:
    """Parse ``formula`` into a sympy expression in the coordinates, parameters substituted.

    ``key`` names the configuration entry in error messages.
    """
    return parse_formulas({"formula": formula}, coordinates, parameters, key, RESERVED_NAMES)[0]


class _KernelPrinter(PythonCodePrinter):
    """Prints math-module calls and full-precision float literals for numba."""

    def _print_Float(self, expr):
        return repr(float(expr))


def _printer() -> _KernelPrinter:
    return _KernelPrinter({"fully_qualified_modules": True, "standard": "python3"})


def kernel_lines(coordinates, outputs, load) -> list[str]:
    """The body of a generated kernel: load the coordinates, share common subexpressions, assign outputs.

    ``outputs`` are ``(target, expression)`` pairs (e.g. ``("out[0]", dV/dx)``); ``load(i)`` is
    the source of coordinate ``i`` (e.g. ``q[i]``, ``q[i, j]``, ``state[i]``). Raises sympy's
    PrintMethodNotImplementedError for a term with no code.
    """
    printer = _printer()
    replacements, reduced = sympy.cse([expr for _, expr in outputs], optimizations="basic")
    lines = [f"{name} = {load(i)}" for i, name in enumerate(coordinates)]
    lines += [f"{symbol} = {printer.doprint(expr)}" for symbol, expr in replacements]
    lines += [f"{target} = {printer.doprint(expr)}" for (target, _), expr in zip(outputs, reduced)]
    return lines


def generate_kernel_source(expression: sympy.Expr, coordinates: tuple[str, ...]) -> str:
    """Source of the potential, gradient, Hessian and block kernels of ``expression``."""
    symbols = [sympy.Symbol(name, real=True) for name in coordinates]
    gradient = [sympy.diff(expression, s) for s in symbols]
    hessian = [[sympy.diff(g, s) for s in symbols] for g in gradient]
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
        "potential": function("potential", "q", kernel_lines(coordinates, [("value", expression)], scalar)),
        "gradient": function(
            "gradient", "q, out", kernel_lines(coordinates, [(f"out[{i}]", g) for i, g in enumerate(gradient)], scalar)
        ),
        "hessian": function(
            "hessian",
            "q, out",
            kernel_lines(coordinates, [(f"out[{i}, {k}]", hessian[i][k]) for i in range(n) for k in range(n)], scalar),
        ),
        "acceleration_block": function(
            "acceleration_block",
            "q, out, count",
            kernel_lines(coordinates, [(f"out[{i}, j]", -g) for i, g in enumerate(gradient)], column),
            loop=True,
        ),
        "potential_block": function(
            "potential_block",
            "q, out, count",
            kernel_lines(coordinates, [("out[j]", expression)], column),
            loop=True,
        ),
    }
    return "import math\n\n\n" + "\n\n".join(sources[name] for name in Kernels._fields)


def _uncompilable(name: str, formula: str, expression: sympy.Expr, coordinates: tuple[str, ...], key: str) -> str:
    """Why the kernels of ``expression`` cannot be generated: the first term of V, its gradient
    or its Hessian that has no code (e.g. DiracDelta, the second derivative of Abs)."""
    printer = _printer()
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
