"""Snakemake script of the accuracy_cost rule: one call to the stage function."""

from ldpipe.logs import log_to

with log_to(snakemake.log[0]):  # noqa: F821 (snakemake is injected)
    from ldpipe.stages.accuracy import run_accuracy_cost  # inside, so an import failure is logged too

    run_accuracy_cost(
        **snakemake.params.stage,  # noqa: F821
        equilibria=list(snakemake.input.equilibria),  # noqa: F821
        output=snakemake.output.data,  # noqa: F821
        table=snakemake.output.table,  # noqa: F821
        threads=snakemake.threads,  # noqa: F821
    )
