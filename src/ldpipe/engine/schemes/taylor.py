"""The ``taylor`` scheme: Taylor series stepping for q'' = a(q), the potential given by a formula.

Along a trajectory q(t) = sum_k q_k t^k, and q'' = a(q) gives the recurrence

    q_{k+2} = a^[k] / ((k + 1)(k + 2)),

where a^[k], the k-th Taylor coefficient of t -> a(q(t)), needs q_0..q_k only: a constant
term of a contributes at k = 0, a linear term c q_l contributes c q_{l,k}, and a monomial of
degree d >= 2 the k-th coefficient of a product of series, by Cauchy products
(sum_{l=0}^k f_l g_{k-l}; half of it for a square), chained for d > 2. The acceleration's
monomials come from the system's formula by sympy, so the scheme serves every polynomial
potential (the built-ins give their formula too).

A potential that is not a polynomial (exp, log, sin, cos, sqrt, real and negative powers,
quotients; tan and the hyperbolic functions rewritten in these) takes auxiliary series
instead: the acceleration's sympy expression tree becomes one series per distinct
subexpression, each with its standard recurrence (automatic differentiation, Jorba & Zou
2005; heyoka does the same; see :class:`ExpressionSeries`). A polynomial's source stays that
of the monomials above. A term with no recurrence (Abs's sign) gets a ConfigError naming the
system and the term.

With the momentum series p = q' taken to degree m (the *order*; q to degree m + 1), the step
follows Jorba & Zou (Experiment. Math. 14, 2005): with rho_k = max over the components of
|x_c^[k]| / (atol + rtol |x_c|), x = (q, p),

    h = SAFETY * min(rho_m^(-1/m), rho_{m-1}^(-1/(m-1))),

so the first terms left out are about the tolerance; two orders guard against a coefficient
that vanishes by symmetry. The step is chosen before it is taken: no rejected attempts. The
default order, ceil(-ln(tol) / 2) + 1, balances the cost of the series (~m^2 per product)
against the number of steps (Jorba & Zou; heyoka's choice too). The LD settings start from
it: five more for the arc length (an engine step's fixed work outweighs the series), two
less for |v|^p (shorter steps for the cusp quadrature); see :meth:`Taylor.order_for`.

The series is the step's dense output, of the step's own order: the velocity polynomials
VC of the LD quadrature are the series of p and of a(q(t)), and the configuration
polynomials QC (event location) that of q, each in x = t / h.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from ...errors import ConfigError
from ..integrands import is_arclength
from ..stepping import Layout, SchemeSource, lane_loops
from .base import AdaptiveScheme

# Safety factor of the step rule: the coefficient estimate of the truncation error is not a
# bound, so the step stays a little inside it.
SAFETY = 0.95
MIN_ORDER = 4
MAX_ORDER = 40


def jorba_zou_order(tolerance: float) -> int:
    """Jorba & Zou's order for a tolerance, ceil(-ln(tol) / 2) + 1 (not clipped to the limits)."""
    return math.ceil(-math.log(tolerance) / 2.0) + 1


@dataclass(frozen=True)
class Acceleration:
    """a_i(q) = sum over ``terms[i]`` of coefficient * prod_l q_l^(exponent_l).

    ``products`` lists the series products the monomials of degree >= 2 need, each as
    (left, right) operands: ("q", l) is the series of q_l, ("product", r) an earlier product;
    ``monomials`` maps an exponent tuple of degree >= 2 to the index of its product.
    """

    terms: tuple[tuple[tuple[tuple[int, ...], float], ...], ...]
    products: tuple[tuple[tuple[str, int], tuple[str, int]], ...]
    monomials: dict


