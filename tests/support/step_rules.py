"""The engine's LD quadrature rules of one step, called directly by the engine's step-rule tests.

``rule_engine`` is the compiled engine module (Barbanis 2 DoF, dop853, 64 lanes) whose template
functions (``special``, ``component_integral``, ``two_roots``, ``one_dip``, the flag checks)
those tests call on polynomials they build; ``rules`` the Gauss–Legendre and folded
Gauss–Jacobi nodes and weights the engine passes them; ``integrand_kind`` the engine's code for
|v|^p.
"""

from __future__ import annotations


def rule_engine():
    from ldpipe.engine.codegen import load_engine
    from ldpipe.systems import make_system

    return load_engine(make_system("barbanis_2dof", {"builtin": "barbanis_2dof"}), "dop853", 64)


def rules(nodes: int, p: float):
    """(glx, glw, gjx, gjf): Gauss–Legendre on [0, 1] and Gauss–Jacobi for the weight x^p, folded."""
    from ldpipe.engine.gauss_rules import folded_jacobi_rule, legendre_rule

    glx, glw = legendre_rule(nodes)
    gjx, gjf = folded_jacobi_rule(nodes, p)
    return glx, glw, gjx, gjf


def integrand_kind(engine, p: float) -> int:
    """The engine's integrand code for |v|^p: its square-root special case, or the general power."""
    return engine.KIND_HALF if p == 0.5 else engine.KIND_POW
