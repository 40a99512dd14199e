"""Engines of one shape share the compiled LD quadrature: its templates live in common modules.

ldpipe.engine.codegen puts the templates that read no system or scheme code into common modules
whose text is only the header constants they read and the templates (the quadrature: the
integrand kinds; the block quadrature and events: the block's sizes and offsets), loaded through
ldpipe.jitcache by the hash of that text. The expected values here are that design itself: two
engines whose common texts are equal load one module (the same module object, the same file),
and an engine with another constant of the block gets another. Loading compiles nothing (numba
compiles on the first call), so these tests are cheap.
"""

import sys
from pathlib import Path

import pytest

from ldpipe.engine.codegen import COMMON_LAYERS, assemble, common_modules, engine_modules, load_engine, load_modules
from ldpipe.engine.vector_field import vector_field_modules
from ldpipe.systems import make_system

HENON_HEILES = {"formula": "(x**2 + y**2)/2 + lam*(x**2*y - y**3/3)", "coordinates": ["x", "y"],
                "parameters": {"lam": 1.0}}
DUFFING = {"vector_field": {"x": "y", "y": "x - x**3 - delta*y + F*cos(omega*t)"}, "coordinates": ["x", "y"],
           "parameters": {"delta": 0.25, "F": 0.3, "omega": 1.2}}


def module_of(function):
    return sys.modules[function.py_func.__module__]


def test_engines_of_one_shape_load_one_common_module(barbanis):
    # Same shape (2 DoF, dop853, 64 lanes): a built-in, a formula system, the same formula with
    # masses (its kinetic section rebinds engine functions only) and the flow driver's module all
    # import the one block-quadrature module, and the LD quadrature is one module for every engine.
    henon_heiles = make_system("henon_heiles", HENON_HEILES)
    massive = make_system("henon_heiles_masses", {**HENON_HEILES, "masses": {"x": 1.0, "y": 2.0}})
    engines = [load_engine(barbanis, "dop853", 64), load_engine(henon_heiles, "dop853", 64),
               load_engine(massive, "dop853", 64), load_engine(barbanis, "dop853", 64, entry="flow_process")]
    assert len({id(engine) for engine in engines}) == len(engines)  # four engine modules
    (block,) = {module_of(engine.first_exit) for engine in engines}
    assert all(engine.special is block.special for engine in engines[:3])
    (quadrature,) = {module_of(engine.component_integral) for engine in engines}
    assert module_of(block.special) is block and quadrature is not block
    assert Path(block.__file__).name == f"{block.__name__}.py"
    assert Path(block.__file__).read_text() == engine_modules(henon_heiles, "dop853", 64).common[1].text
    # The quadrature reads the integrand kinds only: every scheme, block size and the vector
    # field's engine share it; the block quadrature reads the block's constants: another block
    # size, another module.
    duffing = make_system("duffing_shared", DUFFING)
    others = [load_engine(barbanis, "dop853", 32), load_engine(barbanis, "rk4", 64),
              load_modules(vector_field_modules(duffing))]
    assert all(module_of(other.component_integral) is quadrature for other in others)
    assert all(module_of(other.first_exit) is not block for other in others[:2])
    assert module_of(others[0].special) is not module_of(others[1].special)


def test_a_common_module_holds_only_the_constants_its_templates_read(barbanis):
    # Invariant of the text: a constant in a common module's header that its templates do not read
    # would split engines that could share it (the sizes of the state, the scheme's order and
    # workspace size are read by the engine's own templates only).
    quadrature, block = engine_modules(barbanis, "dop853", 64).common
    assert "\nKIND_HALF = 0\nKIND_ONE = 1\n" in quadrature.text and "\nLANES = " not in quadrature.text
    for constant in ("ORDER", "SIZE", "ADAPTIVE", "NB", "OQ", "OP"):
        assert f"\n{constant} = " not in block.text
    assert "\nLANES = 64\n" in block.text and "\nOVC = " in block.text


def test_a_common_template_may_not_read_system_or_scheme_code(barbanis):
    # The driver reads the kernels and the scheme's attempt: it cannot be compiled apart from them.
    constants = {"N": 2, "LANES": 8, "KIND_HALF": 0, "KIND_ONE": 1}
    with pytest.raises(ValueError, match="attempt"):
        common_modules([("common_driver", ("driver",))], constants)


def test_the_engine_may_not_rebind_a_common_name(barbanis):
    # A rebinding in the engine module would not reach the common module's own callers of the name.
    parts = {"N": 2, "LANES": 8, "NCOMP": 4, "NC": 8, "CS": 32, "OH": 0, "OVC": 0, "OFC": 0, "OMIN": 0, "OMAX": 0,
             "OACC": 0, "OPRV": 0, "ORAT": 0, "OCRV": 0, "KIND_HALF": 0, "KIND_ONE": 1, "KIND_ARCLENGTH": 3}
    with pytest.raises(ValueError, match="special"):
        assemble(barbanis, "rebinding", "title", (), parts, [("rebinding", "special = None\n")], COMMON_LAYERS)
