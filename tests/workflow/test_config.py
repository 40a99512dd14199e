"""Configuration: the shipped files validate, defaults fill in, bad values name their key."""

import pytest
import yaml

from ldpipe.config import load_config, validate_config
from ldpipe.errors import ConfigError
from support.workflow import ROOT


@pytest.mark.parametrize("name", ["config.yaml", "config.quick.yaml"])
def test_shipped_configurations_validate(name):
    config = yaml.safe_load((ROOT / name).read_text())
    if name != "config.yaml":  # Snakemake merges the quick file over the main one
        config = {"systems": {**yaml.safe_load((ROOT / "config.yaml").read_text())["systems"], **config["systems"]}}
    validate_config(config)


def test_the_schema_reads_the_same_with_the_fast_loader():
    # The schema is parsed by libyaml when PyYAML has it (planning reads it on every command); the
    # expected document is PyYAML's pure-Python safe loader's, the reference parser.
    from importlib import resources

    from ldpipe.config import SCHEMA_RESOURCE, load_schema

    text = resources.files(SCHEMA_RESOURCE[0]).joinpath(SCHEMA_RESOURCE[1]).read_text()
    reference = yaml.load(text, Loader=yaml.SafeLoader)
    loaded = load_schema()
    assert loaded == reference
    # == holds 1 == 1.0 == True: the scalars' types must agree too (a default of 1 is not 1.0).
    assert repr(loaded) == repr(reference)


def test_a_schema_changed_by_its_caller_changes_no_other_reader():
    """The schema is parsed once per process; ``load_schema`` gives each caller a copy of its own,
    so a caller that edits it leaves validation (here, a map's default tau of 50) as it was."""
    from ldpipe.config.loading import load_schema, shared_schema

    edited = load_schema()
    edited["$defs"]["ld_map"]["properties"]["tau"]["default"] = 1.0
    edited["$defs"].pop("system")
    assert load_schema() == shared_schema() and "system" in shared_schema()["$defs"]
    config = validate_config({"systems": {"b": {"builtin": "barbanis_2dof"}},
                              "ld_maps": {"m": {"system": "b", "energy": {"excess": 0.1}, "section": {
                                  "axes": [{"name": "y", "range": [-1.0, 1.0], "points": 3},
                                           {"name": "py", "range": [-1.0, 1.0], "points": 3}],
                                  "fixed": {"x": 0.0}, "solve": "px"}}}})
    assert config["ld_maps"]["m"]["tau"] == 50


@pytest.mark.parametrize(("system", "timing"), [
    ({"vector_field": {"x": "y", "y": "-x", "z": "0"}, "coordinates": ["x", "y", "z"]}, {"tau": 1.0}),
    ({"map": "henon"}, {"iterations": 5}),
], ids=["vector field", "discrete map"])
def test_a_grid_over_a_state_is_refused_by_key_alike_for_a_flow_and_a_map(system, timing):
    """A flow's map and a discrete map's both lay their grid over the whole state: two axes, the
    other variables fixed to numbers, each named once, no more tiles than rows."""
    coordinates = system.get("coordinates", ["x", "y"])
    fixed = {name: 0.0 for name in coordinates[2:]}

    def refusal(section=None, **entry):
        section = {"axes": [{"name": "x", "range": [0.0, 1.0], "points": 3},
                            {"name": "y", "range": [0.0, 1.0], "points": 3}], "fixed": fixed, **(section or {})}
        with pytest.raises(ConfigError) as info:
            validate_config({"systems": {"s": system},
                             "ld_maps": {"m": {"system": "s", "section": section, **timing, **entry}}})
        return str(info.value)

    named = refusal({"fixed": {**fixed, "w": 0.0}})
    assert named.startswith(f"config key 'ld_maps.m.section': the two axes and the fixed variables must name each "
                            f"of {coordinates} (the state of system 's') exactly once"), named
    if fixed:
        assert refusal({"fixed": {"z": "saddle"}}).startswith("config key 'ld_maps.m.section.fixed': system 's' has "
                                                             "no saddle")
    assert refusal(tiles=4).startswith("config key 'ld_maps.m.tiles': 4 tiles for 3 rows")


