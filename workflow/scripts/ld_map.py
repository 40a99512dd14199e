"""Snakemake script of the ld_map rule (a map of one tile): one call to the stage function."""

from ldpipe.logs import log_to

with log_to(snakemake.log[0]):  # noqa: F821 (snakemake is injected)
    from ldpipe.stages.ld import run_ld_map  # inside, so an import failure is logged too

    run_ld_map(
        **snakemake.params.stage,  # noqa: F821
        # a vector field's map has no equilibria input (an empty list)
        equilibria=snakemake.input.equilibria or None,  # noqa: F821
        tiles=1,
        threads=snakemake.threads,  # noqa: F821
        output=snakemake.output[0],  # noqa: F821
    )
