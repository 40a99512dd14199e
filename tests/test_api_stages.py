"""The Python API's Poincaré (Hamiltonian and vector field), saddle-flux, transport, normal-form and
NHIM calls against the stage functions.

The expected values are the pipeline's own files: each stage's ``run_*`` function (the one
Snakemake's script calls) given ``parameters_from_config`` of the same configuration entry and
the input files the workflow wires to it. The API must give them back bit for bit, data and
attributes, but for ``history`` (when and how a file was written), the values of wall times (the
seconds a part of the run took, measured: never the same twice) and, where a stage records its
input files, their names (a path in the pipeline, the title of a Dataset given in memory).

The Poincaré and saddle-flux calls find their system's equilibria themselves, with the system's
own settings, as the workflow's equilibria rule does; the files the transport and NHIM stages read
(equilibria, the orbit family, the LD map) are computed once by their stage functions and given to
both sides, the API as the Datasets ``ldpipe.open_dataset`` reads, so that each of these tests checks
one API call. The systems and settings are those other tests compile: Barbanis'
section of tests/stages/test_poincare.py, the quadratic 3 DoF saddle of
tests/transport/test_saddle_flux.py, Barbanis' bottom family of tests/transport/test_stage.py (on
smaller ensembles), the normal forms of both saddles at tests/normal_form/test_stage.py's order and
Fig. 4's slice y = -7 of tests/stages/test_nhim.py (on a smaller window), which is also the base
map of the orbit validation (slices through points of the bottom family's orbit, as
tests/stages/test_nhim_orbits.py's 2 DoF study, on smaller windows) and of the NHIM sampling (its
slices y = -7.02 and -6.98, each meeting the orbit).
"""

import json

import numpy as np
import pytest

import ldpipe
from ldpipe.config import validate_config
from ldpipe.errors import ConfigError
from ldpipe.stages.accuracy import run_accuracy_cost
from ldpipe.stages.equilibria import run_equilibria
from ldpipe.stages.ld import run_ld_map
from ldpipe.stages.plan import ld_map_tiles
from ldpipe.stages.nhim import run_nhim_study
from ldpipe.stages.nhim_orbits import run_nhim_orbit_validation
from ldpipe.stages.nhim_sampling import run_nhim_sampling
from ldpipe.stages.normal_form import run_normal_form
from ldpipe.config.parameters import parameters_from_config
from ldpipe.stages.poincare import run_poincare
from ldpipe.stages.saddle_flux import run_saddle_flux
from ldpipe.stages.transport import run_transport
from ldpipe.stages.upo import run_upo
from support import quadratic_saddle as quadratic
from support.stage_files import assert_same_file, wall_times

BARBANIS = {"builtin": "barbanis_2dof"}
#: tests/stages/test_poincare.py's stage section.
POINCARE = {
    "system": "barbanis_2dof", "energy": {"excess": 0.125}, "time": 50, "max_crossings": 20,
    "initial_conditions": {"axes": [{"name": "x", "range": [-5, 5], "points": 4},
                                    {"name": "px", "range": [-5, 5], "points": 4}],
                           "fixed": {"y": 0.0}, "solve": "py"},
}
#: The quadratic saddle with its non-default equilibrium box (tests/transport/test_saddle_flux.py).
QUADRATIC = {**quadratic.spec(), "equilibria": {"default_interval": [-3.0, 3.0]}}
SADDLE_FLUX = {"system": "quadratic", "energies": {"excess": [0.05, 0.4]},
               "monte_carlo": {"batch": 100, "max_samples": 100, "commit": 1.0, "duration": 12.0}}
#: tests/transport/test_stage.py's family and study at one energy, on the schema's smallest ensembles.
FAMILY = {"system": "barbanis_2dof", "saddle_near": [5.5, -7.0], "energies": {"excess": [0.125]}, "samples": 64}
TRANSPORT = {"orbits": "bottom", "energies": {"excess": [0.125]}, "island": {"points": 8},
             "monte_carlo": {"batch": 20, "max_samples": 20},
             "survival": {"initial_count": 200, "count": 20, "duration": 0.5, "decay_window": [0.2, 0.5],
                          "points": 10},
             "gap_times": {"count": 20}}
