"""The registry of system kinds against the config schema, its messages, and the protocols.

The config schema is a static file: its ``system`` entry is a ``oneOf`` of one branch per kind
(the kind's key required, with what else it needs; the other kinds' keys refused). These tests
check that the registry (ldpipe.systems.kinds.SYSTEM_KINDS) and the schema say the same, that
every message listing kinds lists the registry's, and that each registered class offers every
attribute its protocol states (so code reads them without a getattr default).
"""

import dataclasses

import pytest

from ldpipe.config import load_schema, validate_config
from ldpipe.errors import ConfigError
from ldpipe.systems import (
    SYSTEM_CLASSES, SYSTEM_KINDS, DataFlowModel, FlowModel, HamiltonianModel, MapModel, SystemModel, make_system,
    on_sphere,
    require_hamiltonian, system_coordinates, system_data_files, system_kind, system_phase_coordinates,
)
from ldpipe.systems.model import protocol_members


@pytest.fixture(scope="module")
def branches():
    """The schema's branches of a system entry: kind key -> (required keys, refused keys)."""
    system = load_schema()["$defs"]["system"]
    found = {}
    for branch in system["oneOf"]:
        refused = [key for alternative in branch["not"]["anyOf"] for key in alternative["required"]]
        found[branch["required"][0]] = (tuple(branch["required"]), sorted(refused))
    return found


def test_schema_branches_are_the_registry(branches):
    assert list(branches) == list(SYSTEM_KINDS)
    for key, kind in SYSTEM_KINDS.items():
        required, refused = branches[key]
        assert kind.key == key
        assert required == kind.required, key
        assert refused == sorted([other for other in SYSTEM_KINDS if other != key] + list(kind.excluded)), key


def test_every_kind_is_a_property_the_schema_describes():
    properties = load_schema()["$defs"]["system"]["properties"]
    for key, kind in SYSTEM_KINDS.items():
        assert key in properties, key
        for extra in kind.required + kind.excluded:
            assert extra in properties, (key, extra)


@pytest.mark.parametrize("spec", [{}, {"builtin": "barbanis_2dof", "velocity_data": {"path": "x.nc"}},
                                  {"coordinates": ["x"], "parameters": {}}])
def test_an_entry_of_no_kind_or_two_is_refused_naming_every_kind(spec):
    with pytest.raises(ConfigError) as info:
        system_kind(spec, key="systems.s")
    message = str(info.value)
    assert message.startswith("config key 'systems.s': ")
    for key in SYSTEM_KINDS:
        assert f"'{key}'" in message, message
    with pytest.raises(ConfigError) as info:
        make_system("s", spec)
    assert str(info.value) == message


def test_the_schema_error_of_a_system_names_every_kind_and_what_each_needs():
    with pytest.raises(ConfigError) as info:
        validate_config({"systems": {"s": {"parameters": {}}}})
    message = str(info.value)
    assert "systems.s" in message
    for key, kind in SYSTEM_KINDS.items():
        assert f"'{key}'" in message, message
        for extra in kind.required[1:] + kind.excluded:
            assert f"'{extra}'" in message and kind.noun in message, (key, extra, message)


def test_require_hamiltonian_names_the_hamiltonian_kinds(oscillator):
    flow = make_system("saddle", {"vector_field": {"x": "y", "y": "x"}, "coordinates": ["x", "y"]})
    with pytest.raises(ConfigError) as info:
        require_hamiltonian(flow, "a periodic-orbit family")
    message = str(info.value)
    for key, kind in SYSTEM_KINDS.items():
        assert (f"'{key}'" in message) == kind.hamiltonian, (key, message)
    assert require_hamiltonian(oscillator, "a periodic-orbit family") is None


def _class_members(cls) -> set[str]:
    return {f.name for f in dataclasses.fields(cls)} | {name for name in dir(cls) if not name.startswith("_")}


def test_every_class_offers_its_protocol():
    for key, kind in SYSTEM_KINDS.items():
        family = HamiltonianModel if kind.hamiltonian else MapModel if kind.discrete else FlowModel
        protocols = [SystemModel, family]
        protocols += [DataFlowModel] if kind.stop_flags else []
        for cls in kind.classes:
            for protocol in protocols:
                missing = protocol_members(protocol) - _class_members(cls)
                assert not missing, f"{key}: {cls.__name__} lacks {sorted(missing)} of {protocol.__name__}"
            assert cls.hamiltonian == kind.hamiltonian, (key, cls)
            assert cls.discrete == kind.discrete, (key, cls)
            assert cls.has_stop_flags == kind.stop_flags, (key, cls)
            assert cls in SYSTEM_CLASSES


def test_the_protocol_check_sees_a_missing_member():
    @dataclasses.dataclass
    class Partial:
        name: str
        hamiltonian = True

    missing = protocol_members(SystemModel) - _class_members(Partial)
    assert "coordinates" in missing and "ld_units" in missing and "hamiltonian" not in missing


def test_built_systems_are_their_protocols(barbanis, oscillator):
    flow = make_system("saddle", {"vector_field": {"x": "y", "y": "x"}, "coordinates": ["x", "y"]})
    for system in (barbanis, oscillator):
        assert isinstance(system, SystemModel) and isinstance(system, HamiltonianModel)
    assert isinstance(flow, FlowModel) and not isinstance(flow, HamiltonianModel)
    henon = make_system("henon", {"map": "henon"})
    assert isinstance(henon, MapModel) and not isinstance(henon, (FlowModel, HamiltonianModel))


def test_entry_helpers_ask_the_kind():
    data = {"velocity_data": {"path": "currents.nc", "coordinates": "sphere", "w": "w"}}
    assert system_kind(data).key == "velocity_data"
    assert system_coordinates(data) == system_phase_coordinates(data) == ("lon", "lat", "depth")
    assert on_sphere(data) and system_data_files(data) == ["currents.nc"]
    assert "currents.nc" in system_kind(data).caption(data)
    formula = {"formula": "x**2 + y**2", "coordinates": ["x", "y"]}
    assert system_phase_coordinates(formula) == ("x", "y", "px", "py")
    assert not on_sphere(formula) and system_data_files(formula) == []
    assert system_phase_coordinates({"builtin": "barbanis_2dof"}) == ("x", "y", "px", "py")