def test_paper_parameters_in_config_yaml():
    config = load_config(ROOT / "config.yaml")
    assert config["systems"]["barbanis_2dof"]["parameters"] == {"omega_x": 1.0, "omega_y": 1.1, "delta": -0.11}
    assert config["systems"]["barbanis_contopoulos_3dof"]["parameters"] == {
        "omega_x2": 0.9, "omega_y2": 1.6, "omega_z2": 0.4, "epsilon": 0.08, "eta": 0.01,
    }


def test_defaults_are_filled():
    config = validate_config({"systems": {"b": {"builtin": "barbanis_2dof"}}})
    settings = config["systems"]["b"]["equilibria"]
    assert settings == {"box": {}, "default_interval": [-20.0, 20.0], "seeds_per_axis": 9, "tolerance": 1e-10}


@pytest.mark.parametrize(
    "system, words",
    [
        ({"builtin": "barbanis_2dof", "equilibria": {"seeds_per_axis": 1}},
         ["systems.b.equilibria.seeds_per_axis", ">= 2"]),
        ({"builtin": "barbanis_2dof", "equilibria": {"tolerance": -1}},
         ["systems.b.equilibria.tolerance", "> 0"]),
        ({"builtin": "barbanis_2dof", "equilibria": {"box": {"x": [1, 0]}}},
         ["systems.b.equilibria.box.x", "low < high"]),
        ({"builtin": "barbanis_2dof", "equilibria": {"box": {"w": [0, 1]}}},
         ["systems.b.equilibria.box.w", "not a coordinate"]),
        ({"builtin": "barbanis_2dof", "parameters": {"delta": "big"}},
         ["systems.b.parameters.delta", "number"]),
        ({"builtin": "barbanis_2dof", "parameters": {"gamma": 1.0}},
         ["systems.b.parameters", "gamma", "omega_x"]),
        ({"builtin": "barbanis_3dof"}, ["systems.b.builtin", "barbanis_contopoulos_3dof"]),
        ({"builtin": "barbanis_2dof", "colour": "red"}, ["systems.b", "unknown keys ['colour']"]),
        ({"formula": "x**2"}, ["systems.b", "exactly one of 'builtin', 'formula', 'vector_field', 'velocity_data' or 'map'",
                               "a formula or a vector field also needs 'coordinates'"]),
    ],
)
def test_bad_values_name_the_key_and_what_is_allowed(system, words):
    with pytest.raises(ConfigError) as info:
        validate_config({"systems": {"b": system}})
    for word in words:
        assert word in str(info.value), str(info.value)


def test_unknown_top_level_key_and_bad_files(tmp_path):
    with pytest.raises(ConfigError, match="unknown keys \\['sistems'\\]"):
        validate_config({"sistems": {}, "systems": {"b": {"builtin": "barbanis_2dof"}}})
    broken = tmp_path / "broken.yaml"
    broken.write_text("systems: [unclosed")
    with pytest.raises(ConfigError, match="broken.yaml: not valid YAML"):
        load_config(broken)
    with pytest.raises(ConfigError, match="missing.yaml: cannot read"):
        load_config(tmp_path / "missing.yaml")
    bad = tmp_path / "bad.yaml"
    bad.write_text("systems:\n  b: {builtin: barbanis_2dof, equilibria: {seeds_per_axis: 100}}\n")
    with pytest.raises(ConfigError, match=r"(?s)bad.yaml: .*systems.b.equilibria.seeds_per_axis.*<= 60"):
        load_config(bad)


