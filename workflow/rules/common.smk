# Helpers shared by the rules: configuration checks, targets, parameters, code dependencies.
import math
import re

try:
    import ldpipe
    from ldpipe.config import validate_config
    from ldpipe.errors import ConfigError
    from ldpipe.io.provenance import code_digest
    from ldpipe.config.parameters import parameters_from_config
    from ldpipe.core.maps.budget import band_memory_mb
    from ldpipe.stages.plan import (accuracy_systems, ladder_engines, ld_map_points, ld_map_tiles, ld_tile_points,
                                    nhim_orbit_inputs,
                                    nhim_sampling_system, nhim_study_inputs)
    from ldpipe.systems import has_equilibria, is_vector_field, system_data_files
except ImportError as error:
    raise WorkflowError(
        f"cannot import ldpipe ({error}); install it first (see README.md: pip install -e .)"
    )

try:
    validate_config(config)  # fills the schema's defaults in place
except ConfigError as error:
    raise WorkflowError(str(error))


SYSTEMS = sorted(config["systems"])
# A time-dependent vector field has no fixed equilibria: no equilibrium file for it.
EQUILIBRIUM_SYSTEMS = [name for name in SYSTEMS if has_equilibria(name, config["systems"][name])]
LD_MAPS = sorted(config["ld_maps"])
# A map of one tile is computed and finished by one job (rule ld_map); the others by tile jobs and a gather.
ONE_TILE_MAPS = [name for name in LD_MAPS if ld_map_tiles(config, name) == 1]
TILED_MAPS = [name for name in LD_MAPS if name not in ONE_TILE_MAPS]
# Maps whose structures (singular curves, FTLE ridges) are extracted into a file of their own.
STRUCTURE_MAPS = [name for name in LD_MAPS if config["ld_maps"][name].get("structures")]
UPO_FAMILIES = sorted(config["periodic_orbits"])
# A manifold set names a periodic-orbit family (rule manifolds) or a discrete map (rule map_manifolds).
MANIFOLD_SETS = sorted(name for name, spec in config["manifolds"].items() if "system" not in spec)
MAP_MANIFOLD_SETS = sorted(name for name, spec in config["manifolds"].items() if "system" in spec)
POINCARE_SECTIONS = sorted(config["poincare_sections"])
FIGURES = list(config["figures"])
NHIM_STUDIES = list(config["nhim"]["studies"])
NHIM_ORBIT_STUDIES = list(config["nhim"]["orbit_validation"])
NHIM_SAMPLING_STUDIES = list(config.get("nhim_sampling", {}))
TRANSPORT_STUDIES = list(config.get("transport", {}))
SADDLE_FLUX_STUDIES = list(config.get("saddle_flux", {}))
NORMAL_FORM_STUDIES = list(config.get("normal_form", {}))
RESULTS = "results"


def _one_of(names):
    return "|".join(re.escape(name) for name in names) or "(?!)"


wildcard_constraints:
    system=_one_of(SYSTEMS),
    map=_one_of(LD_MAPS),
    tile=r"\d+",
    tiles=r"\d+",
    family=_one_of(UPO_FAMILIES),
    manifold=_one_of(MANIFOLD_SETS),
    map_manifold=_one_of(MAP_MANIFOLD_SETS),
    section=_one_of(POINCARE_SECTIONS),


# Where each stage's code digest lives: beside Snakemake's own records, one file per module.
CODE_DIGESTS = ".snakemake/ldpipe_code"


def library_code(module):
    """The digest of the ldpipe source files a stage imports, rewritten when one of them changes,
    so that editing them reruns the stage (and only then)."""
    return str(code_digest(module, CODE_DIGESTS))