def acceleration_of(system) -> Acceleration | ExpressionSeries:
    """The acceleration -M^-1 grad V of ``system`` (-grad V without masses), from its formula: as polynomials if it is one,
    else as series nodes (:func:`expression_series`; ConfigError for a term it cannot take)."""
    import sympy  # here, not at the top: only a Taylor module's text needs it, and a warm job skips sympy's import

    from ...systems.formula import parse_potential

    if not system.formula:
        raise ValueError(f"scheme 'taylor': system {system.name!r} has no formula for V; use dop853")
    expression = parse_potential(system.formula, system.coordinates, system.parameters, f"systems.{system.name}")
    symbols = [sympy.Symbol(name, real=True) for name in system.coordinates]
    accelerations = [-sympy.diff(expression, s) for s in symbols]
    if system.mass_matrix is not None:
        # q'' = -M^-1 grad V (ldpipe.engine.kinetic): the series of q' is that of M^-1 p.
        inverse = system.inverse_mass
        accelerations = [
            sum((sympy.Float(float(c), 17) * f for c, f in zip(inverse[i], accelerations) if c != 0.0), sympy.Integer(0))
            for i in range(len(symbols))
        ]
    terms = []
    for acceleration in accelerations:
        try:
            # numeric coefficients first: pi * x or sqrt(2) * x is a polynomial over the reals
            polynomial = sympy.Poly(sympy.N(acceleration, 17), *symbols)
        except sympy.PolynomialError:
            polynomial = None
        if polynomial is None or not polynomial.domain.is_Numerical:
            return expression_series(accelerations, symbols, system.name, system.formula)
        terms.append(tuple((tuple(m), float(c)) for m, c in polynomial.terms() if float(c) != 0.0))

    products: list[tuple[tuple[str, int], tuple[str, int]]] = []
    by_factors: dict[tuple[int, ...], tuple[str, int]] = {}

    def series_of(factors: tuple[int, ...]) -> tuple[str, int]:
        """Operand for the product of the q-series listed in ``factors`` (sorted, with repeats)."""
        if len(factors) == 1:
            return ("q", factors[0])
        if factors not in by_factors:
            products.append((series_of(factors[:-1]), ("q", factors[-1])))
            by_factors[factors] = ("product", len(products) - 1)
        return by_factors[factors]

    monomials = {}
    for component in terms:
        for exponents, _ in component:
            if sum(exponents) >= 2:
                factors = tuple(l for l, e in enumerate(exponents) for _ in range(e))
                monomials[exponents] = series_of(factors)[1]
    return Acceleration(tuple(terms), tuple(products), monomials)


# --- potentials that are not polynomials: auxiliary series ------------------------------------------
# Functions the series recurrences take (see ExpressionSeries); others a formula may call are
# first rewritten in these (rewrites()), and what remains is refused naming the term.
def rewrites() -> dict:
    """Each function without a recurrence of its own, mapped to its rewriting in those with one."""
    import sympy

    return {
        sympy.tan: lambda f: sympy.sin(f) / sympy.cos(f),
        sympy.sinh: lambda f: (sympy.exp(f) - sympy.exp(-f)) / 2,
        sympy.cosh: lambda f: (sympy.exp(f) + sympy.exp(-f)) / 2,
        sympy.tanh: lambda f: (sympy.exp(f) - sympy.exp(-f)) / (sympy.exp(f) + sympy.exp(-f)),
    }


@dataclass(frozen=True)
class ExpressionSeries:
    """The acceleration -grad V as a list of series nodes, each computed degree by degree.

    ``nodes[r]`` is (kind, operands, data) for the auxiliary series r, stored like a product
    of :class:`Acceleration`; operands are ("q", l), ("aux", r') with r' < r, or
    ("const", value). Kinds and their k-th coefficient u_k (Jorba & Zou 2005, section 3;
    f, g the operands' series, u_0 the function's value at f_0):

    - ``sum``: sum of the operands (constants at k = 0); ``scale``: data * f_k;
    - ``product``: the Cauchy product sum_{j=0..k} f_j g_{k-j} (half of it for a square);
    - ``exp`` (u' = f' u): u_k = (1/k) sum_{j=1..k} j f_j u_{k-j};
    - ``log`` (f u' = f'): u_k = (f_k - (1/k) sum_{j=1..k-1} j u_j f_{k-j}) / f_0;
    - ``sin``/``cos``, a pair (s' = c f', c' = -s f'): s_k = (1/k) sum j f_j c_{k-j},
      c_k = -(1/k) sum j f_j s_{k-j}; ``data`` of each is the other's index;
    - ``power`` f^data, data not a natural number (f u' = data f' u):
      u_k = (1/(k f_0)) sum_{j=0..k-1} (data (k-j) - j) f_{k-j} u_j; data = 1/2 is sqrt.

    ``components[i]`` is the operand holding a_i.
    """

    nodes: tuple
    components: tuple


