"""Systems given as a formula for V(q): derivatives by sympy, kernels by code generation.

The generated kernels have exactly the signatures and loop shapes of the
hand-written built-ins (see :mod:`ldpipe.systems.base`), with the parameter
values substituted as literals, and are compiled the same way
(:func:`~ldpipe.systems.base.compile_kernels`). The formula parser (:func:`parse_formulas`)
and the kernel printer (:func:`kernel_lines`) serve vector fields too
(:mod:`ldpipe.systems.vector_field`): one set of rules for names, parameters and functions.
"""

from __future__ import annotations

import ast
import math
import operator

import sympy
from sympy.printing.codeprinter import PrintMethodNotImplementedError
from sympy.printing.pycode import PythonCodePrinter

from ..errors import ConfigError
from .base import Kernels, System, compile_kernels
from .grammar import CHAINS, CONSTANTS, FUNCTIONS, check_formulas, shown_formula

# What the names a formula may call or name (ldpipe.systems.grammar) stand for.
ALLOWED_FUNCTIONS = {name: getattr(sympy, name) for name in (*FUNCTIONS, *CONSTANTS)}
# Names the generated kernels use themselves.
RESERVED_NAMES = {"q", "out", "count", "j", "math", "value", "_njit", *Kernels._fields}
# A formula is parsed, never evaluated: ldpipe.systems.grammar checks its syntax tree, and only the
# node kinds it lets through become sympy objects here. Numbers become sympy numbers as sympy's
# own parser made them (Integer, and Float of the literal's text), and each operator is applied to
# sympy objects as Python applied it, so a formula gives the expression, and the kernel text, it
# always gave.
BINARY_OPERATORS = {ast.Add: operator.add, ast.Sub: operator.sub, ast.Mult: operator.mul,
                    ast.Div: operator.truediv, ast.Pow: operator.pow}
UNARY_OPERATORS = {ast.UAdd: operator.pos, ast.USub: operator.neg}
#: The largest exact number a power of exact numbers may make, in bits: 9**9**9 would take
#: minutes and gigabytes to compute exactly.
MAX_EXACT_BITS = 4096


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
    ``time``: the name of the time, if the formulas may use it. Nothing in a formula is evaluated
    as Python: :func:`ldpipe.systems.grammar.check_formulas` checks each one's syntax tree, and
    the tree is built into sympy objects node by node.
    """
    clash = (set(coordinates) | set(parameters)) & (reserved | set(ALLOWED_FUNCTIONS))
    if clash:
        raise ConfigError(f"config key '{key}': the names {sorted(clash)} are reserved; rename them")
    overlap = set(coordinates) & set(parameters)
    if overlap:
        raise ConfigError(
            f"config key '{key}.parameters': {sorted(overlap)} are also coordinates; a name is one or the other"
        )
    trees = check_formulas(formulas, coordinates, parameters, key, time)
    names = (*coordinates, *parameters, *((time,) if time else ()))
    symbols = {name: sympy.Symbol(name, real=True) for name in names}
    namespace = {**{name: ALLOWED_FUNCTIONS[name] for name in CONSTANTS}, **symbols}
    values = {symbols[name]: sympy.Float(value, 17) for name, value in parameters.items()}
    expressions = []
    for place, tree in trees.items():
        text = str(formulas[place]).strip()
        where, shown = f"config key '{key}.{place}'", shown_formula(text)
        try:
            expression = _Builder(text, namespace, where, shown).build(tree.body)
        except (ArithmeticError, TypeError, ValueError) as error:
            raise ConfigError(f"{where}: cannot parse {shown}: {error}") from None
        if not isinstance(expression, sympy.Expr):
            raise ConfigError(f"{where}: {shown} is not an expression")
        expressions.append(expression.subs(values))
    return expressions


class _Builder:
    """Builds the sympy expression of a checked syntax tree, node by node. The tree's nesting is
    bounded (:data:`~ldpipe.systems.grammar.MAX_FORMULA_DEPTH`), and so is this recursion."""

    def __init__(self, text: str, names: dict, where: str, shown: str):
        self.text, self.names, self.where, self.shown = text, names, where, shown

    def build(self, node: ast.expr):
        if isinstance(node, ast.BinOp) and type(node.op) in CHAINS:
            # a + b - c + ... is a tree as deep as it is long: walk down its left operands in a loop
            # and apply the operators from the left, as Python does.
            chain, chained = [], CHAINS[type(node.op)]
            while isinstance(node, ast.BinOp) and CHAINS.get(type(node.op)) == chained:
                chain.append((node.op, node.right))
                node = node.left
            value = self.build(node)
            for op, right in reversed(chain):
                value = BINARY_OPERATORS[type(op)](value, self.build(right))
            return value
        if isinstance(node, ast.BinOp) and isinstance(node.op, ast.Pow):
            base, exponent = self.build(node.left), self.build(node.right)
            self.check_power(base, exponent)
            return base**exponent
        if isinstance(node, ast.UnaryOp) and type(node.op) in UNARY_OPERATORS:
            return UNARY_OPERATORS[type(node.op)](self.build(node.operand))
        if isinstance(node, ast.Constant) and type(node.value) is int:
            return sympy.Integer(node.value)
        if isinstance(node, ast.Constant) and type(node.value) is float:
            # the literal's text, as sympy's parser read it: 0.1 is the decimal 0.1 at 15 digits,
            # a longer literal keeps its digits
            return sympy.Float(ast.get_source_segment(self.text, node))
        if isinstance(node, ast.Name) and node.id in self.names:
            return self.names[node.id]
        if isinstance(node, ast.Call) and isinstance(node.func, ast.Name) and node.func.id in FUNCTIONS:
            return ALLOWED_FUNCTIONS[node.func.id](*(self.build(argument) for argument in node.args))
        # the grammar let nothing else through; should it ever, refuse rather than guess
        raise ConfigError(f"{self.where}: cannot parse {self.shown}: unexpected {type(node).__name__}")

    def check_power(self, base, exponent) -> None:
        """Refuse an exact power too large to compute (9**9**9), before sympy starts on it."""
        if isinstance(base, sympy.Rational) and isinstance(exponent, sympy.Rational) and base.p and abs(base.p) != base.q:
            bits = math.log2(max(abs(base.p), base.q)) * abs(exponent)
            if bits > MAX_EXACT_BITS:
                raise ConfigError(f"{self.where}: {self.shown} makes the exact number {base}**{exponent}, of about "
                                  f"{int(bits)} bits; at most {MAX_EXACT_BITS} are accepted")


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
