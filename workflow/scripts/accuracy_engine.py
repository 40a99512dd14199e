"""Snakemake script of the accuracy_engine rule: one call to the stage function."""

from ldpipe.logs import log_to

with log_to(snakemake.log[0]):  # noqa: F821 (snakemake is injected)
    from ldpipe.stages.accuracy import run_accuracy_engine  # inside, so an import failure is logged too

    run_accuracy_engine(
        **snakemake.params.stage,  # noqa: F821
        equilibria=list(snakemake.input.equilibria),  # noqa: F821
        output=snakemake.output[0],  # noqa: F821
    )
