"""A formula is mathematics, never code: the classic escapes from an evaluating parser are refused,
naming the key and the construct, and nothing of them runs.

Every escape carries a payload that would create a sentinel file; each test asserts the file is
absent afterwards. The escapes go in through every door: ``make_system`` (the systems layer),
``ldpipe.system`` (the API), a configuration file (``load_config``, which refuses before anything
is built), and as a component of a vector field. Generated cases (hypothesis: random token
strings, random syntax trees) either parse to an expression in the allowed names and functions or
raise ConfigError, never another exception.
"""

from __future__ import annotations

import ast

import pytest
import sympy
import yaml
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import ldpipe
from ldpipe.config.loading import load_config, validate_config
from ldpipe.errors import ConfigError
from ldpipe.jitcache import module_name
from ldpipe.systems import make_system
from ldpipe.systems.formula import ALLOWED_FUNCTIONS, generate_kernel_source, parse_formulas, parse_potential
from ldpipe.systems.grammar import FUNCTIONS, MAX_FORMULA_DEPTH, MAX_FORMULA_LENGTH, formula_tree

WRAP_CLOSE = next(i for i, c in enumerate(object.__subclasses__()) if c.__name__ == "_wrap_close")


def escapes(sentinel) -> list[tuple[str, str]]:
    """(formula, the construct its refusal names): each would create ``sentinel`` if evaluated."""
    touch = f"touch {sentinel}"
    return [
        # the attribute walk from a tuple literal to os.system, which parse_expr let through
        (f"().__class__.__base__.__subclasses__()[{WRAP_CLOSE}].__init__.__globals__['system']('{touch}')",
         "attribute access ('.__globals__')"),
        (f"__import__('os').system('{touch}')", "attribute access ('.system')"),
        (f"exec(\"__import__('os').system('{touch}')\")", "a string"),
        (f"eval(\"__import__('os').system('{touch}')\")", "a string"),
        (f"getattr(__import__('os'), 'system')('{touch}')", "a call of something other than a function's name"),
        (f"(lambda: __import__('os').system('{touch}'))()", "a lambda"),
        (f"[__import__('os').system('{touch}') for _ in (1,)]", "a comprehension"),
        (f"open('{sentinel}', 'w')", "a string"),
        (f"x.__class__.__init__.__globals__['__builtins__']['exec'](\"import os; os.system('{touch}')\")",
         "a subscript ('[...]')"),
        (f"f'{{__import__(\"os\").system(\"{touch}\")}}'", "an f-string"),
        (f"(s := __import__('os').system('{touch}'))", "an assignment (':=')"),
        (f"sin(x=__import__('os').system('{touch}'))", "a keyword argument ('x=')"),
        (f"sin(**{{'x': __import__('os').system('{touch}')}})", "'**' unpacking"),
        (f"sin(*[__import__('os').system('{touch}')])", "'*' unpacking"),
        (f"x if __import__('os').system('{touch}') else y", "a conditional ('if ... else')"),
        (f"__import__('os').system('{touch}') == 0", "a comparison"),
    ]


# Refused constructs that carry no payload of their own, each with what the message calls it.
PLAIN_REFUSALS = [
    ("x.real", "attribute access ('.real')"),
    ('"abc"', "a string ('abc')"),
    ("x[0]", "a subscript ('[...]')"),
    ("lambda: 0", "a lambda"),
    ("[x for x in ()]", "a comprehension"),
    ("(x, y)", "a tuple"),
    ("x^2", "the operator '^' (a power is written **)"),
    ("x % 2", "the operator '%'"),
    ("x // 2", "the operator '//'"),
    ("x < 1", "a comparison"),
    ("x and y", "'and' or 'or'"),
    ("not x", "the operator 'not'"),
    ("x**2 + True", "the constant True"),
    ("None", "the constant None"),
    ("2j*x", "an imaginary number"),
    ("x(2)", "a call of 'x', which is not a function"),
    ("sin", "the function 'sin' without its argument in parentheses"),
    ("sin(x, y)", "a call of 'sin' with 2 arguments (it takes 1)"),
    ("sqrt(x, 0)", "a call of 'sqrt' with 2 arguments (it takes 1)"),
    ("1e999999999*x", "the number 1e999999999, outside the range of a double"),
    ("1e-99999999*x", "the number 1e-99999999, outside the range of a double"),
]

