"""The scheme and integrand registries, and the one home of every integrator default.

The config schema is a static file and the CLI states its defaults in its own code; both must
agree with the registry (ldpipe.engine.schemes.SCHEMES) and the settings records
(ldpipe.engine.settings). Expected values here are the registry's and the records' own: these
tests check that one home is read (or mirrored) everywhere, not numbers.
"""

import dataclasses
import math

import numpy as np
import pytest

from ldpipe.cli.main import build_parser
from ldpipe.config import load_schema
from ldpipe.engine import (
    DEFAULT_ESCAPE_RADIUS, SCHEMES, DescriptorSettings, IntegratorSettings, LDSettings, StoppingRules, compute_ld,
)
from ldpipe.engine import api, integrands
from ldpipe.engine.codegen import engine_source
from ldpipe.engine.schemes.taylor import MAX_ORDER, MIN_ORDER
from ldpipe.core.trajectories import FlowSettings


@pytest.fixture(scope="module")
def schema():
    return load_schema()


def _ld_map(schema):
    return schema["$defs"]["ld_map"]["properties"]


def test_schema_scheme_enums_are_the_registry(schema):
    integrator = _ld_map(schema)["integrator"]["properties"]
    assert integrator["scheme"]["enum"] == list(SCHEMES)
    assert schema["$defs"]["integrator_setting"]["properties"]["scheme"]["enum"] == list(SCHEMES)
    for name in SCHEMES:  # the schema's help text names every scheme
        assert name in integrator["scheme"]["description"], name


def test_schema_integrator_block_mirrors_integrator_settings(schema):
    block = _ld_map(schema)["integrator"]["properties"]
    defaults = IntegratorSettings()
    assert set(block) == {f.name for f in dataclasses.fields(IntegratorSettings)}
    for name, spec in block.items():
        assert spec["default"] == getattr(defaults, name), name
    assert (block["taylor_order"]["minimum"], block["taylor_order"]["maximum"]) == (MIN_ORDER, MAX_ORDER)
    # The config's block, defaults filled in by the schema, gives the default settings.
    assert IntegratorSettings.from_config({name: spec["default"] for name, spec in block.items()}) == defaults


def test_schema_descriptor_and_stopping_defaults(schema):
    ld_map = _ld_map(schema)
    assert ld_map["p"]["default"] == DescriptorSettings().p
    assert {"const": integrands.ARCLENGTH} in ld_map["p"]["anyOf"]
    assert ld_map["tau"]["default"] == StoppingRules().tau


def test_escape_radius_default_is_stated_once(schema):
    assert IntegratorSettings().escape_radius == DEFAULT_ESCAPE_RADIUS
    assert FlowSettings().escape_radius == DEFAULT_ESCAPE_RADIUS
    assert schema["$defs"]["flow_integrator"]["properties"]["escape_radius"]["default"] == DEFAULT_ESCAPE_RADIUS


def test_schema_accuracy_ladder_is_the_registry(schema):
    ladder = schema["$defs"]["accuracy_cost"]["properties"]["ld"]["properties"]["ladder"]
    assert list(ladder["properties"]) == list(SCHEMES)
    for name, record in SCHEMES.items():
        entry = ladder["properties"][name]
        assert entry["required"] == [record.parameters[0]], name
        assert set(entry["properties"]) <= set(record.parameters), name
    assert ladder["default"] == {name: {r.parameters[0]: list(r.ladder)} for name, r in SCHEMES.items()}


def test_cli_defaults_are_the_settings_defaults():
    args = build_parser().parse_args(["ld", "-o", "out.nc"])
    integrator = IntegratorSettings()
    assert (args.scheme, args.rtol, args.atol, args.dt, args.taylor_order) == (
        integrator.scheme, integrator.rtol, integrator.atol, integrator.dt, integrator.taylor_order)
    assert float(args.p) == DescriptorSettings().p and args.tau == StoppingRules().tau


def test_ld_settings_default_to_the_parts():
    flat = LDSettings()
    assert flat == LDSettings.from_parts(IntegratorSettings(), DescriptorSettings(), StoppingRules())
    assert (flat.integrator, flat.descriptor, flat.stopping) == (IntegratorSettings(), DescriptorSettings(), StoppingRules())
    assert flat.rtol == flat.atol == 1e-8  # the config's and the CLI's default since the registry


def test_ladder_setting_names_only_the_numbers_its_scheme_uses():
    for name, record in SCHEMES.items():
        spec = {"scheme": name, **{p: 0.01 for p in record.parameters}}
        setting = IntegratorSettings.from_spec(spec)
        assert setting.adaptive == record.adaptive
        assert {k for k, v in setting.numbers().items() if v} == set(record.parameters)
        other = "dt" if record.adaptive else "rtol"
        with pytest.raises(ValueError, match=name):
            IntegratorSettings.from_spec({**spec, other: 0.01})


