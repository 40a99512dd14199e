"""Snakemake script of the saddle_flux_study rule: one call to the stage function."""

from ldpipe.logs import log_to

with log_to(snakemake.log[0]):  # noqa: F821 (snakemake is injected)
    from ldpipe.stages.saddle_flux import run_saddle_flux  # inside, so an import failure is logged too

    run_saddle_flux(
        **snakemake.params.stage,  # noqa: F821
        equilibria=snakemake.input.equilibria,  # noqa: F821
        threads=snakemake.threads,  # noqa: F821
        output=snakemake.output[0],  # noqa: F821
    )