#: Normal forms of the quadratic 3 DoF saddle compared with the saddle-flux study (as in
#: tests/normal_form/test_stage.py), and of Barbanis' bottom saddle (2 DoF: one centre frequency,
#: which its file holds as a scalar) compared with the transport study.
NORMAL_FORMS = {
    "nq": {"system": "quadratic", "energies": {"excess": [0.1, 1.0]}, "order": 6, "nhim_angles": 6,
           "saddle_flux": "q"},
    "nb": {"system": "barbanis_2dof", "saddle_near": [5.5, -7.0], "energies": {"excess": [0.125]}, "order": 6,
           "nhim_angles": 8, "transport": "t"},
}
#: Fig. 4's slice y = -7 (tests/stages/test_nhim.py) on a 16 x 16 grid about its NHIM point (the
#: orbit's crossing is (5.6025, 0.3768)), in two tiles.
NHIM_MAP = {
    "system": "barbanis_2dof", "saddle_near": [5.5, -7.0],
    "section": {"axes": [{"name": "x", "range": [5.4, 5.8], "points": 16},
                         {"name": "px", "range": [0.18, 0.58], "points": 16}],
                "fixed": {"y": -7.0}, "solve": "py"},
    "energy": {"excess": 0.125}, "tau": 50, "time": "variable", "region": {"x": [4.5, 6.5], "y": [-8.5, -5.5]},
    "tiles": 2,
}
#: Both keys differ from the schema's defaults (1e-8, zoom on): the user's values must reach the stage.
REFINEMENT = {"tolerance": 1e-9, "zoom": False}
#: Slices through two points of the bottom family's orbit (phases 0 and 1/2), both kinds, on 15 x 15 windows.
ORBIT_VALIDATION = {"base_map": "k-7.0", "orbits": ["bottom"], "energies": {"excess": [0.125]}, "phases": 2,
                    "slices": [["x", "px"], ["y", "py"]], "half_width": 0.2, "points": 15}
#: The accuracy ladders on the same map and family, each as short as the schema allows, timed once.
ACCURACY = {"ld": {"maps": ["k-7.0"], "points": 32, "repeats": 1, "ladder": {"dop853": {"rtol": [1e-6, 1e-8]}}},
            "upo": {"family": "bottom", "tolerance": [1e-10], "rtol": [1e-13], "repeats": 1},
            "nhim": {"map": "k-7.0", "grid_points": [12], "refinement_grid": 12, "tolerance": [1e-4]}}
#: Two slices y = const of the map's section (every other key of the map kept), seeded on 21 x 21 points.
NHIM_SAMPLING = {"base_map": "base_map", "fixed": {"y": {"range": [-7.02, -6.98], "points": 2}}, "seed_points": 21}


def without(entry: dict, key: str) -> dict:
    """An entry's keys as an API call's arguments: the one naming another entry left out."""
    return {k: v for k, v in entry.items() if k != key}


@pytest.fixture(scope="module")
def pipeline(tmp_path_factory):
    """The configuration of every entry here and the files of its Barbanis inputs, as the workflow makes them."""
    folder = tmp_path_factory.mktemp("api_stages")
    config = validate_config({
        "systems": {"barbanis_2dof": dict(BARBANIS), "quadratic": QUADRATIC},
        "poincare_sections": {"p": dict(POINCARE)},
        "saddle_flux": {"q": dict(SADDLE_FLUX)},
        "periodic_orbits": {"bottom": dict(FAMILY)},
        "transport": {"t": dict(TRANSPORT)},
        "normal_form": {name: dict(entry) for name, entry in NORMAL_FORMS.items()},
        # the sampling's base map, under the name the API gives a map passed by its keys (never computed)
        "ld_maps": {"k-7.0": dict(NHIM_MAP), "base_map": dict(NHIM_MAP)},
        "nhim": {"refinement": dict(REFINEMENT), "studies": {"s": {"maps": ["k-7.0"], "reference": ["bottom"]}},
                 "orbit_validation": {"o": dict(ORBIT_VALIDATION)}},
        "nhim_sampling": {"ns": dict(NHIM_SAMPLING)},
        "accuracy_cost": ACCURACY,
    })
    equilibria = run_equilibria(**parameters_from_config(config, "equilibria", "barbanis_2dof"),
                                output=folder / "eq.nc")
    upo = run_upo(**parameters_from_config(config, "upo", "bottom"), equilibria=equilibria,
                  output=folder / "bottom.nc")
    quadratic_equilibria = run_equilibria(**parameters_from_config(config, "equilibria", "quadratic"),
                                          output=folder / "quadratic_eq.nc")
    ld_map = run_ld_map(**parameters_from_config(config, "ld", "k-7.0"), equilibria=equilibria,
                        tiles=ld_map_tiles(config, "k-7.0"), show_progress=False, output=folder / "k-7.0.nc")
    return {"folder": folder, "config": config, "equilibria": equilibria, "quadratic_equilibria": quadratic_equilibria,
            "upo": upo, "map": ld_map}