SPEC = {"coordinates": ["x", "y"], "parameters": {"a": 1.5}}


@pytest.fixture
def sentinel(tmp_path):
    path = tmp_path / "SENTINEL"
    yield path
    assert not path.exists(), "a formula ran code"


def refused(call, *words) -> str:
    """The ConfigError ``call()`` raises; it must contain every word."""
    with pytest.raises(ConfigError) as info:
        call()
    message = str(info.value)
    for word in words:
        assert word in message, message
    return message


def test_the_escapes_are_live_when_evaluated(sentinel):
    # The payloads work: evaluated as sympy's parse_expr evaluated a formula (builtins emptied), the
    # first creates the sentinel. So the refusals below are of real escapes, not of broken text.
    formula, _ = escapes(sentinel)[0]
    eval(formula, {"__builtins__": {}}, {"x": 1})
    assert sentinel.exists()
    sentinel.unlink()


@pytest.mark.parametrize("case", range(16))
def test_escapes_in_a_formula_are_refused_by_make_system(case, sentinel):
    formula, construct = escapes(sentinel)[case]
    refused(lambda: make_system("evil", {"formula": formula, **SPEC}), "config key 'systems.evil.formula'", construct)


@pytest.mark.parametrize("case", range(16))
def test_escapes_in_a_vector_field_are_refused_by_make_system(case, sentinel):
    formula, construct = escapes(sentinel)[case]
    spec = {"vector_field": {"x": "y", "y": formula}, **SPEC}
    refused(lambda: make_system("evil", spec), "config key 'systems.evil.vector_field.y'", construct)


@pytest.mark.parametrize("case", range(16))
def test_escapes_are_refused_by_the_api(case, sentinel):
    formula, construct = escapes(sentinel)[case]
    refused(lambda: ldpipe.system(name="evil", formula=formula, **SPEC), "argument 'formula'", construct)
    refused(lambda: ldpipe.system(name="evil", vector_field={"x": formula, "y": "x"}, **SPEC),
            "argument 'vector_field.x'", construct)


@pytest.mark.parametrize("case", range(16))
def test_escapes_in_a_configuration_file_are_refused_when_it_is_loaded(case, sentinel, tmp_path):
    # The configuration's validation refuses them: before Snakemake plans a job, before any system is built.
    formula, construct = escapes(sentinel)[case]
    path = tmp_path / "config.yaml"
    config = {"systems": {"evil": {"formula": formula, **SPEC}, "flow": {"vector_field": {"x": formula, "y": "x"},
                                                                         **SPEC}}}
    path.write_text(yaml.safe_dump(config))
    refused(lambda: load_config(path), "config key 'systems.evil.formula'", construct)
    del config["systems"]["evil"]
    refused(lambda: validate_config(config), "config key 'systems.flow.vector_field.x'", construct)


@pytest.mark.parametrize("formula, construct", PLAIN_REFUSALS)
def test_other_constructs_are_refused_naming_them(formula, construct):
    message = refused(lambda: make_system("odd", {"formula": formula, **SPEC}), "config key 'systems.odd.formula'",
                      construct)
    assert "A formula is numbers, names, + - * / ** and parentheses" in message or "outside the range" in message


def test_unknown_names_and_functions_are_refused_as_before():
    refused(lambda: make_system("odd", {"formula": "__builtins__ + x", **SPEC}), "unknown names ['__builtins__']")
    refused(lambda: make_system("odd", {"formula": "exec(x)", **SPEC}), "unknown functions ['exec']")
    refused(lambda: make_system("odd", {"formula": "Rational(1, 3)*x", **SPEC}), "unknown functions ['Rational']")