def all_targets():
    return [
        *expand(f"{RESULTS}/{{system}}/equilibria.nc", system=EQUILIBRIUM_SYSTEMS),
        *expand(f"{RESULTS}/ld/{{map}}.nc", map=LD_MAPS),
        *expand(f"{RESULTS}/structures/{{map}}.nc", map=STRUCTURE_MAPS),
        *expand(f"{RESULTS}/upo/{{family}}.nc", family=UPO_FAMILIES),
        *expand(f"{RESULTS}/manifolds/{{manifold}}.nc", manifold=[*MANIFOLD_SETS, *MAP_MANIFOLD_SETS]),
        *expand(f"{RESULTS}/poincare/{{section}}.nc", section=POINCARE_SECTIONS),
        *expand(f"{RESULTS}/figures/{{figure}}.{{format}}", figure=FIGURES, format=["png", "pdf"]),
        *nhim_targets(),
        *expand(f"{RESULTS}/nhim_sampling/{{study}}.nc", study=NHIM_SAMPLING_STUDIES),
        *transport_targets(),
        *saddle_flux_targets(),
        *normal_form_targets(),
        *([f"{RESULTS}/accuracy/accuracy_cost.nc", f"{RESULTS}/figures/accuracy_cost.png"]
          if config.get("accuracy_cost") else []),
    ]


def equilibria_params(wildcards):
    return parameters_from_config(config, "equilibria", wildcards.system)


def ld_params(wildcards):
    return parameters_from_config(config, "ld", wildcards.map)


def ld_equilibria_file(wildcards):
    """The map's system's equilibria (its saddle and critical energy); none for a vector field."""
    system = config["ld_maps"][wildcards.map]["system"]
    if is_vector_field(config["systems"][system]):
        return []
    return f"{RESULTS}/{system}/equilibria.nc"


def ld_velocity_data_file(wildcards):
    """The dataset of a map's velocity-data system (made by a rule if it is the example's); none otherwise."""
    return system_data_files(config["systems"][config["ld_maps"][wildcards.map]["system"]])


def ld_tile_files(wildcards):
    tiles = ld_map_tiles(config, wildcards.map)
    return [f"{RESULTS}/ld/{wildcards.map}/tile-{tile}-of-{tiles}.nc" for tile in range(tiles)]


def _ld_points(map_name):
    # every start time's grid of a map with several (the file's t0 dimension)
    return ld_map_points(config, map_name)


# Cores of one job of a multi-threaded stage (LD tiles, manifolds, Poincare sections). A local
# run caps it at --cores; on a cluster it is what each such job asks for (a profile's set-threads
# changes it per rule). The numbers a stage writes do not depend on it (tests/workflow/test_slurm.py runs
# LD tiles on one core and compares them with a local run on two).
STAGE_THREADS = 4

# Core-seconds one LD grid point costs per unit of tau, forward and backward together: the
# paper's fixed-time Fig. 3 tiles took 1.4e-6 with dop853 at rtol 1e-8 (results/benchmarks/ld);
# fifteen times that covers fixed-step schemes at small dt, tighter tolerances and 3 DoF.
LD_CORE_SECONDS_PER_POINT_TAU = 2e-5


def ld_tile_memory_mb(wildcards):
    return _ld_tile_memory_mb(wildcards.map, int(wildcards.tiles))


def _ld_tile_memory_mb(map_name, tiles):
    return band_memory_mb(ld_tile_points(config, map_name, tiles))


def ld_tile_runtime_min(wildcards, threads, attempt):
    return _ld_tile_runtime_min(wildcards.map, int(wildcards.tiles), threads, attempt)


def _ld_tile_runtime_min(map_name, tiles, threads, attempt):
    # A time limit that fits the tile (a scheduler starts short jobs sooner), doubled on a retry.
    # a discrete map (no tau) costs a few flops an iteration: far below a unit of a flow's time
    tau = parameters_from_config(config, "ld", map_name).get("tau", 1.0)
    tile_points = ld_tile_points(config, map_name, tiles)
    core_seconds = tile_points * tau * LD_CORE_SECONDS_PER_POINT_TAU
    return (10 + math.ceil(core_seconds / threads / 60)) * attempt


def ld_gather_memory_mb(wildcards):
    return 1000 + 2 * _ld_points(wildcards.map) * 120 // 2**20


def ld_map_memory_mb(wildcards):
    """A one-tile map's job: the tile's computation, then the gather's write of the same fields
    (measured: 670 MB peak for a 1500 x 1500 adaptive Fig. 4 map, asked 1515)."""
    return max(_ld_tile_memory_mb(wildcards.map, 1), ld_gather_memory_mb(wildcards))


def ld_map_runtime_min(wildcards, threads, attempt):
    return _ld_tile_runtime_min(wildcards.map, 1, threads, attempt)


def structures_params(wildcards):
    return parameters_from_config(config, "structures", wildcards.map)