def test_integrand_registry():
    assert len({r.kind for r in integrands.INTEGRANDS.values()}) == len(integrands.INTEGRANDS)
    assert api._kind(0.5) == (integrands.INTEGRANDS["half"].kind, 0.5)
    assert api._kind(1.0) == (integrands.INTEGRANDS["one"].kind, 1.0)
    assert api._kind(0.3) == (integrands.INTEGRANDS["power"].kind, 0.3)
    assert api._kind("arclength") == (integrands.INTEGRANDS["arclength"].kind, 1.0)
    assert integrands.caption("arclength") == "arc length" and integrands.caption(0.25) == "p = 0.25"
    with pytest.raises(ValueError, match="p"):
        integrands.check_p(1.5)


class SharedModuleRK4(type(SCHEMES["rk4"])):
    """rk4's record under another name whose engine module is rk4's, as sym4 and sym6 share theirs."""

    def variant(self, order: int | None = None) -> str:
        return "rk4"


def test_a_registered_toy_scheme_is_accepted_and_runs(barbanis, monkeypatch):
    # A record under a new name over rk4's builder: the registry alone makes it known to the
    # settings and the code generator. Invariant: the same builder generates the same
    # arithmetic, so the generated text is rk4's and the LD equals rk4's bit for bit. Its record
    # names rk4's variant, so the copy runs rk4's module, which other tests compile too: the
    # registry's path (settings, the generator reading the record) is what this test runs, not a
    # second compile of the same text. monkeypatch restores the registry.
    with pytest.raises(ValueError, match="unknown scheme"):
        LDSettings(scheme="rk4_copy")
    toy_record = SharedModuleRK4(**{**dataclasses.asdict(SCHEMES["rk4"]), "name": "rk4_copy"})
    monkeypatch.setitem(SCHEMES, "rk4_copy", toy_record)
    settings = LDSettings(scheme="rk4_copy", dt=0.05, tau=2.0)
    assert not settings.adaptive and settings.nodes == LDSettings(scheme="rk4").nodes
    assert engine_source(barbanis, "rk4_copy", 64) == engine_source(barbanis, "rk4", 64)
    states = np.array([[0.5, 0.2, 0.1, 0.8], [1.0, -0.5, 0.3, 0.2]])
    toy = compute_ld(barbanis, states, +1, settings)
    rk4 = compute_ld(barbanis, states, +1, dataclasses.replace(settings, scheme="rk4"))
    for name in toy._fields:
        np.testing.assert_array_equal(getattr(toy, name), getattr(rk4, name), err_msg=name)


def _numbers_named(node, name, where=""):
    """Every schema property ``name`` of type number, with where it is."""
    if isinstance(node, dict):
        for key, value in node.items():
            if key == name and isinstance(value, dict) and value.get("type") == "number":
                yield f"{where}.{key}", value
            yield from _numbers_named(value, name, f"{where}.{key}")
    elif isinstance(node, list):
        for index, value in enumerate(node):
            yield from _numbers_named(value, name, f"{where}.{index}")


#: The rtol minimum above the floor on purpose: the accuracy ladder's periodic-orbit settings
#: (scipy's DOP853, whose own floor is 100 eps = 2.2e-14).
RTOL_MINIMUM_ABOVE_THE_FLOOR = 1.0e-13


def test_schema_tolerance_minimums_are_the_settings_floors(schema):
    from ldpipe.engine.settings import ATOL_FLOOR, RTOL_FLOOR

    rtols = dict(_numbers_named(schema, "rtol"))
    atols = dict(_numbers_named(schema, "atol"))
    assert len(rtols) >= 5 and len(atols) >= 4
    wrong = {where: spec.get("minimum") for where, spec in rtols.items()
             if spec.get("minimum") not in (RTOL_FLOOR, RTOL_MINIMUM_ABOVE_THE_FLOOR)}
    assert not wrong, f"rtol minimums other than RTOL_FLOOR ({RTOL_FLOOR}): {wrong}"
    assert [w for w, s in rtols.items() if s["minimum"] == RTOL_FLOOR] != []
    wrong = {where: spec.get("minimum") for where, spec in atols.items() if spec.get("minimum") != ATOL_FLOOR}
    assert not wrong, f"atol minimums other than ATOL_FLOOR ({ATOL_FLOOR}): {wrong}"
    assert schema["$defs"]["tolerance_list"]["items"]["minimum"] == RTOL_FLOOR  # rtol and atol lists of a ladder


def test_the_cli_refuses_an_rtol_just_below_the_floor_naming_it(tmp_path, capsys):
    from ldpipe.cli.main import main
    from ldpipe.engine.settings import RTOL_FLOOR

    arguments = ["ld", "--system", "barbanis_2dof", "--axis", "x=4.8:6.0:3", "--axis", "px=-0.6:0.6:3",
                 "--fixed", "y=-7.0", "--solve", "py", "--excess-energy", "0.125", "--quiet", "-o",
                 str(tmp_path / "m.nc")]
    assert main([*arguments, "--rtol", repr(math.nextafter(RTOL_FLOOR, 0.0))]) == 2
    error = capsys.readouterr().err
    assert "config key 'ld_maps.cli.integrator.rtol'" in error and ">= 1e-15" in error and "Traceback" not in error, error