def test_limits_refuse_formulas_that_would_hang_or_crash_the_parser():
    def parse(text):
        return parse_formulas({"formula": text}, ("x", "y"), {}, "systems.big", set())

    refused(lambda: parse("x" + " + x" * MAX_FORMULA_LENGTH), "characters long", str(MAX_FORMULA_LENGTH))
    refused(lambda: parse("-" * 5000 + "x"), "cannot parse", "nested too deeply")
    refused(lambda: parse("x" + "**x" * (MAX_FORMULA_DEPTH + 1)), f"more than {MAX_FORMULA_DEPTH} levels")
    refused(lambda: parse("sin(" * 300 + "x" + ")" * 300), "cannot parse")  # Python's own limit: 200 parentheses
    refused(lambda: parse("9**9**9"), "exact number 9**387420489")
    refused(lambda: parse("2**-(10**5)"), "exact number")
    refused(lambda: parse("x\0"), "cannot parse")
    # a long sum is one level of nesting, however many terms it has
    assert parse(" + ".join(f"{k}*x**{k}" for k in range(1, 400)))[0].is_polynomial()


@pytest.mark.parametrize("name", ["x); import os; (", "lambda", "None", "_x", "__class__", "xé", "x y", ""])
def test_a_coordinate_that_is_not_a_plain_name_never_reaches_the_kernel_source(name):
    # Coordinates are printed into the kernels' source as variables: only ASCII identifiers that
    # are not keywords get there, whichever door the name comes in by.
    spec = {"formula": "x**2", "coordinates": ["x", name]}
    with pytest.raises(ConfigError):
        validate_config({"systems": {"odd": spec}})
    with pytest.raises(ConfigError, match="coordinates"):
        parse_potential("x**2", ("x", name), {}, "systems.odd")
    with pytest.raises(ConfigError, match="coordinates"):
        make_system("odd", spec)


def test_parameter_names_never_reach_the_kernel_source():
    # Parameters are substituted as numbers before printing: an odd name is unusable, never code.
    name = "a); import os; os.system('true'); ("
    source = generate_kernel_source(parse_potential("x**2 + y**2", ("x", "y"), {name: 2.0}, "systems.odd"), ("x", "y"))
    assert "import os" not in source and "system" not in source
    ast.parse(source)


def test_a_system_name_makes_only_an_identifier_of_a_module_name():
    # A system's name reaches generated code only as part of its module's (and file's) name.
    for name in ("x); import os; (", "../../etc/passwd", "a b"):
        assert module_name("x = 1\n", f"formula_{name}").isidentifier()


# --- the expressions valid formulas give, against expressions built by hand ------------------------
X, Y, T = (sympy.Symbol(n, real=True) for n in "xyt")
LAM, A, D, EPS, W = (sympy.Symbol(n, real=True) for n in ("lam", "A", "D", "eps", "w"))
HAND_BUILT = [
    # config.quick.yaml's Hénon-Heiles
    ("(x**2 + y**2)/2 + lam*(x**2*y - y**3/3)",
     (X**2 + Y**2) / 2 + LAM * (X**2 * Y - Y**3 / 3)),
    # the forced Duffing oscillator of config.quick.yaml and the docs (time-dependent)
    ("x - x**3 - D*y + A*cos(w*t)", X - X**3 - D * Y + A * sympy.cos(W * T)),
    # a float literal is sympy's Float of its text (15 digits), and -0.8 is -(0.8)
    ("2*(1 - exp(-0.8*x))**2 + y**2/2", 2 * (1 - sympy.exp(-sympy.Float("0.8") * X))**2 + Y**2 / 2),
    # a longer literal keeps its digits (quadratic_saddle writes repr()s of floats)
    ("(-0.5773502691896258)*x + 1e-3*y", -sympy.Float("0.5773502691896258") * X + sympy.Float("1e-3") * Y),
    ("1 - cos(x) + sqrt(1 + y**2) + x*log(3 + y)/10 + x*y/(10*(2 + y)) + (2 + x)**2.5/50",
     1 - sympy.cos(X) + sympy.sqrt(1 + Y**2) + X * sympy.log(3 + Y) / 10 + X * Y / (10 * (2 + Y))
     + (2 + X)**sympy.Float("2.5") / 50),
    ("-pi*A*sin(pi*(eps*sin(w*t)*x**2 + (1 - 2*eps*sin(w*t))*x))*cos(pi*y)",
     -sympy.pi * A * sympy.sin(sympy.pi * (EPS * sympy.sin(W * T) * X**2 + (1 - 2 * EPS * sympy.sin(W * T)) * X))
     * sympy.cos(sympy.pi * Y)),
    ("Abs(x)**3 + y**2/2 + E**x + log(x, 2) + atan(y) + tanh(x)",
     sympy.Abs(X)**3 + Y**2 / 2 + sympy.E**X + sympy.log(X, 2) + sympy.atan(Y) + sympy.tanh(X)),
    # integers stay exact: 1/2 is a Rational, 1_000 and 0x10 integers
    ("1/2*x + 1_000*y - 0x10 + +x", sympy.Rational(1, 2) * X + 1000 * Y - 16 + X),
]