def test_poincare_equals_the_stage_functions_file(pipeline):
    # the API finds the equilibria itself, with the system's settings (here the defaults), as the
    # workflow's equilibria rule does
    stored = run_poincare(**parameters_from_config(pipeline["config"], "poincare", "p"),
                          equilibria=pipeline["equilibria"], output=pipeline["folder"] / "p.nc")
    barbanis = ldpipe.system(**BARBANIS)
    assert_same_file(ldpipe.poincare(barbanis, name="p", **without(POINCARE, "system")), ldpipe.open_dataset(stored))


def test_poincare_of_a_vector_field_equals_the_stage_functions_file(tmp_path):
    # no equilibria on either side: a vector field has no energy, its trajectories start at t0
    # (tests/stages/test_vector_field_stages.py's oscillator section)
    oscillator = {"vector_field": {"x": "y", "y": "-x"}, "coordinates": ["x", "y"]}
    section = {"system": "osc", "t0": 0.7, "time": 20.0, "max_crossings": 10,
               "initial_conditions": {"axes": [{"name": "x", "range": [0.2, 0.6], "points": 3},
                                               {"name": "y", "range": [-0.4, 0.4], "points": 3}]},
               "section": {"coordinate": "y", "value": 0.0, "direction": -1}}
    config = validate_config({"systems": {"osc": oscillator}, "poincare_sections": {"p": section}})
    stored = run_poincare(**parameters_from_config(config, "poincare", "p"), equilibria=None,
                          output=tmp_path / "p.nc")
    result = ldpipe.poincare(ldpipe.system(name="osc", **oscillator), name="p", **without(section, "system"))
    assert result.attrs["t0"] == 0.7 and "energy" not in result.attrs
    assert_same_file(result, ldpipe.open_dataset(stored))


def test_saddle_flux_equals_the_stage_functions_file(pipeline):
    # the equilibria found by the API with the system's own (non-default) box, as the workflow does
    stored = run_saddle_flux(**parameters_from_config(pipeline["config"], "saddle_flux", "q"),
                             equilibria=pipeline["quadratic_equilibria"], output=pipeline["folder"] / "q.nc")
    system = ldpipe.system(name="quadratic", **QUADRATIC)
    assert_same_file(ldpipe.saddle_flux(system, name="q", **without(SADDLE_FLUX, "system")),
                     ldpipe.open_dataset(stored))


def test_transport_equals_the_stage_functions_file(pipeline):
    stored = run_transport(**parameters_from_config(pipeline["config"], "transport", "t"), upo=pipeline["upo"],
                           equilibria=pipeline["equilibria"], output=pipeline["folder"] / "t.nc")
    orbits, equilibria = ldpipe.open_dataset(pipeline["upo"]), ldpipe.open_dataset(pipeline["equilibria"])
    result = ldpipe.transport(orbits, name="t", equilibria=equilibria, **without(TRANSPORT, "orbits"))
    assert_same_file(result, ldpipe.open_dataset(stored))


