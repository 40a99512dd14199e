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
import keyword
import math
import operator
import re

import sympy
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
ALLOWED_FUNCTIONS["E"] = sympy.E
# Names the generated kernels use themselves.
RESERVED_NAMES = {"q", "out", "count", "j", "math", "value", "_njit", *Kernels._fields}

# A formula is parsed, never evaluated: Python's parser gives the tree, and only the node kinds
# below become sympy objects; anything else (attributes, subscripts, strings, lambdas, ...) is
# refused by name. Numbers become sympy numbers as sympy's own parser made them (Integer, and
# Float of the literal's text), and each operator is applied to sympy objects as Python applied
# it, so an accepted formula gives the expression, and the kernel text, it always gave.
BINARY_OPERATORS = {ast.Add: operator.add, ast.Sub: operator.sub, ast.Mult: operator.mul,
                    ast.Div: operator.truediv, ast.Pow: operator.pow}
UNARY_OPERATORS = {ast.UAdd: operator.pos, ast.USub: operator.neg}
# The constants a formula may name; the functions it may call, with how many arguments each
# takes (log(x, b) is the logarithm to base b; sympy's sqrt(x, 0) would be an unevaluated root).
CONSTANTS = {name: ALLOWED_FUNCTIONS[name] for name in ("pi", "E")}
ARGUMENTS = {name: (1, 2) if name == "log" else (1, 1) for name in ALLOWED_FUNCTIONS if name not in CONSTANTS}
#: The longest formula text accepted (characters).
MAX_FORMULA_LENGTH = 10_000
#: The deepest nesting accepted: operations and calls inside one another, a chain of + and - (or
#: of * and /) counting as one level. It keeps the parser's recursion (and sympy's on the result)
#: far from Python's recursion limit.
MAX_FORMULA_DEPTH = 100
#: The largest exact number a power of exact numbers may make, in bits: 9**9**9 would take
#: minutes and gigabytes to compute exactly.
MAX_EXACT_BITS = 4096
#: What a coordinate may be called: an ASCII identifier (as the schema says), never a Python keyword.
NAME_PATTERN = re.compile(r"[A-Za-z][A-Za-z0-9_]*")
# Operators a formula may not use, by how a message names them.
_REFUSED_OPERATORS = {
    ast.BitXor: "the operator '^' (a power is written **)", ast.FloorDiv: "the operator '//'",
    ast.Mod: "the operator '%'", ast.MatMult: "the operator '@'", ast.LShift: "the operator '<<'",
    ast.RShift: "the operator '>>'", ast.BitOr: "the operator '|'", ast.BitAnd: "the operator '&'",
    ast.Not: "the operator 'not'", ast.Invert: "the operator '~'",
}
# Other constructs, by how a message names them.
_REFUSED_NODES = {
    ast.Subscript: "a subscript ('[...]')", ast.Lambda: "a lambda",
    ast.ListComp: "a comprehension", ast.SetComp: "a comprehension", ast.DictComp: "a comprehension",
    ast.GeneratorExp: "a comprehension", ast.List: "a list", ast.Tuple: "a tuple", ast.Set: "a set",
    ast.Dict: "a dict", ast.JoinedStr: "an f-string", ast.NamedExpr: "an assignment (':=')",
    ast.Compare: "a comparison", ast.BoolOp: "'and' or 'or'", ast.IfExp: "a conditional ('if ... else')",
    ast.Starred: "'*' unpacking", ast.Await: "'await'", ast.Yield: "'yield'", ast.YieldFrom: "'yield'",
}


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
    as Python (:func:`parse_formula`).
    """
    # Coordinates are printed into the kernels' source: only plain identifiers reach it.
    odd = [c for c in coordinates if not isinstance(c, str) or not NAME_PATTERN.fullmatch(c) or keyword.iskeyword(c)]
    if odd:
        raise ConfigError(f"config key '{key}.coordinates': {odd} are not names: a coordinate is a letter, then "
                          "letters, digits or '_', and not a Python keyword")
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
    namespace = {**CONSTANTS, **symbols}
    values = {symbols[name]: sympy.Float(value, 17) for name, value in parameters.items()}
    expected = [f"the coordinates {list(coordinates)}", f"the parameters {sorted(parameters)}"]
    expected += [f"the time '{time}'"] if time else []
    expected_text = ", ".join(expected[:-1]) + " and " + expected[-1]
    expressions = []
    for place, text in formulas.items():
        where = f"config key '{key}.{place}'"
        if isinstance(text, bool) or not isinstance(text, (str, int, float)):
            raise ConfigError(f"{where}: expected a formula (text), got {text!r}")
        expression = parse_formula(str(text), namespace, where, f"expected only {expected_text}")
        expressions.append(expression.subs(values))
    return expressions


def parse_formula(text: str, names: dict[str, sympy.Expr], where: str, expected: str) -> sympy.Expr:
    """The sympy expression of ``text``, built from its syntax tree, never evaluated as Python.

    A formula is numbers, the ``names`` (symbols and constants), ``+ - * / **``, parentheses and
    calls of the allowed functions with positional arguments. Anything else is refused with a
    ConfigError naming ``where`` and the construct; ``expected`` says which names are known.
    """
    text = text.strip()  # sympy's parser read ' x' as x; Python's parser calls it an indent
    shown = repr(text) if len(text) <= 200 else repr(text[:200]) + "..."
    if len(text) > MAX_FORMULA_LENGTH:
        raise ConfigError(f"{where}: the formula is {len(text)} characters long; at most {MAX_FORMULA_LENGTH} are "
                          "accepted")
    try:
        tree = ast.parse(text, mode="eval")
    except SyntaxError as error:
        column = f" (column {error.offset})" if error.offset else ""
        raise ConfigError(f"{where}: cannot parse {shown}: {error.msg}{column}") from None
    except ValueError as error:  # e.g. a NUL character
        raise ConfigError(f"{where}: cannot parse {shown}: {error}") from None
    except (RecursionError, MemoryError):  # Python's parser gives up on thousands of nested operators
        raise ConfigError(f"{where}: cannot parse {shown}: nested too deeply for Python's parser; at most "
                          f"{MAX_FORMULA_DEPTH} levels are accepted") from None
    refused = _refused_constructs(tree, names)
    if refused:
        raise ConfigError(f"{where}: {shown} is not a formula: it contains {', '.join(refused)}. {grammar()}")
    called = {id(node.func) for node in ast.walk(tree) if isinstance(node, ast.Call)}
    unknown = {n.id for n in ast.walk(tree) if isinstance(n, ast.Name) and id(n) not in called and n.id not in names}
    if unknown:
        raise ConfigError(f"{where}: unknown names {sorted(unknown)}; {expected}")
    undefined = {n.func.id for n in ast.walk(tree) if isinstance(n, ast.Call) and n.func.id not in ARGUMENTS}
    if undefined:
        raise ConfigError(f"{where}: unknown functions {sorted(undefined)}; allowed are {sorted(ARGUMENTS)}")
    try:
        expression = _Builder(text, names, where, shown).build(tree.body, 1)
    except (ArithmeticError, TypeError, ValueError) as error:
        raise ConfigError(f"{where}: cannot parse {shown}: {error}") from None
    if not isinstance(expression, sympy.Expr):
        raise ConfigError(f"{where}: {shown} is not an expression")
    return expression


def grammar() -> str:
    """What a formula may contain, in one sentence (the end of every refusal)."""
    return (f"A formula is numbers, names, + - * / ** and parentheses, the constants {sorted(CONSTANTS)} and calls "
            f"of {sorted(ARGUMENTS)} (positional arguments only)")


def _refused_constructs(tree: ast.Expression, names: dict) -> list[str]:
    """Every construct of ``tree`` a formula may not contain, as a message names it, in order
    (outermost first), each once."""
    refused = []
    called = set()
    for node in ast.walk(tree):  # breadth first, without recursion: a Call comes before its function's Name
        what = None
        if isinstance(node, (ast.Expression, ast.BinOp, ast.UnaryOp, ast.Load)):
            pass
        elif isinstance(node, (ast.operator, ast.unaryop)):
            if type(node) not in BINARY_OPERATORS and type(node) not in UNARY_OPERATORS:
                what = _REFUSED_OPERATORS.get(type(node), f"the operator {type(node).__name__}")
        elif isinstance(node, ast.Constant):
            value = node.value
            if isinstance(value, bool) or value is None:
                what = f"the constant {value}"
            elif isinstance(value, complex):
                what = "an imaginary number"
            elif isinstance(value, (str, bytes)):
                what = f"a string ({value[:40]!r})"
            elif not isinstance(value, (int, float)):
                what = f"the constant {value!r}"
        elif isinstance(node, ast.Name):
            if id(node) not in called and node.id in ARGUMENTS:
                what = f"the function '{node.id}' without its argument in parentheses"
        elif isinstance(node, ast.Call):
            if not isinstance(node.func, ast.Name):
                what = "a call of something other than a function's name"
            else:
                called.add(id(node.func))
                if node.func.id in names:
                    what = f"a call of '{node.func.id}', which is not a function"
                elif node.func.id in ARGUMENTS:
                    low, high = ARGUMENTS[node.func.id]
                    given = len(node.args)
                    if not low <= given <= high:
                        takes = f"{low}" if low == high else f"{low} or {high}"
                        what = f"a call of '{node.func.id}' with {given} arguments (it takes {takes})"
        elif isinstance(node, ast.keyword):
            what = "'**' unpacking" if node.arg is None else f"a keyword argument ('{node.arg}=')"
        elif isinstance(node, ast.Attribute):
            what = f"attribute access ('.{node.attr}')"
        elif isinstance(node, (ast.comprehension, ast.arguments, ast.arg, ast.FormattedValue, ast.Slice,
                               ast.expr_context, ast.cmpop, ast.boolop)):
            pass  # parts of a construct refused at its own node
        else:
            what = _REFUSED_NODES.get(type(node), f"a {type(node).__name__} expression")
        if what and what not in refused:
            refused.append(what)
    return refused


class _Builder:
    """Builds the sympy expression of a checked syntax tree (:func:`parse_formula`), node by node."""

    def __init__(self, text: str, names: dict, where: str, shown: str):
        self.text, self.names, self.where, self.shown = text, names, where, shown

    def build(self, node: ast.expr, depth: int):
        if depth > MAX_FORMULA_DEPTH:
            raise ConfigError(f"{self.where}: {self.shown} nests operations and calls more than "
                              f"{MAX_FORMULA_DEPTH} levels deep, the most accepted")
        if isinstance(node, ast.BinOp) and type(node.op) in _CHAINS:
            # a + b - c + ... is a tree as deep as it is long: walk down its left operands in a loop
            # and apply the operators from the left, as Python does.
            chain, chained = [], _CHAINS[type(node.op)]
            while isinstance(node, ast.BinOp) and _CHAINS.get(type(node.op)) == chained:
                chain.append((node.op, node.right))
                node = node.left
            value = self.build(node, depth + 1)
            for op, right in reversed(chain):
                value = BINARY_OPERATORS[type(op)](value, self.build(right, depth + 1))
            return value
        if isinstance(node, ast.BinOp) and isinstance(node.op, ast.Pow):
            base, exponent = self.build(node.left, depth + 1), self.build(node.right, depth + 1)
            self.check_power(base, exponent)
            return base**exponent
        if isinstance(node, ast.UnaryOp) and type(node.op) in UNARY_OPERATORS:
            return UNARY_OPERATORS[type(node.op)](self.build(node.operand, depth + 1))
        if isinstance(node, ast.Constant) and type(node.value) is int:
            return sympy.Integer(node.value)
        if isinstance(node, ast.Constant) and type(node.value) is float:
            return self.float_literal(ast.get_source_segment(self.text, node))
        if isinstance(node, ast.Name) and node.id in self.names:
            return self.names[node.id]
        if isinstance(node, ast.Call) and isinstance(node.func, ast.Name) and node.func.id in ARGUMENTS:
            return ALLOWED_FUNCTIONS[node.func.id](*(self.build(argument, depth + 1) for argument in node.args))
        # _refused_constructs let nothing else through; should it ever, refuse rather than guess
        raise ConfigError(f"{self.where}: cannot parse {self.shown}: unexpected {type(node).__name__}")

    def float_literal(self, literal: str) -> sympy.Float:
        """``Float`` of the literal's text, as sympy's parser made it (``0.1`` is the decimal 0.1
        at 15 digits, a longer literal keeps its digits); refused outside a double's range, where
        sympy would work out a number of a billion digits."""
        value = float(literal)
        mantissa = re.split("[eE]", literal)[0]
        if not math.isfinite(value) or (value == 0.0 and re.search("[1-9]", mantissa)):
            raise ConfigError(f"{self.where}: the number {literal} in {self.shown} is outside the range of a double")
        return sympy.Float(literal)

    def check_power(self, base, exponent) -> None:
        """Refuse an exact power too large to compute (9**9**9), before sympy starts on it."""
        if isinstance(base, sympy.Rational) and isinstance(exponent, sympy.Rational) and base.p and abs(base.p) != base.q:
            bits = math.log2(max(abs(base.p), base.q)) * abs(exponent)
            if bits > MAX_EXACT_BITS:
                raise ConfigError(f"{self.where}: {self.shown} makes the exact number {base}**{exponent}, of about "
                                  f"{int(bits)} bits; at most {MAX_EXACT_BITS} are accepted")


# Operators that chain from the left and that sympy flattens: a chain counts as one level of nesting.
_CHAINS = {ast.Add: "sum", ast.Sub: "sum", ast.Mult: "product", ast.Div: "product"}


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