def upo_params(wildcards):
    return parameters_from_config(config, "upo", wildcards.family)


def upo_equilibria_file(wildcards):
    return f"{RESULTS}/{config['periodic_orbits'][wildcards.family]['system']}/equilibria.nc"


def manifold_params(wildcards):
    return parameters_from_config(config, "manifolds", wildcards.manifold)


def manifold_upo_file(wildcards):
    return f"{RESULTS}/upo/{config['manifolds'][wildcards.manifold]['orbits']}.nc"


def map_manifold_params(wildcards):
    return parameters_from_config(config, "manifolds", wildcards.map_manifold)


def map_manifold_equilibria_file(wildcards):
    return f"{RESULTS}/{config['manifolds'][wildcards.map_manifold]['system']}/equilibria.nc"


def map_manifold_memory_mb(wildcards):
    # The curves (manifold x branch x image x point x 2 coordinates doubles) of up to 8 saddles, four copies.
    spec = config["manifolds"][wildcards.map_manifold]
    return 1000 + 4 * 8 * 2 * 2 * (spec["iterations"] + 1) * spec["segment_points"] * 2 * 8 // 2**20


def manifold_memory_mb(wildcards):
    # The trajectories (manifold x branch x point x sample x phase doubles), a few copies, plus the interpreter.
    spec = config["manifolds"][wildcards.manifold]
    return 1000 + 4 * spec["points"] * spec["samples"] * 4 * 12 * 8 // 2**20


def poincare_params(wildcards):
    return parameters_from_config(config, "poincare", wildcards.section)


def poincare_equilibria_file(wildcards):
    """The section's system's equilibria (for an excess energy); none for a vector field."""
    system = config["poincare_sections"][wildcards.section]["system"]
    if is_vector_field(config["systems"][system]):
        return []
    return f"{RESULTS}/{system}/equilibria.nc"


def poincare_memory_mb(wildcards):
    # Crossing states of every grid point (trajectory x crossing x phase doubles), a few copies.
    spec = config["poincare_sections"][wildcards.section]
    axes = spec["initial_conditions"]["axes"]
    return 1000 + 4 * axes[0]["points"] * axes[1]["points"] * spec["max_crossings"] * 12 * 8 // 2**20


def nhim_params(wildcards):
    return parameters_from_config(config, "nhim", wildcards.study)


def _nhim_inputs(study):
    return nhim_study_inputs(config, study)


def nhim_map_files(wildcards):
    return [f"{RESULTS}/ld/{name}.nc" for name in _nhim_inputs(wildcards.study)["maps"]]


def nhim_equilibria_files(wildcards):
    return [f"{RESULTS}/{system}/equilibria.nc" for system in _nhim_inputs(wildcards.study)["systems"]]


def nhim_reference_files(wildcards):
    return [f"{RESULTS}/upo/{family}.nc" for family in _nhim_inputs(wildcards.study)["references"]]


def nhim_memory_mb(wildcards):
    # One LD map in memory at a time (about 110 bytes a point as loaded), plus the interpreter.
    largest = max([_ld_points(name) for name in _nhim_inputs(wildcards.study)["maps"]], default=0)
    return 1000 + largest * 110 // 2**20


def nhim_study_files():
    return [f"{RESULTS}/nhim/{study}.nc" for study in NHIM_STUDIES]


def nhim_orbit_params(wildcards):
    return parameters_from_config(config, "nhim_orbits", wildcards.study)


def _nhim_orbit_inputs(study):
    return nhim_orbit_inputs(config, study)


def nhim_orbit_family_files(wildcards):
    return [f"{RESULTS}/upo/{family}.nc" for family in _nhim_orbit_inputs(wildcards.study)["orbits"]]


def nhim_orbit_equilibria_file(wildcards):
    return f"{RESULTS}/{_nhim_orbit_inputs(wildcards.study)['systems'][0]}/equilibria.nc"


def nhim_orbit_files():
    return [f"{RESULTS}/nhim/orbits/{study}.nc" for study in NHIM_ORBIT_STUDIES]


def nhim_figure_maps():
    """The LD maps of the figure's top row: those of the first study that lists 2 DoF maps."""
    from ldpipe.systems import system_coordinates

    for study in NHIM_STUDIES:
        maps = _nhim_inputs(study)["maps"]
        if maps and len(system_coordinates(config["systems"][config["ld_maps"][maps[0]]["system"]])) == 2:
            return [f"{RESULTS}/ld/{name}.nc" for name in maps]
    return []