def test_transport_takes_the_familys_equilibria_and_no_others(pipeline):
    """The study reads the well, the centre frequencies and every other saddle from the equilibria,
    and a family's file records its system without the equilibrium-search settings (so that changing
    them reruns only the equilibria). Found again with the search's defaults they can differ from
    the pipeline's: for Barbanis with delta = -0.03 and the box [-30, 30] its saddles (x = 20.17) are
    outside the default [-20, 20], and the stage failed ("the well is not bounded") where the
    pipeline's file had the study. So the call needs them, and refuses those of a system with
    another spec, before any work."""
    orbits = ldpipe.open_dataset(pipeline["upo"])
    arguments = without(TRANSPORT, "orbits")
    with pytest.raises(ConfigError, match=r"^ldpipe.transport: argument 'equilibria': required: give the equilibria "
                                          r"of the family's system \(ldpipe.equilibria\(system\), found with the "
                                          r"system's own 'equilibria' settings\)"):
        ldpipe.transport(orbits, name="t", **arguments)
    quadratic_equilibria = ldpipe.open_dataset(pipeline["quadratic_equilibria"])
    with pytest.raises(ConfigError, match=r"^ldpipe.transport: argument 'equilibria': equilibria of system "
                                          r"'quadratic' \{.*\}, but the family is of 'barbanis_2dof' "
                                          r"\{'builtin': 'barbanis_2dof', 'parameters': \{\}\}$"):
        ldpipe.transport(orbits, name="t", equilibria=quadratic_equilibria, **arguments)
    # Barbanis' equilibria under the family's system name, as the equilibria stage records them for
    # other parameters (the check reads the record, not the numbers)
    other = ldpipe.open_dataset(pipeline["equilibria"])
    recorded = json.loads(other.attrs["parameters"])
    recorded["system_spec"]["parameters"] = {"delta": -0.03}
    other.attrs["parameters"] = json.dumps(recorded, sort_keys=True)
    with pytest.raises(ConfigError, match=r"^ldpipe.transport: argument 'equilibria': equilibria of system "
                                          r"'barbanis_2dof' \{'builtin': 'barbanis_2dof', 'parameters': "
                                          r"\{'delta': -0.03\}\}, but the family is of 'barbanis_2dof'"):
        ldpipe.transport(orbits, name="t", equilibria=other, **arguments)


def test_normal_form_equals_the_stage_functions_file(pipeline):
    # the compared studies' files written by their stage functions and given to both sides, the
    # API as Datasets in place of the names the entries give
    config, folder = pipeline["config"], pipeline["folder"]
    flux = run_saddle_flux(**parameters_from_config(config, "saddle_flux", "q"),
                           equilibria=pipeline["quadratic_equilibria"], output=folder / "nf_q.nc")
    transport = run_transport(**parameters_from_config(config, "transport", "t"), upo=pipeline["upo"],
                              equilibria=pipeline["equilibria"], output=folder / "nf_t.nc")
    quadratic_system = ldpipe.system(name="quadratic", **QUADRATIC)
    stored = run_normal_form(**parameters_from_config(config, "normal_form", "nq"),
                             equilibria=pipeline["quadratic_equilibria"], saddle_flux_file=flux,
                             output=folder / "nq.nc")
    result = ldpipe.normal_form(quadratic_system, name="nq", saddle_flux=ldpipe.open_dataset(flux),
                                **without(without(NORMAL_FORMS["nq"], "system"), "saddle_flux"))
    assert_same_file(result, ldpipe.open_dataset(stored))
    assert "flux_monte_carlo" in result and "flux_orbit_action" not in result

    stored = run_normal_form(**parameters_from_config(config, "normal_form", "nb"),
                             equilibria=pipeline["equilibria"], transport_file=transport, output=folder / "nb.nc")
    # here the equilibria given (the quadratic saddle's above found by the API with its own box)
    result = ldpipe.normal_form(ldpipe.system(**BARBANIS), name="nb",
                                equilibria=ldpipe.open_dataset(pipeline["equilibria"]),
                                transport=ldpipe.open_dataset(transport),
                                **without(without(NORMAL_FORMS["nb"], "system"), "transport"))
    assert_same_file(result, ldpipe.open_dataset(stored))
    assert "flux_orbit_action" in result and result.attrs["centre_frequencies"].shape == ()

    # a compared study of another system is refused by argument, as the configuration refuses its key
    with pytest.raises(ConfigError, match=r"^ldpipe.normal_form: argument 'transport': study 't' is of system "
                                          r"'barbanis_2dof' \{.*\}, not 'quadratic' \{.*\}$"):
        ldpipe.normal_form(quadratic_system, name="nq", transport=ldpipe.open_dataset(transport),
                           **without(without(NORMAL_FORMS["nq"], "system"), "saddle_flux"))


