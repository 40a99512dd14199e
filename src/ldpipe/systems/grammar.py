"""What a formula may contain, checked on its syntax tree without sympy and without evaluating it.

A formula (a potential V, a component of a vector field) is mathematics, never code: numbers,
names (the coordinates, the parameters, the time of a vector field, the constants ``pi`` and
``E``), ``+ - * / **``, unary ``+`` and ``-``, parentheses, and calls of the functions in
:data:`FUNCTIONS` with positional arguments. :func:`formula_tree` reads the text with Python's
parser (which only builds a tree) and refuses every other construct, naming it: attribute access,
subscripts, strings, lambdas, comprehensions, keyword arguments, comparisons, ``^``, ... It needs
no sympy, so the configuration's validation refuses a bad formula before anything is built;
:mod:`ldpipe.systems.formula` turns a checked tree into sympy objects node by node.
"""

from __future__ import annotations

import ast
import keyword
import math
import re

from ..errors import ConfigError

#: The functions a formula may call, each with the least and most arguments it takes (log(x, b)
#: is the logarithm to base b; sympy's sqrt(x, 0) would be an unevaluated root, not mathematics).
FUNCTIONS = {name: (1, 2) if name == "log" else (1, 1)
             for name in ("sin", "cos", "tan", "exp", "log", "sqrt", "sinh", "cosh", "tanh", "atan", "Abs")}
#: The constants a formula may name.
CONSTANTS = ("pi", "E")
#: The longest formula text accepted (characters).
MAX_FORMULA_LENGTH = 10_000
#: The deepest nesting accepted: operations and calls inside one another, a chain of + and - (or
#: of * and /) counting as one level, as sympy flattens it. It keeps the recursion over the tree
#: (here, in the builder, and sympy's over the result) far from Python's recursion limit.
MAX_FORMULA_DEPTH = 100
#: What a coordinate may be called: an ASCII identifier (as the schema says), never a Python keyword.
NAME_PATTERN = re.compile(r"[A-Za-z][A-Za-z0-9_]*")

# The operators a formula may use.
OPERATORS = (ast.Add, ast.Sub, ast.Mult, ast.Div, ast.Pow, ast.UAdd, ast.USub)
# Operators that chain from the left and that sympy flattens: a chain is one level of nesting.
CHAINS = {ast.Add: "sum", ast.Sub: "sum", ast.Mult: "product", ast.Div: "product"}
# Operators a formula may not use, as a message names them.
_REFUSED_OPERATORS = {
    ast.BitXor: "the operator '^' (a power is written **)", ast.FloorDiv: "the operator '//'",
    ast.Mod: "the operator '%'", ast.MatMult: "the operator '@'", ast.LShift: "the operator '<<'",
    ast.RShift: "the operator '>>'", ast.BitOr: "the operator '|'", ast.BitAnd: "the operator '&'",
    ast.Not: "the operator 'not'", ast.Invert: "the operator '~'",
}
# Other constructs, as a message names them.
_REFUSED_NODES = {
    ast.Subscript: "a subscript ('[...]')", ast.Lambda: "a lambda", ast.ListComp: "a comprehension",
    ast.SetComp: "a comprehension", ast.DictComp: "a comprehension", ast.GeneratorExp: "a comprehension",
    ast.List: "a list", ast.Tuple: "a tuple", ast.Set: "a set", ast.Dict: "a dict", ast.JoinedStr: "an f-string",
    ast.NamedExpr: "an assignment (':=')", ast.Compare: "a comparison", ast.BoolOp: "'and' or 'or'",
    ast.IfExp: "a conditional ('if ... else')", ast.Starred: "'*' unpacking", ast.Await: "'await'",
    ast.Yield: "'yield'", ast.YieldFrom: "'yield'",
}
# Parts of constructs, each refused at the construct's own node.
_PARTS = (ast.comprehension, ast.arguments, ast.arg, ast.FormattedValue, ast.Slice, ast.expr_context, ast.cmpop,
          ast.boolop)


def grammar() -> str:
    """What a formula may contain, in one sentence (the end of every refusal)."""
    return (f"A formula is numbers, names, + - * / ** and parentheses, the constants {list(CONSTANTS)} and calls "
            f"of {sorted(FUNCTIONS)} (positional arguments only)")


def odd_names(names) -> list:
    """The ``names`` that may not be printed into a kernel's source as a variable (see :data:`NAME_PATTERN`)."""
    return [n for n in names if not isinstance(n, str) or not NAME_PATTERN.fullmatch(n) or keyword.iskeyword(n)]


def check_formulas(formulas: dict, coordinates, parameters, key: str, time: str | None = None) -> dict:
    """The checked syntax tree of each formula (:func:`formula_tree`), by where it sits.

    ``formulas`` maps where each formula sits under the configuration entry ``key`` (e.g.
    ``"formula"``, ``"vector_field.x"``) to its text; a formula may use the ``coordinates``, the
    ``parameters`` (names), the constants, and ``time`` if given. ConfigError naming the key of
    the first formula that is not one, or of coordinates that are not plain names (they are
    printed into kernels' source).
    """
    odd = odd_names(coordinates)
    if odd:
        raise ConfigError(f"config key '{key}.coordinates': {odd} are not names: a coordinate is a letter, then "
                          "letters, digits or '_', and not a Python keyword")
    expected = [f"the coordinates {list(coordinates)}", f"the parameters {sorted(parameters)}"]
    expected += [f"the time '{time}'"] if time else []
    expected_text = "expected only " + ", ".join(expected[:-1]) + " and " + expected[-1]
    names = {*coordinates, *parameters, *((time,) if time else ())}
    trees = {}
    for place, text in formulas.items():
        where = f"config key '{key}.{place}'"
        if isinstance(text, bool) or not isinstance(text, (str, int, float)):
            raise ConfigError(f"{where}: expected a formula (text), got {text!r}")
        trees[place] = formula_tree(str(text), names, where, expected_text)
    return trees


