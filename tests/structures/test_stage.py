"""The structures stage: a map's ``structures:`` option, its file, and the workflow's rule.

The expected file is the API's (``ldpipe.structures`` on the same map, in memory): the stage must
give it back bit for bit, but for when it was written and the name of its input. The map is the
linear saddle's of tests/structures/test_map_curves.py (the same compiled engine).
"""

import copy

import pytest
import yaml

import ldpipe
from ldpipe.config import load_schema, validate_config
from ldpipe.config.parameters import parameters_from_config
from ldpipe.core.structures.curves import DEFAULTS
from ldpipe.errors import ConfigError
from ldpipe.io.contracts import STRUCTURES
from ldpipe.io.datafile import open_stage_file, stage_parameters
from ldpipe.stages.ld import run_ld_map
from ldpipe.stages.structures import run_structures
from support.stage_files import assert_same_file
from support.workflow import copy_workflow, job_counts, run_snakemake

SYSTEMS = {"linear_saddle": {"vector_field": {"x": "lam*x", "y": "-lam*y"}, "coordinates": ["x", "y"],
                             "parameters": {"lam": 0.8}}}
MAP = {"system": "linear_saddle", "tau": 10.0, "p": 0.5,
       "integrator": {"rtol": 1e-12, "atol": 1e-12, "escape_radius": 1e4},
       "section": {"axes": [{"name": "x", "range": [-0.5, 0.53], "points": 25},
                            {"name": "y", "range": [-0.47, 0.6], "points": 25}]},
       "structures": {"threshold": 0.2}}


def config(**overrides):
    return validate_config({"systems": copy.deepcopy(SYSTEMS), "ld_maps": {"m": {**copy.deepcopy(MAP), **overrides}}})


def test_the_stage_file_is_the_api_result(tmp_path):
    cfg = config()
    ld_file = run_ld_map(output=tmp_path / "m.nc", equilibria=None, show_progress=False,
                         **parameters_from_config(cfg, "ld", "m"))
    parameters = parameters_from_config(cfg, "structures", "m")
    # the schema fills the block's defaults
    assert parameters == {"map_name": "m", "threshold": 0.2, "min_points": 10, "ld_kind": "valley"}
    stored = open_stage_file(run_structures(output=tmp_path / "s.nc", ld_map=ld_file, **parameters), stage=STRUCTURES)
    in_memory = ldpipe.structures(open_stage_file(ld_file, stage="ld_grid"), threshold=0.2)
    assert_same_file(in_memory, stored, inputs=("map",))
    assert stage_parameters(stored)["map"] == str(ld_file)
    assert stored.sizes["curve"] == 2
    # the option steers the workflow only: the map's own parameters do not hold it
    assert "structures" not in parameters_from_config(cfg, "ld", "m")
    assert parameters_from_config(config(structures=True), "structures", "m") == {"map_name": "m"}


def test_the_schema_defaults_are_the_extraction_defaults():
    # one set of defaults: the configuration reference's and the function's
    block = load_schema()["$defs"]["ld_map"]["properties"]["structures"]["oneOf"][1]["properties"]
    assert {key: spec["default"] for key, spec in block.items() if "default" in spec} == \
        {key: value for key, value in DEFAULTS.items() if value is not None}
    assert set(block) == set(DEFAULTS)


def test_a_bad_structures_block_names_its_key():
    with pytest.raises(ConfigError, match=r"ld_maps\.m\.structures\.fields': the map holds no \['ftle_forward'\]"):
        config(structures={"fields": ["ftle_forward"]})
    with pytest.raises(ConfigError, match=r"ld_maps\.m\.structures"):
        config(structures={"threshold": 1.5})
    config(ftle=True, structures={"fields": ["ftle_forward"]})
    with pytest.raises(ConfigError, match=r"structures\.fields': the map holds no \['ld_backward'\]"):
        config(directions="forward", structures={"fields": ["ld_backward"]})
    with pytest.raises(ConfigError, match=r"ld_maps\.m\.structures': the map has a start-time dimension"):
        config(t0=[0.0, 1.0])


@pytest.mark.slow
def test_the_workflow_plans_the_structures_of_a_map_with_the_option(tmp_path):
    # a dry run (a real one costs a map's job and Snakemake's start-up twice): the map with the
    # option gets a structures job after its own
    workdir = copy_workflow(tmp_path / "w")
    (workdir / "user.yaml").write_text(yaml.safe_dump({"systems": SYSTEMS, "ld_maps": {"saddle_structures": MAP}}))
    run = run_snakemake(workdir, "results/structures/saddle_structures.nc", "-n", "--configfile",
                        "config.quick.yaml", "user.yaml")
    assert run.returncode == 0, run.stderr[-3000:]
    assert job_counts(run.stdout) == {"ld_map": 1, "structures": 1}


def test_the_documented_option_validates():
    from support.workflow import documented_yaml

    entry = yaml.safe_load(documented_yaml("structures: {threshold: 0.1"))
    cfg = validate_config({"systems": copy.deepcopy(SYSTEMS), **entry})
    assert parameters_from_config(cfg, "structures", "saddle")["fields"] == ["ld_forward", "ld_backward",
                                                                            "ftle_forward"]