def test_nhim_equals_the_stage_functions_file_but_for_the_inputs_names(pipeline):
    stored = ldpipe.open_dataset(run_nhim_study(
        **parameters_from_config(pipeline["config"], "nhim", "s"), maps=[pipeline["map"]],
        reference_files=[pipeline["upo"]], output=pipeline["folder"] / "s.nc"))
    ld_map, orbits = ldpipe.open_dataset(pipeline["map"]), ldpipe.open_dataset(pipeline["upo"])
    result = ldpipe.nhim([ld_map], study="s", references=[orbits], **REFINEMENT)
    # The one difference: the pipeline records its input files' paths, the API the titles of the
    # Datasets it was given (which have no path).
    recorded, stored_recorded = (json.loads(data.attrs["parameters"]) for data in (result, stored))
    assert stored_recorded["maps"] == [str(pipeline["map"])]
    assert stored_recorded["references"] == {"bottom": str(pipeline["upo"])}
    assert recorded["maps"] == [f"(in memory) {ld_map.attrs['title']}"]
    assert recorded["references"] == {"bottom": f"(in memory) {orbits.attrs['title']}"}
    assert_same_file(result, stored, inputs=("maps", "references"))
    assert list(stored.slice.values) == ["k-7.0"]


def test_orbit_validation_equals_the_stage_functions_file(pipeline):
    stored = ldpipe.open_dataset(run_nhim_orbit_validation(
        **parameters_from_config(pipeline["config"], "nhim_orbits", "o"), orbit_files=[pipeline["upo"]],
        equilibria=pipeline["equilibria"], output=pipeline["folder"] / "o.nc"))
    orbits, equilibria = ldpipe.open_dataset(pipeline["upo"]), ldpipe.open_dataset(pipeline["equilibria"])
    ld_map = ldpipe.open_dataset(pipeline["map"])
    arguments = {k: v for k, v in ORBIT_VALIDATION.items() if k not in ("base_map", "orbits")}
    result = ldpipe.orbit_validation(orbits, study="o", base_map=ld_map, equilibria=equilibria,
                                     refinement=REFINEMENT, **arguments)
    assert_same_file(result, stored)
    # both kinds of slice at both points: searched or degenerate, each with its status
    assert stored.sizes["slice"] == 4 and all(str(status) for status in stored.status.values)
    assert json.loads(stored.attrs["parameters"])["refinement"]["tolerance"] == REFINEMENT["tolerance"]


def test_orbit_validation_names_its_arguments(pipeline):
    orbits, equilibria = ldpipe.open_dataset(pipeline["upo"]), ldpipe.open_dataset(pipeline["equilibria"])
    ld_map = ldpipe.open_dataset(pipeline["map"])
    with pytest.raises(ConfigError, match=r"^ldpipe.orbit_validation: argument 'equilibria': required"):
        ldpipe.orbit_validation(orbits, base_map=ld_map, energies={"excess": [0.125]})
    with pytest.raises(ConfigError, match=r"(?s)^ldpipe.orbit_validation: .*argument 'points'.*odd"):
        ldpipe.orbit_validation(orbits, base_map=ld_map, equilibria=equilibria, energies={"excess": [0.125]},
                                points=16)
    with pytest.raises(ConfigError, match=r"(?s)^ldpipe.orbit_validation: .*argument 'refinement.tolerance'"):
        ldpipe.orbit_validation(orbits, base_map=ld_map, equilibria=equilibria, energies={"excess": [0.125]},
                                refinement={"tolerance": "small"})
    with pytest.raises(ConfigError, match=r"(?s)^ldpipe.orbit_validation: .*argument 'base_map.tau'"):
        ldpipe.orbit_validation(orbits, base_map={**without(NHIM_MAP, "system"), "tau": -1.0}, equilibria=equilibria,
                                energies={"excess": [0.125]})


def test_nhim_sampling_equals_the_stage_functions_file(pipeline):
    stored = ldpipe.open_dataset(run_nhim_sampling(
        **parameters_from_config(pipeline["config"], "nhim_sampling", "ns"), equilibria=pipeline["equilibria"],
        output=pipeline["folder"] / "ns.nc"))
    barbanis = ldpipe.system(**BARBANIS)
    result = ldpipe.nhim_sampling(barbanis, study="ns", base_map=without(NHIM_MAP, "system"),
                                  equilibria=ldpipe.open_dataset(pipeline["equilibria"]), refinement=REFINEMENT,
                                  **without(NHIM_SAMPLING, "base_map"))
    # the run's measured time is an attribute here: the one value that cannot be the same twice
    for dataset in (result, stored):
        assert dataset.attrs.pop("wall_time") > 0
    assert_same_file(result, stored)
    assert stored.sizes["slice"] == 2 and stored.sizes["point"] == 2  # both slices meet the orbit


#: What the accuracy measurement measures besides its wall times (the reference orbit's among its
#: attributes, which assert_same_file sets aside), never the same twice: CPU times, rates from the
#: times, the load average.
MEASURED = ("cpu_time", "throughput", "throughput_per_core", "map_wall_time_estimate")
MEASURED_ATTRIBUTES = ("load_average_before", "load_average_after")