def expression_series(expressions, symbols, name: str, formula: str) -> ExpressionSeries:
    """The series nodes of ``expressions`` (the acceleration's components) in ``symbols``.

    Equal subexpressions share one node (a memo keyed by the sympy expression), so a
    common factor such as exp(-a x) is one auxiliary series. ConfigError names the system and
    the term if a function has no recurrence here (Abs, sign, a special function).
    """
    import sympy

    index = {symbol: l for l, symbol in enumerate(symbols)}
    nodes: list = []
    memo: dict = {}

    def add(kind, operands, data=None):
        nodes.append((kind, tuple(operands), data))
        return ("aux", len(nodes) - 1)

    def refuse(term):
        raise ConfigError(
            f"scheme 'taylor': system {name!r}, V = {formula}: the term {term} of the acceleration has no "
            "Taylor recurrence here (the scheme takes + - * /, powers, exp, log, sin, cos, sqrt; use dop853)"
        )

    def natural_power(base, exponent: int):
        if exponent == 1:
            return base
        half = natural_power(base, exponent // 2)
        key, square_key = ("power", base, exponent), ("power", base, exponent // 2 * 2)
        if square_key not in memo:
            memo[square_key] = add("product", (half, half))
        if key not in memo:
            memo[key] = add("product", (memo[square_key], base))
        return memo[key]

    def product(operands):
        result = operands[0]
        for operand in operands[1:]:
            key = ("product", result, operand)
            if key not in memo:
                memo[key] = add("product", (result, operand))
            result = memo[key]
        return result

    def build(expression):
        if expression in memo:
            return memo[expression]
        if expression.is_Number:
            result = ("const", float(expression))
        elif expression in index:
            result = ("q", index[expression])
        elif not expression.free_symbols:
            value = sympy.N(expression, 17)
            if not value.is_real or not value.is_Number:
                refuse(expression)
            result = ("const", float(value))
        elif expression.is_Add:
            operands = [build(arg) for arg in expression.args]
            constant = sum(value for kind, value in operands if kind == "const")
            series = [operand for operand in operands if operand[0] != "const"]
            result = add("sum", series + ([("const", constant)] if constant else []))
        elif expression.is_Mul:
            operands = [build(arg) for arg in expression.args]
            constant = math.prod(value for kind, value in operands if kind == "const")
            series = product([operand for operand in operands if operand[0] != "const"])
            result = series if constant == 1.0 else add("scale", (series,), constant)
        elif expression.is_Pow:
            base, exponent = expression.args
            if exponent.free_symbols:  # f^g = exp(g log f)
                return build(sympy.exp(exponent * sympy.log(base)))
            exponent = float(exponent)
            if exponent.is_integer() and exponent >= 1:
                result = natural_power(build(base), int(exponent))
            else:
                result = add("power", (build(base),), exponent)
        elif isinstance(expression, sympy.exp):
            result = add("exp", (build(expression.args[0]),))
        elif isinstance(expression, sympy.log):
            result = add("log", (build(expression.args[0]),))
        elif isinstance(expression, (sympy.sin, sympy.cos)):
            argument = build(expression.args[0])
            sine = add("sin", (argument,), len(nodes) + 1)
            cosine = add("cos", (argument,), len(nodes) - 1)
            memo[sympy.sin(expression.args[0])], memo[sympy.cos(expression.args[0])] = sine, cosine
            return memo[expression]
        else:
            refuse(expression)
        memo[expression] = result
        return result

    components = []
    for expression in expressions:
        for function, rewrite in rewrites().items():
            expression = expression.replace(function, rewrite)
        components.append(build(expression))
    return ExpressionSeries(tuple(nodes), tuple(components))


def series_rows(n: int, order: int, n_products: int) -> int:
    """Workspace rows of the series: q to degree order + 1, each product to degree order - 1."""
    return (order + 2) * n + order * n_products


def taylor_source(L, acceleration: Acceleration, order: int) -> str:
    """Source of ``attempt`` and ``qpoly`` of the Taylor scheme of ``order`` for layout L.

    Series coefficients live in the workspace region OTS: q_{k,i} in row k n + i, the k-th
    coefficient of product r in row (order + 2) n + k n_products + r. One loop over the lanes
    per degree k, with the Cauchy sums written out (the order is a compile-time constant), so
    each loop vectorizes across lanes.
    """
    n, B, m = L.n, L.lanes, order
    NB = n * B
    general = isinstance(acceleration, ExpressionSeries)
    n_products = len(acceleration.nodes if general else acceleration.products)
    base_products = L.OTS + (m + 2) * NB

    def q(k: int, i: int) -> str:
        return f"W[{L.OTS + (k * n + i) * B} + j]"

    def product(r: int, k: int) -> str:
        return f"W[{base_products + (k * n_products + r) * B} + j]"

    def operand(ref: tuple[str, int], k: int) -> str:
        kind, index = ref
        if kind == "const":  # of an ExpressionSeries node: its value at k = 0, then 0
            return repr(index) if k == 0 else ""
        return q(k, index) if kind == "q" else product(index, k)

    def cauchy(left, right, k: int) -> str:
        if left == right:  # a square: each cross term twice
            pairs = [f"{operand(left, l)} * {operand(left, k - l)}" for l in range((k + 1) // 2)]
            total = f"2.0 * ({' + '.join(pairs)})" if pairs else ""
            middle = f"{operand(left, k // 2)} * {operand(left, k // 2)}" if k % 2 == 0 else ""
            return " + ".join(t for t in (total, middle) if t)
        return " + ".join(f"{operand(left, l)} * {operand(right, k - l)}" for l in range(k + 1))

    def weighted(weights, left, right, k: int) -> str:
        """sum over (j, weight) in weights of weight * left_j * right_{k-j}, zero weights left out."""
        terms = []
        for j, weight in weights:
            if weight == 0.0:
                continue
            factor = "" if weight == 1.0 else f"{weight!r} * "
            terms.append(f"{factor}{operand(left, j)} * {operand(right, k - j)}")
        return " + ".join(terms) or "0.0"

    def node_source(node, r: int, k: int) -> str:
        """The k-th coefficient of ExpressionSeries node r (recurrences in its docstring)."""
        kind, operands, data = node
        own = ("aux", r)
        f = operands[0]
        if kind == "sum":
            return " + ".join(t for t in (operand(o, k) for o in operands) if t) or "0.0"
        if kind == "scale":
            return f"{data!r} * {operand(f, k)}"
        if kind == "product":
            return cauchy(operands[0], operands[1], k)
        if k == 0:
            if kind == "power":
                if data == 0.5:
                    return f"math.sqrt({operand(f, 0)})"
                return f"1.0 / {operand(f, 0)}" if data == -1.0 else f"{operand(f, 0)} ** {data!r}"
            return f"math.{kind}({operand(f, 0)})"
        ones = range(1, k + 1)
        if kind == "exp":
            return f"({weighted([(j, float(j)) for j in ones], f, own, k)}) / {float(k)!r}"
        if kind in ("sin", "cos"):
            sign = "" if kind == "sin" else "-"
            return f"{sign}({weighted([(j, float(j)) for j in ones], f, ('aux', data), k)}) / {float(k)!r}"
        if kind == "log":
            inner = weighted([(j, float(j)) for j in range(1, k)], own, f, k)
            return f"({operand(f, k)} - ({inner}) / {float(k)!r}) / {operand(f, 0)}"
        # power: f^data
        weights = [(j, data * (k - j) - j) for j in range(k)]
        return f"({weighted(weights, own, f, k)}) / ({float(k)!r} * {operand(f, 0)})"

    lines = [
        *lane_loops("attempt(W, rtol, atol)", n, B),
        f"        W[{L.OTS} + i * {B} + j] = W[{L.OQ} + i * {B} + j]",
        f"        W[{L.OTS + NB} + i * {B} + j] = W[{L.OP} + i * {B} + j]",
    ]
    for k in range(m):  # a^[k] from q_0..q_k, then q_{k+2}
        lines.append(f"    for j in range({B}):")
        if general:
            lines += [f"        {product(r, k)} = {node_source(node, r, k)}" for r, node in enumerate(acceleration.nodes)]
            for i, component in enumerate(acceleration.components):
                value = operand(component, k) or "0.0"
                lines.append(f"        {q(k + 2, i)} = ({value}) * {1.0 / ((k + 1) * (k + 2))!r}")
            continue
        for r, (left, right) in enumerate(acceleration.products):
            lines.append(f"        {product(r, k)} = {cauchy(left, right, k)}")
        for i, component in enumerate(acceleration.terms):
            parts = []
            for exponents, coefficient in component:
                degree = sum(exponents)
                if degree == 0:
                    if k == 0:
                        parts.append(repr(coefficient))
                elif degree == 1:
                    parts.append(f"{coefficient!r} * {q(k, exponents.index(1))}")
                else:
                    parts.append(f"{coefficient!r} * {product(acceleration.monomials[exponents], k)}")
            value = " + ".join(parts) if parts else "0.0"
            lines.append(f"        {q(k + 2, i)} = ({value}) * {1.0 / ((k + 1) * (k + 2))!r}")

    # Step size (Jorba & Zou, see the module docstring), in the lanes' own direction.
    lines += [
        f"    for j in range({B}):",
        "        rho_last = 0.0",
        "        rho_before = 0.0",
    ]
    for i in range(n):
        lines += [  # reciprocals of the error scales: two divisions per component instead of four
            f"        iq = 1.0 / (atol + rtol * abs(W[{L.OQ + i * B} + j]))",
            f"        ip = 1.0 / (atol + rtol * abs(W[{L.OP + i * B} + j]))",
            f"        rho_last = max(rho_last, abs({q(m, i)}) * iq, {float(m + 1)!r} * abs({q(m + 1, i)}) * ip)",
            f"        rho_before = max(rho_before, abs({q(m - 1, i)}) * iq, {float(m)!r} * abs({q(m, i)}) * ip)",
        ]
    lines += [
        f"        W[{L.OERR} + j] = 0.0",
        f"        requested = W[{L.OH} + j]",
        # both bounds by inverse_root (templates/roots.py): no pow, so the lane loop vectorizes;
        # a bound that does not bind changes nothing
        f"        last = {SAFETY!r} * inverse_root(rho_last, {1.0 / m!r})",
        f"        before = {SAFETY!r} * inverse_root(rho_before, {1.0 / (m - 1)!r})",
        "        limit = abs(requested)",
        "        limit = min(limit, last) if rho_last > 0.0 else limit",
        "        limit = min(limit, before) if rho_before > 0.0 else limit",
        f"        W[{L.OH} + j] = math.copysign(limit, requested)",
    ]

    # The step's end by Horner, and the velocity polynomials in x = t / h: VC of q_i is
    # p_i(t) = sum_k (k+1) q_{k+1} t^k, VC of p_i is a_i(t) = sum_k (k+1)(k+2) q_{k+2} t^k.
    CS = 2 * NB
    lines += [
        f"    for i in range({n}):",
        f"      for j in range({B}):",
        f"        h = W[{L.OH} + j]",
    ]
    qk = lambda k: f"W[{L.OTS + k * NB} + i * {B} + j]"  # noqa: E731  (row k n + i)
    horner_q = qk(m + 1)
    for k in range(m, -1, -1):
        horner_q = f"({horner_q}) * h + {qk(k)}"
    horner_p = f"{float(m + 1)!r} * {qk(m + 1)}"
    for k in range(m - 1, -1, -1):
        horner_p = f"({horner_p}) * h + {float(k + 1)!r} * {qk(k + 1)}"
    lines += [
        f"        W[{L.OQN} + i * {B} + j] = {horner_q}",
        f"        W[{L.OPN} + i * {B} + j] = {horner_p}",
        f"        vq = {L.OVC} + i * {B} + j",
        f"        vp = {L.OVC + NB} + i * {B} + j",
        "        hk = 1.0",
    ]
    for k in range(L.nc):
        velocity = f"{float(k + 1)!r} * {qk(k + 1)} * hk" if k <= m else "0.0"
        force = f"{float((k + 1) * (k + 2))!r} * {qk(k + 2)} * hk" if k <= m - 1 else "0.0"
        lines += [f"        W[vq + {k * CS}] = {velocity}", f"        W[vp + {k * CS}] = {force}"]
        if k < m:
            lines.append("        hk *= h")
    lines.append(
        f"    acceleration_block(W[{L.OQN}:{L.OQN + NB}].reshape(({n}, {B})), "
        f"W[{L.OAN}:{L.OAN + NB}].reshape(({n}, {B})), {B})"
    )
    # qpoly: q(x) = sum_k q_k h^k x^k
    lines += [
        "",
        "",
        *lane_loops("qpoly(W)", n, B),
        f"        h = W[{L.OH} + j]",
        "        hk = 1.0",
    ]
    for k in range(m + 2):
        lines.append(f"        W[{L.OQC + k * NB} + i * {B} + j] = {qk(k)} * hk")
        if k < m + 1:
            lines.append("        hk *= h")
    return "\n".join(lines) + "\n"


@dataclass(frozen=True)
class Taylor(AdaptiveScheme):
    """Taylor series of an order chosen from the tolerance, Jorba–Zou steps; potentials given by a formula."""

    def order_for(self, settings) -> int:
        """``settings.taylor_order``, or the default picked from the tolerance and the integrand."""
        if settings.taylor_order is not None:
            return settings.taylor_order
        order = jorba_zou_order(min(settings.rtol, settings.atol))
        if is_arclength(settings.p):
            # Five orders above Jorba & Zou's: an engine step's fixed work (the quadrature over
            # the step, the lanes' bookkeeping) outweighs the series' ~m^2 terms, so longer steps
            # pay until the step's Gauss rule limits the accuracy. Measured (400 points of the
            # benchmark section against dop853 at rtol 1e-14, 8 nodes): at rtol 1e-10 order 18
            # ran 82 steps per tau = 50 against 154 at order 13, 1.3-1.5x the throughput, the
            # median error 2.0e-12 against 1.5e-12; at 1e-12 order 20 (89 steps) against 15
            # (157), 1.2-1.5x, median 3.4e-14 against 2.7e-14. Order 24 lost accuracy.
            order += 5
        else:
            # |v|^p: two orders below, for shorter steps. A velocity component that nearly
            # touches zero inside a step makes |v|^p vary on the scale sqrt(|v_min| / |v''|),
            # which Gauss–Legendre resolves only on steps a few times that long. Measured (1000
            # points of the benchmark section, p = 1/2, against dop853 at rtol 1e-14): at rtol
            # 1e-12 the worst error was 2e-9 at order 15 and 4e-12 at order 13; at 1e-10, 5e-9
            # at order 13 and 1.3e-10 at order 11; the medians did not change.
            order -= 2
        return max(MIN_ORDER, min(MAX_ORDER, order))

    def nodes(self, settings) -> int:
        """8 for the arc length; 12 for |v|^p at rtol >= 1e-9, 16 below.

        Its steps are 2-5x longer than dop853's at the same tolerance. Measured (400 points of
        the benchmark section, against dop853 at rtol 1e-14): the arc length at its default
        orders needs 8 nodes (6 raised the median error 60x at rtol 1e-12, order 20); |v|^p
        needs 12 (8 raised the worst error 15x at rtol 1e-8) and 16 below 1e-9.
        """
        if is_arclength(settings.p):
            return 8
        return 12 if settings.rtol >= 1e-9 else 16

    def lanes(self, settings) -> int:
        """32 for the arc length (its series workspace and polynomials of 64 lanes outgrow a 48 KB L1
        cache), else 64. Measured (1/3 of the 300^2 benchmark grid, one thread, per CPU second, 32 and
        64 alternating): 32 lanes 1.09x at rtol 1e-8, 1.05x at 1e-10, 1.07-1.08x at 1e-12;
        16 slower than 32; the same LDs to the bit. |v|^p keeps 64 (not measured)."""
        return 32 if is_arclength(settings.p) else 64

    def check_system(self, system) -> None:
        """The potential must be a formula whose acceleration has series recurrences (see :func:`acceleration_of`)."""
        acceleration_of(system)

    def source(self, system, lanes: int, order: int | None = None) -> SchemeSource:
        if order is None:
            raise ValueError("scheme 'taylor': the order must be given")
        acceleration = acceleration_of(system)
        auxiliary = acceleration.nodes if isinstance(acceleration, ExpressionSeries) else acceleration.products
        rows = series_rows(system.n_dof, order, len(auxiliary))
        layout = Layout.build(system.n_dof, lanes, order + 2, 0, series=rows)
        return SchemeSource(
            layout, True, order, templates=("roots",), source=taylor_source(layout, acceleration, order), self_sized=True
        )


TAYLOR = Taylor(
    name="taylor",
    description=(
        "Taylor series, order from the tolerance (rtol, atol; potentials given by a formula; "
        "the faster one at rtol 1e-8 and tighter)"
    ),
    order=None,
    ladder=(1e-6, 1e-8, 1e-10, 1e-12),
)
