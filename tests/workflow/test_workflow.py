"""The Snakemake workflow, run for real on a copy of the repository's workflow files."""

import subprocess
import sys

import numpy as np
import pytest

from ldpipe.io.datafile import open_stage_file
from support.workflow import job_counts, run_snakemake

pytestmark = pytest.mark.slow


def test_dry_run_lists_equilibria_for_both_systems(workdir):
    result = run_snakemake(workdir, "-n")
    assert result.returncode == 0, result.stderr
    for system in ("barbanis_2dof", "barbanis_contopoulos_3dof"):
        assert f"results/{system}/equilibria.nc" in result.stdout
    assert job_counts(result.stdout).get("equilibria", 0) == 2


def test_a_map_of_one_tile_is_one_job_and_a_map_of_more_its_tiles_and_a_gather(workdir):
    """The tile counts config.yaml gives (Fig. 4's maps 1, Fig. 3's 2), as planned
    (ldpipe.stages.plan.ld_map_tiles): a map of one tile is one ld_map job, with no tile file and no
    gather; another is its ld_tile jobs and their ld_gather. A changed count moves a map across."""
    targets = ("results/ld/fig4_k-7.0.nc", "results/ld/fig3_dE0.125.nc")
    result = run_snakemake(workdir, "-n", *targets)
    assert result.returncode == 0, result.stderr[-3000:]
    assert job_counts(result.stdout) == {"equilibria": 1, "ld_map": 1, "ld_tile": 2, "ld_gather": 1}
    assert "results/ld/fig3_dE0.125/tile-1-of-2.nc" in result.stdout and "fig4_k-7.0/tile-" not in result.stdout
    (workdir / "tiles.yaml").write_text("ld_maps:\n  fig4_k-7.0: {tiles: 3}\n  fig3_dE0.125: {tiles: 1}\n")
    result = run_snakemake(workdir, "-n", *targets, "--configfile", "tiles.yaml")
    assert result.returncode == 0, result.stderr[-3000:]
    assert job_counts(result.stdout) == {"equilibria": 1, "ld_map": 1, "ld_tile": 3, "ld_gather": 1}
    assert "results/ld/fig4_k-7.0/tile-2-of-3.nc" in result.stdout and "fig3_dE0.125/tile-" not in result.stdout


def test_a_maps_manifolds_are_a_job_of_the_manifold_stage_after_its_equilibria(workdir):
    """A manifold set naming a discrete map (a configuration added to config.yaml's): its rule
    reads the map's equilibria file, and the file it writes is the API's from the same entry."""
    import ldpipe

    (workdir / "maps.yaml").write_text("systems:\n  henon: {map: henon}\n"
                                       "manifolds:\n  henon_saddles: {system: henon, iterations: 6, "
                                       "segment_points: 20}\n")
    target = "results/manifolds/henon_saddles.nc"
    result = run_snakemake(workdir, target, "--configfile", "maps.yaml")
    assert result.returncode == 0, result.stderr[-3000:]
    assert job_counts(result.stderr + result.stdout) == {"equilibria": 1, "map_manifolds": 1}
    written = open_stage_file(workdir / target, stage="map_manifolds").load()
    expected = ldpipe.map_manifolds(ldpipe.system(name="henon", map="henon"), name="henon_saddles", iterations=6,
                                    segment_points=20)
    for name in expected.variables:
        np.testing.assert_array_equal(written[name].values, expected[name].values, err_msg=name)
    assert written.attrs["parameters"] == expected.attrs["parameters"]


# Planning reads the configuration and names files (ldpipe.stages.plan): it needs none of the
# science's libraries. The expected set is the design, not a measurement: each of these, imported
# by a plan, costs every `snakemake` command (and every SLURM job's own snakemake) a fixed start-up.
NOT_FOR_PLANNING = ("matplotlib", "numba", "scipy.integrate", "scipy.optimize", "sympy")
PLAN_AND_LIST_MODULES = """
import runpy, sys
sys.argv = ["snakemake", "--cores", "2", "-n", "-q"]
try:
    runpy.run_module("snakemake", run_name="__main__")
except SystemExit as stop:
    print("exit", stop.code)
print("loaded", sorted(name for name in {names!r} if name in sys.modules))
"""