def formula_tree(text: str, names, where: str, expected: str) -> ast.Expression:
    """The syntax tree of the formula ``text``, checked: ConfigError naming ``where`` and what is
    wrong, if it is not a formula in the ``names`` (coordinates, parameters, time; the constants
    and functions are known here), or is longer or deeper than the limits. ``expected`` says, in
    the message for an unknown name, which names are known. ``text`` is stripped first (sympy's
    parser read ' x' as x). Nothing of ``text`` is evaluated."""
    text = text.strip()
    shown = shown_formula(text)
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
    known = set(names) | set(CONSTANTS)
    refused = _refused_constructs(tree, text, known)
    if refused:
        raise ConfigError(f"{where}: {shown} is not a formula: it contains {', '.join(refused)}. {grammar()}")
    called = {id(node.func) for node in ast.walk(tree) if isinstance(node, ast.Call)}
    unknown = {n.id for n in ast.walk(tree) if isinstance(n, ast.Name) and id(n) not in called and n.id not in known}
    if unknown:
        raise ConfigError(f"{where}: unknown names {sorted(unknown)}; {expected}")
    undefined = {n.func.id for n in ast.walk(tree) if isinstance(n, ast.Call) and n.func.id not in FUNCTIONS}
    if undefined:
        raise ConfigError(f"{where}: unknown functions {sorted(undefined)}; allowed are {sorted(FUNCTIONS)}")
    if nesting(tree) > MAX_FORMULA_DEPTH:
        raise ConfigError(f"{where}: {shown} nests operations and calls more than {MAX_FORMULA_DEPTH} levels deep, "
                          "the most accepted")
    return tree


def shown_formula(text: str) -> str:
    """``text`` quoted for a message, cut at 200 characters."""
    return repr(text) if len(text) <= 200 else repr(text[:200]) + "..."


def nesting(tree: ast.Expression) -> int:
    """How deep ``tree``'s operations and calls nest, a chain of + and - (or of * and /) as one
    level; counted with a stack of its own, not by recursion."""
    deepest, stack = 0, [(tree.body, 1)]
    while stack and deepest <= MAX_FORMULA_DEPTH:
        node, depth = stack.pop()
        deepest = max(deepest, depth)
        for child in ast.iter_child_nodes(node):
            if isinstance(child, ast.expr):
                chained = (child is getattr(node, "left", None) and isinstance(child, ast.BinOp)
                           and CHAINS.get(type(child.op), 0) == CHAINS.get(type(node.op), 1))
                stack.append((child, depth if chained else depth + 1))
    return deepest


def _refused_constructs(tree: ast.Expression, text: str, known: set[str]) -> list[str]:
    """Every construct of ``tree`` a formula may not contain, as a message names it, outermost
    first, each once. ``known``: the names of symbols and constants (not callable)."""
    refused = []
    called = set()
    for node in ast.walk(tree):  # breadth first, without recursion: a Call comes before its function's Name
        what = None
        if isinstance(node, (ast.Expression, ast.BinOp, ast.UnaryOp)):
            pass
        elif isinstance(node, (ast.operator, ast.unaryop)):
            if not isinstance(node, OPERATORS):
                what = _REFUSED_OPERATORS.get(type(node), f"the operator {type(node).__name__}")
        elif isinstance(node, ast.Constant):
            what = _constant(node, text)
        elif isinstance(node, ast.Name):
            if id(node) not in called and node.id in FUNCTIONS:
                what = f"the function '{node.id}' without its argument in parentheses"
        elif isinstance(node, ast.Call):
            if not isinstance(node.func, ast.Name):
                what = "a call of something other than a function's name"
            else:
                called.add(id(node.func))
                if node.func.id in known:
                    what = f"a call of '{node.func.id}', which is not a function"
                elif node.func.id in FUNCTIONS and not FUNCTIONS[node.func.id][0] <= len(node.args) <= FUNCTIONS[node.func.id][1]:
                    low, high = FUNCTIONS[node.func.id]
                    takes = f"{low}" if low == high else f"{low} or {high}"
                    what = f"a call of '{node.func.id}' with {len(node.args)} arguments (it takes {takes})"
        elif isinstance(node, ast.keyword):
            what = "'**' unpacking" if node.arg is None else f"a keyword argument ('{node.arg}=')"
        elif isinstance(node, ast.Attribute):
            what = f"attribute access ('.{node.attr}')"
        elif not isinstance(node, _PARTS):
            what = _REFUSED_NODES.get(type(node), f"a {type(node).__name__} expression")
        if what and what not in refused:
            refused.append(what)
    return refused


def _constant(node: ast.Constant, text: str) -> str | None:
    """Why the literal ``node`` is refused, or None for a number a formula may hold: an int, or a
    float literal inside a double's range (sympy would work out 1e-999999999 to a billion digits)."""
    value = node.value
    if isinstance(value, bool) or value is None:
        return f"the constant {value}"
    if isinstance(value, complex):
        return "an imaginary number"
    if isinstance(value, (str, bytes)):
        return f"a string ({value[:40]!r})"
    if isinstance(value, float):
        literal = ast.get_source_segment(text, node)
        mantissa = re.split("[eE]", literal)[0]
        if not math.isfinite(value) or (value == 0.0 and re.search("[1-9]", mantissa)):
            return f"the number {literal}, outside the range of a double"
        return None
    return None if isinstance(value, int) else f"the constant {value!r}"