@pytest.mark.parametrize("formula, expected", HAND_BUILT)
def test_valid_formulas_give_the_expression_built_by_hand(formula, expected):
    names = sorted(n.id for n in ast.walk(ast.parse(formula, mode="eval")) if isinstance(n, ast.Name)
                   and n.id not in ALLOWED_FUNCTIONS and n.id != "t")
    (parsed,) = parse_formulas({"formula": formula}, tuple(names), {}, "systems.s", set(), time="t")
    assert sympy.srepr(parsed) == sympy.srepr(expected)


# --- generated cases ----------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def generated_sentinel(tmp_path_factory):
    path = tmp_path_factory.mktemp("generated") / "SENTINEL"
    yield path
    assert not path.exists(), "a generated formula ran code"


def check_outcome(text: str, names=("x", "y")) -> None:
    """``text`` parses to an expression in the allowed names and functions, or raises ConfigError."""
    try:
        (expression,) = parse_formulas({"formula": text}, names, {"a": 2.0}, "systems.g", set(), time="t")
    except ConfigError as error:
        assert "config key 'systems.g" in str(error)
        return
    assert isinstance(expression, sympy.Expr)
    assert {str(s) for s in expression.free_symbols} <= {*names, "t"}
    assert {f.func.__name__ for f in expression.atoms(sympy.Function)} <= set(FUNCTIONS)


def tokens(sentinel) -> list[str]:
    return ["x", "y", "a", "t", "1", "0.5", "1e3", "2", "pi", "E", "sin", "log", "sqrt", "foo", "exec", "eval",
            "getattr", "open", "__import__", "__class__", "__subclasses__", "__globals__", "__builtins__", "os",
            "system", "_", "__", ".", "[", "]", "(", ")", "(", ")", ",", ":", ";", "'", '"', "f'", "{", "}", "+", "-",
            "*", "/", "**", "^", "%", "//", "@", "=", "==", ":=", "<", "!", "~", "lambda", "for", "in", "if", "else",
            "not", "and", "True", "None", "j", "import", " ", "\n", "\\", "#", f"'touch {sentinel}'"]