def test_planning_the_paper_imports_none_of_the_science_libraries(workdir):
    code = PLAN_AND_LIST_MODULES.format(names=NOT_FOR_PLANNING)
    result = subprocess.run([sys.executable, "-c", code], cwd=workdir, capture_output=True, text=True, timeout=600)
    lines = result.stdout.splitlines()
    assert lines[-2:] == ["exit 0", "loaded []"], result.stdout[-2000:] + result.stderr[-2000:]


def test_lint_is_clean(lint):
    output = lint.stdout + lint.stderr
    assert lint.returncode == 0, output[-3000:]
    assert "Congratulations, your workflow is in a good condition!" in output, output[-3000:]


def test_quick_run_then_rerun_only_what_changed(quick_run):
    workdir, result = quick_run
    assert result.returncode == 0, result.stderr
    henon = open_stage_file(workdir / "results/henon_heiles/equilibria.nc", stage="equilibria")
    assert sorted(henon.type.values) == ["index-1 saddle"] * 3 + ["minimum"]  # classical Henon-Heiles
    barbanis = open_stage_file(workdir / "results/barbanis_2dof/equilibria.nc", stage="equilibria")
    np.testing.assert_allclose(barbanis.critical_energy.values, [15.125, 15.125], atol=1e-12)
    for name in ("equilibria.log",):
        assert (workdir / "results/logs/henon_heiles" / name).stat().st_size > 0
    assert (workdir / "results/benchmarks/henon_heiles/equilibria.tsv").is_file()
    # The time-dependent vector field: its map from t0, its figure, and no equilibria (it has none).
    duffing = open_stage_file(workdir / "results/ld/forced_duffing_t0.nc", stage="ld_grid")
    assert duffing.attrs["t0"] == 1.5 and duffing.allowed.values.all() and "energy" not in duffing.attrs
    assert (workdir / "results/figures/forced_duffing_ld.png").is_file()
    assert not (workdir / "results/forced_duffing").exists()

    result = run_snakemake(workdir, "--configfile", "config.quick.yaml", "-n")
    assert "Nothing to be done" in result.stdout + result.stderr

    # A parameter change reruns that system's stage only (a dry run on a changed copy of the
    # configuration: the shared run's results stay as they are).
    quick = (workdir / "config.quick.yaml").read_text().replace("lam: 1.0", "lam: 0.5")
    (workdir / "config.changed.yaml").write_text(quick)
    result = run_snakemake(workdir, "--configfile", "config.changed.yaml", "-n")
    assert job_counts(result.stdout).get("equilibria", 0) == 1 and "params" in result.stdout.lower()
    assert "output: results/henon_heiles/equilibria.nc" in result.stdout
    assert "output: results/barbanis_2dof/equilibria.nc" not in result.stdout


def test_adding_masses_reruns_that_system_only(quick_run):
    # Provenance sees the kinetic matrix: masses on Hénon-Heiles rerun its equilibria (and what reads
    # them), nothing of Barbanis (a dry run on a changed copy; the shared run's results stay).
    workdir, result = quick_run
    assert result.returncode == 0, result.stderr
    quick = (workdir / "config.quick.yaml").read_text().replace(
        "    parameters: {lam: 1.0}\n", "    parameters: {lam: 1.0}\n    masses: {x: 2.0}\n")
    assert "masses: {x: 2.0}" in quick
    (workdir / "config.masses.yaml").write_text(quick)
    result = run_snakemake(workdir, "--configfile", "config.masses.yaml", "-n")
    assert result.returncode == 0, result.stderr
    assert job_counts(result.stdout).get("equilibria", 0) == 1
    assert "output: results/henon_heiles/equilibria.nc" in result.stdout
    assert "output: results/barbanis_2dof/equilibria.nc" not in result.stdout


def test_bad_config_stops_before_anything_runs(workdir):
    config = (workdir / "config.yaml").read_text().replace("delta: -0.11", "delta: minus")
    (workdir / "config.yaml").write_text(config)
    result = run_snakemake(workdir)
    assert result.returncode != 0
    assert "systems.barbanis_2dof.parameters.delta" in result.stderr + result.stdout
    assert not (workdir / "results").exists()
