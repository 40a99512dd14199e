"""Snakemake script of the nhim_orbit_validation rule: one call to the stage function."""

from ldpipe.logs import log_to

with log_to(snakemake.log[0]):  # noqa: F821 (snakemake is injected)
    from ldpipe.stages.nhim_orbits import run_nhim_orbit_validation  # inside, so an import failure is logged too

    run_nhim_orbit_validation(
        **snakemake.params.stage,  # noqa: F821
        orbit_files=list(snakemake.input.orbits),  # noqa: F821
        equilibria=snakemake.input.equilibria,  # noqa: F821
        threads=snakemake.threads,  # noqa: F821
        output=snakemake.output[0],  # noqa: F821
    )
