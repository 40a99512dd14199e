"""The configuration fuzzed one key at a time: every key of config.yaml (with config.quick.yaml
over it) and every key the schema allows beside them, given a wrong type, a non-finite number,
zero, a negative or huge value, a reversed or empty range, removed, or an unknown key added.
Validation ends valid or with a ConfigError naming the key (``ldpipe.testing.fuzz``)."""

from __future__ import annotations

import pytest
import yaml
from hypothesis import given, settings, strategies as st

from ldpipe.config import validate_config
from ldpipe.config.loading import load_schema
from ldpipe.errors import ConfigError
from ldpipe.testing import fuzz

from support.workflow import ROOT

BASE = validate_config(fuzz.merged(yaml.safe_load((ROOT / "config.yaml").read_text()),
                                   yaml.safe_load((ROOT / "config.quick.yaml").read_text())))
SITES = fuzz.config_sites(BASE, load_schema())


def test_the_sites_reach_every_section_and_keys_the_configuration_leaves_out():
    sections = {path[0] for path in SITES}
    assert set(BASE) <= sections
    dotted = {fuzz.dotted(path) for path in SITES}
    # a key that config.yaml leaves out, found through the schema
    assert "ld_maps.fig3_dE0.000.t0" in dotted
    assert "ld_maps.fig3_dE0.000.section.axes.0.range.1" in dotted


@settings(max_examples=150, deadline=None, derandomize=True)
@given(site=st.sampled_from(SITES), mutation=st.sampled_from(list(fuzz.MUTATIONS)))
def test_a_mutated_key_validates_or_is_refused_by_name(site, mutation):
    fuzz.check_config_case(BASE, site, mutation, validate_config)


def test_every_mutation_of_a_map_key_is_refused_naming_it():
    # tau must be a positive finite number: every wrong value is refused, by name
    def outcome(path, mutation):
        return fuzz.check_config_case(BASE, ("ld_maps", "fig3_dE0.000", *path), mutation, validate_config)

    for mutation in ("string", "null", "bool", "list", "nan", "inf", "zero", "negative"):
        assert outcome(("tau",), mutation) == "refused", mutation
    assert outcome(("section", "axes", 0, "range"), "reversed") == "refused"
    assert outcome(("section", "axes", 0, "range"), "empty_range") == "refused"
    assert outcome(("system",), "missing") == "refused"
    assert outcome((), "unknown_key") == "refused"


def test_a_message_that_does_not_name_the_key_fails_the_check():
    assert fuzz.names_the_key("config key 'ld_maps.m.tau': expected a number", ("ld_maps", "m", "tau"))
    assert not fuzz.names_the_key("expected a number", ("ld_maps", "m", "tau"))


@pytest.mark.parametrize("variable", ["path", "u", "v", "w", "time", "mask"])
def test_an_empty_variable_name_of_velocity_data_is_refused_by_its_key(variable):
    # w: "" made the data 3-D, refused only by a map's FTLE check that named neither the system nor w
    path = ("systems", "example_currents", "velocity_data", variable)
    with pytest.raises(ConfigError, match=rf"config key '{'.'.join(path)}': '' should be non-empty"):
        validate_config(fuzz.mutate(BASE, path, "empty_string"))


@pytest.mark.parametrize("family", ["", "no_such_family"])
@pytest.mark.parametrize("with_normal_form", [True, False])
def test_a_transport_study_of_a_family_not_declared_is_refused_by_its_key(family, with_normal_form):
    # validation took any name here: with a normal-form study comparing with it, a KeyError; without,
    # a valid configuration whose transport job had no family file to read
    config = fuzz.plain(BASE)
    config["transport"]["barbanis_2dof_bottom"]["orbits"] = family
    if not with_normal_form:
        del config["normal_form"]
    with pytest.raises(ConfigError, match=rf"^config key 'transport.barbanis_2dof_bottom.orbits': no family "
                                          rf"'{family}'; expected one of \['barbanis_2dof_bottom', "):
        validate_config(config)


def test_a_reference_to_a_section_left_out_names_the_section():
    # without periodic_orbits: "config key 'manifolds.X.orbits': no family 'Y'; expected one of []"
    assert fuzz.check_config_case(BASE, ("periodic_orbits",), "missing", validate_config) == "refused"
    with pytest.raises(ConfigError, match=r"no family '\w+'; expected one of \[\] \(the entries under "
                                          r"'periodic_orbits'\)"):
        validate_config(fuzz.mutate(BASE, ("periodic_orbits",), "missing"))