def test_a_caption_docutils_cannot_read_is_refused_before_anything_runs():
    # In the report a caption is reStructuredText: "|v|" is a substitution reference that is
    # never defined (docutils: "Undefined substitution referenced"), so the report would show
    # an error box. The config check names the key; the escaped text passes.
    config = yaml.safe_load((ROOT / "config.yaml").read_text())
    config["figures"]["fig1"]["caption"] = "The speed |v| on the section."
    with pytest.raises(ConfigError, match=r"figures\.fig1\.caption.*Undefined substitution"):
        validate_config(config)
    config["figures"]["fig1"]["caption"] = r"The speed \|v\| on the section."
    validate_config(config)


@pytest.mark.parametrize("directive", [".. include:: {path}", ".. raw:: html\n   :file: {path}",
                                       ".. csv-table:: t\n   :file: {path}", ".. raw:: html\n\n   <script>x</script>"])
def test_a_caption_that_reads_a_file_or_pastes_html_is_refused(directive, tmp_path):
    # A caption is text: the report's docutils would read the file into the page. The check reads
    # the caption with file access and raw HTML off, so it neither reads the file nor lets it by.
    secret = tmp_path / "secret.txt"
    secret.write_text("SECRET-CONTENT")
    config = yaml.safe_load((ROOT / "config.yaml").read_text())
    config["figures"]["fig1"]["caption"] = "A caption.\n\n" + directive.format(path=secret)
    with pytest.raises(ConfigError, match=r"figures\.fig1\.caption.*(disabled|deactivated)") as info:
        validate_config(config)
    assert "SECRET-CONTENT" not in str(info.value)


def _schema_text() -> str:
    from importlib import resources

    from ldpipe.config import SCHEMA_RESOURCE

    return resources.files(SCHEMA_RESOURCE[0]).joinpath(SCHEMA_RESOURCE[1]).read_text()


def _parsed_descriptions(text: str) -> dict[int, str]:
    """Every ``description`` of the schema as the YAML parser reads it, by the line its value starts on."""
    found = {}

    def walk(node):
        if isinstance(node, yaml.MappingNode):
            for key, value in node.value:
                if (isinstance(key, yaml.ScalarNode) and key.value == "description"
                        and isinstance(value, yaml.ScalarNode)):
                    found[value.start_mark.line] = value.value
                walk(value)
        elif isinstance(node, yaml.SequenceNode):
            for item in node.value:
                walk(item)

    walk(yaml.compose(text, Loader=yaml.SafeLoader))
    return found


def test_no_schema_description_is_cut_short():
    # An unquoted description in a flow mapping ({type: number, description: A, B}) ends at its
    # first comma (the rest becomes a key of its own): the help and the docs then print half a
    # sentence. Two independent readings must agree: the text after "description:" on its line (a
    # flow mapping's closing brace removed) against the parser's value, which must begin with it
    # (a plain scalar in block style may go on over the next lines); and every description closes
    # each bracket it opens and ends a sentence.
    text = _schema_text()
    parsed = _parsed_descriptions(text)
    assert len(parsed) == text.count("description:")  # every description read, none a key of its own
    for line_number, line in enumerate(text.splitlines()):
        raw = line.partition("description:")[2].strip()
        if not raw or raw[0] in "\"'>|":  # quoted or block scalars cannot be cut by a comma
            continue
        if "{" in line.partition("description:")[0]:  # the flow mappings' closing braces
            raw = raw.rstrip("} ")
        assert parsed[line_number].startswith(raw), (
            f"schema line {line_number + 1}: description {raw!r} reads as {parsed[line_number]!r}: quote it")
    for description in parsed.values():
        text_only = description.strip()
        # "(" and "[" counted together: a half-open interval (0, 1] opens with one and closes with the other
        assert text_only.count("(") + text_only.count("[") == text_only.count(")") + text_only.count("]"), description
        assert text_only.count("{") == text_only.count("}"), description
        assert text_only.endswith((".", ".)", ":", "?")), description
