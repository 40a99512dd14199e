"""Snakemake script of the structures rule: one call to the stage function."""

from ldpipe.logs import log_to

with log_to(snakemake.log[0]):  # noqa: F821 (snakemake is injected)
    from ldpipe.stages.structures import run_structures  # inside, so an import failure is logged too

    run_structures(
        **snakemake.params.stage,  # noqa: F821
        ld_map=snakemake.input.ld_map,  # noqa: F821
        output=snakemake.output[0],  # noqa: F821
    )