def test_accuracy_cost_equals_the_stage_functions_file_but_for_what_it_measures(pipeline):
    stored = ldpipe.open_dataset(run_accuracy_cost(
        **parameters_from_config(pipeline["config"], "accuracy"), equilibria=[pipeline["equilibria"]],
        output=pipeline["folder"] / "accuracy.nc", table=pipeline["folder"] / "accuracy.md", threads=1))
    ld_map, orbits = ldpipe.open_dataset(pipeline["map"]), ldpipe.open_dataset(pipeline["upo"])
    result = ldpipe.accuracy_cost(equilibria=ldpipe.open_dataset(pipeline["equilibria"]), threads=1,
                                  ld={**ACCURACY["ld"], "maps": [ld_map]}, upo={**ACCURACY["upo"], "family": orbits},
                                  nhim={**ACCURACY["nhim"], "map": ld_map}, refinement=REFINEMENT)
    for dataset in (result, stored):
        for name in MEASURED:
            assert np.all(dataset[name].values >= 0), name
            dataset[name].values[...] = 0.0
        for name in MEASURED_ATTRIBUTES:
            dataset.attrs[name] = np.zeros_like(dataset.attrs[name])
    # some of its wall times have no units (assert_same_file asks for them): compared here, then left out
    assert wall_times(result) == wall_times(stored)
    for name in wall_times(stored):
        assert result[name].dims == stored[name].dims and result[name].attrs == stored[name].attrs, name
        assert np.all(result[name].values >= 0) and np.all(stored[name].values >= 0), name
    assert_same_file(result.drop_vars(wall_times(result)), stored.drop_vars(wall_times(stored)))
    assert stored.sizes["setting"] == 2 and stored.sizes["orbit_setting"] == 1 and stored.sizes["nhim_grid"] == 1


def _refused_calls(pipeline):
    """Each API call taking ``equilibria=`` of a system, given the other system's (Barbanis' and the
    quadratic saddle's, both recorded by the equilibria stage)."""
    barbanis, quadratic_system = ldpipe.system(**BARBANIS), ldpipe.system(name="quadratic", **QUADRATIC)
    barbanis_eq = ldpipe.open_dataset(pipeline["equilibria"])
    quadratic_eq = ldpipe.open_dataset(pipeline["quadratic_equilibria"])
    return {
        "ld_map": lambda: ldpipe.ld_map(barbanis, name="k-7.0", equilibria=quadratic_eq, **without(NHIM_MAP, "system")),
        "periodic_orbits": lambda: ldpipe.periodic_orbits(barbanis, name="bottom", equilibria=quadratic_eq,
                                                          **without(FAMILY, "system")),
        "poincare": lambda: ldpipe.poincare(barbanis, name="p", equilibria=quadratic_eq, **without(POINCARE, "system")),
        "nhim_sampling": lambda: ldpipe.nhim_sampling(barbanis, study="ns", equilibria=quadratic_eq,
                                                      base_map=without(NHIM_MAP, "system"),
                                                      **without(NHIM_SAMPLING, "base_map")),
        "saddle_flux": lambda: ldpipe.saddle_flux(quadratic_system, name="q", equilibria=barbanis_eq,
                                                  **without(SADDLE_FLUX, "system")),
        "normal_form": lambda: ldpipe.normal_form(quadratic_system, name="nq", equilibria=barbanis_eq,
                                                  **without(without(NORMAL_FORMS["nq"], "system"), "saddle_flux")),
    }


@pytest.mark.parametrize("function", ["ld_map", "periodic_orbits", "poincare", "nhim_sampling", "saddle_flux",
                                      "normal_form"])
def test_equilibria_of_another_system_are_refused_naming_the_argument(pipeline, function):
    """Another system's saddle would place a map's section, a family's start or a flux's dividing
    surface at a point of the wrong system, silently: every call taking ``equilibria=`` compares the
    spec the equilibria file records with its system's (as ldpipe.transport does for a family)."""
    with pytest.raises(ConfigError, match=rf"^ldpipe.{function}: argument 'equilibria': equilibria of system "
                                          r"'(quadratic|barbanis_2dof)' \{.*\}, but the system given is of "
                                          r"'(barbanis_2dof|quadratic)' \{.*\}$"):
        _refused_calls(pipeline)[function]()