@settings(max_examples=300, deadline=None, derandomize=True,
          suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(data=st.data())
def test_random_token_strings_parse_or_are_refused(data, generated_sentinel):
    words = data.draw(st.lists(st.sampled_from(tokens(generated_sentinel)), min_size=1, max_size=25))
    check_outcome(data.draw(st.sampled_from(["", " "])).join(words))


def _trees(sentinel):
    """Random expression trees over every node kind, the forbidden ones too."""
    names = st.sampled_from(["x", "y", "a", "t", "pi", "E", "k", "__import__", "__builtins__", "os"])
    leaves = st.one_of(
        names.map(lambda n: ast.Name(n, ast.Load())),
        st.one_of(st.integers(0, 12), st.floats(allow_nan=False, allow_infinity=False, width=32),
                  st.sampled_from(["os", f"touch {sentinel}", b"x", True, None, 1j, ...])).map(ast.Constant),
    )
    operators = st.sampled_from([ast.Add, ast.Sub, ast.Mult, ast.Div, ast.Pow, ast.BitXor, ast.Mod, ast.FloorDiv,
                                 ast.MatMult])
    functions = st.sampled_from([*FUNCTIONS, "exec", "eval", "getattr", "open", "foo", "x"])

    def branches(children):
        return st.one_of(
            st.builds(lambda l, o, r: ast.BinOp(l, o(), r), children, operators, children),
            st.builds(lambda o, e: ast.UnaryOp(o(), e), st.sampled_from([ast.USub, ast.UAdd, ast.Not, ast.Invert]),
                      children),
            st.builds(lambda f, args: ast.Call(ast.Name(f, ast.Load()), args, []), functions,
                      st.lists(children, min_size=0, max_size=3)),
            st.builds(lambda f, e: ast.Call(ast.Name(f, ast.Load()), [], [ast.keyword("x", e)]), functions, children),
            st.builds(lambda e, attr: ast.Attribute(e, attr, ast.Load()), children,
                      st.sampled_from(["__class__", "real", "system", "__globals__"])),
            st.builds(lambda e, i: ast.Subscript(e, i, ast.Load()), children, children),
            st.builds(lambda e: ast.Lambda(ast.arguments([], [], None, [], [], None, []), e), children),
            st.builds(lambda es: ast.Tuple(es, ast.Load()), st.lists(children, max_size=2)),
            st.builds(lambda l, r: ast.Compare(l, [ast.Lt()], [r]), children, children),
            st.builds(lambda c, a, b: ast.IfExp(c, a, b), children, children, children),
            st.builds(lambda e: ast.Call(ast.Attribute(e, "system", ast.Load()), [], []), children),
        )

    return st.recursive(leaves, branches, max_leaves=12)


@settings(max_examples=300, deadline=None, derandomize=True,
          suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(data=st.data())
def test_random_syntax_trees_parse_or_are_refused(data, generated_sentinel):
    tree = data.draw(_trees(generated_sentinel))
    check_outcome(ast.unparse(ast.fix_missing_locations(ast.Expression(tree))))


def _valid_trees():
    """Random trees of the grammar alone: they must parse, to what sympy's parser gave."""
    leaves = st.one_of(st.sampled_from(["x", "y", "t", "pi", "E"]).map(lambda n: ast.Name(n, ast.Load())),
                       st.integers(0, 9).map(ast.Constant),
                       st.floats(0.001, 100, allow_nan=False).map(ast.Constant))

    def branches(children):
        return st.one_of(
            st.builds(lambda l, o, r: ast.BinOp(l, o(), r), children,
                      st.sampled_from([ast.Add, ast.Sub, ast.Mult, ast.Div]), children),
            st.builds(lambda l, r: ast.BinOp(l, ast.Pow(), ast.Constant(r)), children, st.integers(-3, 3)),
            st.builds(lambda o, e: ast.UnaryOp(o(), e), st.sampled_from([ast.USub, ast.UAdd]), children),
            st.builds(lambda f, e: ast.Call(ast.Name(f, ast.Load()), [e], []),
                      st.sampled_from(sorted(FUNCTIONS)), children),
        )

    return st.recursive(leaves, branches, max_leaves=10)


def sympy_parser(text: str) -> sympy.Expr:
    """``text`` as sympy's own parser reads it, as ldpipe once called it (only ever given formulas
    of the grammar here: it evaluates what it reads)."""
    from sympy.parsing.sympy_parser import parse_expr, standard_transformations

    names = {**ALLOWED_FUNCTIONS, **{n: sympy.Symbol(n, real=True) for n in ("x", "y", "t")}}
    literals = {k: getattr(sympy, k) for k in ("Integer", "Float", "Rational", "Symbol", "Function")}
    return parse_expr(text, local_dict=names, global_dict={"__builtins__": {}, **literals},
                      transformations=standard_transformations)


@settings(max_examples=200, deadline=None, derandomize=True)
@given(tree=_valid_trees())
def test_random_formulas_of_the_grammar_give_what_sympys_parser_gave(tree):
    text = ast.unparse(ast.fix_missing_locations(ast.Expression(tree)))
    formula_tree(text, {"x", "y", "t"}, "systems.v", "")  # never refused
    (parsed,) = parse_formulas({"formula": text}, ("x", "y"), {}, "systems.v", set(), time="t")
    assert sympy.srepr(parsed) == sympy.srepr(sympy_parser(text))