def nhim_figure_memory_mb():
    return 1000 + sum(_ld_points(path.split("/")[-1][:-3]) for path in nhim_figure_maps()) * 40 // 2**20


def nhim_targets():
    if not (NHIM_STUDIES or NHIM_ORBIT_STUDIES):
        return []
    return [
        *nhim_study_files(),
        *nhim_orbit_files(),
        *[f"{RESULTS}/nhim/{table}.{format}" for table in ("validation", "validation_orbits") for format in ("csv", "md")],
        *([f"{RESULTS}/figures/nhim_validation.png", f"{RESULTS}/figures/nhim_validation.pdf"] if NHIM_STUDIES else []),
    ]


def nhim_sampling_params(wildcards):
    return parameters_from_config(config, "nhim_sampling", wildcards.study)


def nhim_sampling_equilibria_file(wildcards):
    return f"{RESULTS}/{nhim_sampling_system(config, wildcards.study)}/equilibria.nc"


def transport_targets():
    """Every transport study's file and figure (workflow/rules/transport.smk)."""
    return [
        path
        for study in TRANSPORT_STUDIES
        for path in (f"{RESULTS}/transport/{study}.nc", f"{RESULTS}/figures/transport_{study}.png",
                     f"{RESULTS}/figures/transport_{study}.pdf")
    ]


def transport_upo_file(wildcards):
    return f"{RESULTS}/upo/{config['transport'][wildcards.study]['orbits']}.nc"


def transport_equilibria_file(wildcards):
    family = config["transport"][wildcards.study]["orbits"]
    return f"{RESULTS}/{config['periodic_orbits'][family]['system']}/equilibria.nc"


def transport_params(wildcards):
    return parameters_from_config(config, "transport", wildcards.study)


def saddle_flux_targets():
    """Every saddle-flux study's file and figure (workflow/rules/saddle_flux.smk)."""
    return [
        path
        for study in SADDLE_FLUX_STUDIES
        for path in (f"{RESULTS}/saddle_flux/{study}.nc", f"{RESULTS}/figures/saddle_flux_{study}.png",
                     f"{RESULTS}/figures/saddle_flux_{study}.pdf")
    ]


def saddle_flux_equilibria_file(wildcards):
    return f"{RESULTS}/{config['saddle_flux'][wildcards.study]['system']}/equilibria.nc"


def saddle_flux_params(wildcards):
    return parameters_from_config(config, "saddle_flux", wildcards.study)


def accuracy_params(wildcards):
    return parameters_from_config(config, "accuracy")


def accuracy_equilibria_files(wildcards):
    return [f"{RESULTS}/{system}/equilibria.nc" for system in accuracy_systems(config)]


def accuracy_engines():
    """The LD ladder's engine modules by name, each with the map and setting that compile it (none without a ladder)."""
    if not config.get("accuracy_cost"):
        return {}
    return ladder_engines(parameters_from_config(config, "accuracy")["ld"])


def accuracy_engine_params(wildcards):
    return accuracy_engines()[wildcards.engine]


def accuracy_engine_files(wildcards):
    return [f"{RESULTS}/accuracy/engines/{name}.txt" for name in accuracy_engines()]


def normal_form_targets():
    """Every normal-form study's file and figure (workflow/rules/normal_form.smk)."""
    return [
        path
        for study in NORMAL_FORM_STUDIES
        for path in (f"{RESULTS}/normal_form/{study}.nc", f"{RESULTS}/figures/normal_form_{study}.png",
                     f"{RESULTS}/figures/normal_form_{study}.pdf")
    ]


def normal_form_inputs(wildcards):
    """The study's equilibria file and the files of the studies it compares with."""
    spec = config["normal_form"][wildcards.study]
    inputs = {"equilibria": f"{RESULTS}/{spec['system']}/equilibria.nc"}
    for section in ("transport", "saddle_flux"):
        if section in spec:
            inputs[section] = f"{RESULTS}/{section}/{spec[section]}.nc"
    return inputs


def normal_form_params(wildcards):
    return parameters_from_config(config, "normal_form", wildcards.study)
