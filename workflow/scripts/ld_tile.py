"""Snakemake script of the ld_tile rule: one call to the stage function."""

from ldpipe.logs import log_to

with log_to(snakemake.log[0]):  # noqa: F821 (snakemake is injected)
    from ldpipe.stages.ld import run_ld_tile  # inside, so an import failure is logged too

    run_ld_tile(
        **snakemake.params.stage,  # noqa: F821
        # a vector field's map has no equilibria input (an empty list)
        equilibria=snakemake.input.equilibria or None,  # noqa: F821
        tile=int(snakemake.wildcards.tile),  # noqa: F821
        tiles=int(snakemake.wildcards.tiles),  # noqa: F821
        threads=snakemake.threads,  # noqa: F821
        output=snakemake.output[0],  # noqa: F821
    )
