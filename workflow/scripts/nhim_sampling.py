"""Snakemake script of the nhim_sampling rule: one call to the stage function."""

from ldpipe.logs import log_to

with log_to(snakemake.log[0]):  # noqa: F821 (snakemake is injected)
    from ldpipe.stages.nhim_sampling import run_nhim_sampling  # inside, so an import failure is logged too

    run_nhim_sampling(
        **snakemake.params.stage,  # noqa: F821
        equilibria=snakemake.input.equilibria,  # noqa: F821
        threads=snakemake.threads,  # noqa: F821
        output=snakemake.output[0],  # noqa: F821
    )