def test_equilibria_of_the_system_itself_are_taken(pipeline):
    # the same files as the stage functions write given their own equilibria
    barbanis = ldpipe.system(**BARBANIS)
    equilibria = ldpipe.open_dataset(pipeline["equilibria"])
    stored = run_poincare(**parameters_from_config(pipeline["config"], "poincare", "p"),
                          equilibria=pipeline["equilibria"], output=pipeline["folder"] / "p_own.nc")
    assert_same_file(ldpipe.poincare(barbanis, name="p", equilibria=equilibria, **without(POINCARE, "system")),
                     ldpipe.open_dataset(stored))
    assert_same_file(ldpipe.ld_map(barbanis, name="k-7.0", equilibria=equilibria, **without(NHIM_MAP, "system")),
                     ldpipe.open_dataset(pipeline["map"]))
    assert_same_file(ldpipe.periodic_orbits(barbanis, name="bottom", equilibria=equilibria,
                                            **without(FAMILY, "system")), ldpipe.open_dataset(pipeline["upo"]))
    quadratic_system = ldpipe.system(name="quadratic", **QUADRATIC)
    stored = run_saddle_flux(**parameters_from_config(pipeline["config"], "saddle_flux", "q"),
                             equilibria=pipeline["quadratic_equilibria"], output=pipeline["folder"] / "q_own.nc")
    assert_same_file(ldpipe.saddle_flux(quadratic_system, name="q", **without(SADDLE_FLUX, "system"),
                                        equilibria=ldpipe.open_dataset(pipeline["quadratic_equilibria"])),
                     ldpipe.open_dataset(stored))
    # under another name the system is the same: its equilibria are taken
    renamed = ldpipe.system(name="barbanis", **BARBANIS)
    assert ldpipe.poincare(renamed, name="p", equilibria=equilibria, **without(POINCARE, "system")).sizes


def test_energies_shorthand_is_the_total_energies_block(pipeline):
    """``energies=[E]`` (a list or a tuple) stands for ``energies={"total": [E]}``: the same file bit
    for bit. Barbanis' saddle is at a nonzero energy, so a shorthand read as excess energies (or
    the block's total taken for an excess) gives another family: the case where the two coincide
    (a saddle at energy 0, as the quadratic one) could not tell them apart."""
    from ldpipe.core.equilibria.potential import select_saddle

    equilibria = ldpipe.open_dataset(pipeline["equilibria"])
    critical = select_saddle(equilibria, FAMILY["saddle_near"])[1]
    assert abs(critical) > 1.0  # far from zero: total and excess energies differ
    total = critical + 0.125
    barbanis = ldpipe.system(**BARBANIS)
    entry = without(without(FAMILY, "system"), "energies")
    block = ldpipe.periodic_orbits(barbanis, name="bottom", equilibria=equilibria, energies={"total": [total]}, **entry)
    for shorthand in ([total], (total,)):
        assert_same_file(ldpipe.periodic_orbits(barbanis, name="bottom", equilibria=equilibria, energies=shorthand,
                                                **entry), block)
    # and the block is the total energy: the family of the excess 0.125 has the same orbit's period
    stored = ldpipe.open_dataset(pipeline["upo"])
    # (measured: equal; the orbit's own tolerance 1e-10 bounds what a rounding of the total could move)
    np.testing.assert_allclose(block.period.values, stored.period.values, rtol=1e-11)


def test_section_shorthand_gives_the_file_of_its_block(pipeline):
    # ldpipe.section(...) for the initial_conditions block: the stage function's file bit for bit
    stored = run_poincare(**parameters_from_config(pipeline["config"], "poincare", "p"),
                          equilibria=pipeline["equilibria"], output=pipeline["folder"] / "p_section.nc")
    # (POINCARE's block as written above; the pipeline's validation fills its defaults in)
    section = ldpipe.section(x=(-5, 5, 4), px=(-5, 5, 4), fixed={"y": 0.0}, solve="py")
    assert section == {"axes": [{"name": "x", "range": [-5, 5], "points": 4},
                                {"name": "px", "range": [-5, 5], "points": 4}], "fixed": {"y": 0.0}, "solve": "py"}
    result = ldpipe.poincare(ldpipe.system(**BARBANIS), name="p", **{**without(POINCARE, "system"),
                                                                      "initial_conditions": section})
    assert_same_file(result, ldpipe.open_dataset(stored))
