"""Snakemake script of the map_manifolds rule: one call to the stage function."""

from ldpipe.logs import log_to

with log_to(snakemake.log[0]):  # noqa: F821 (snakemake is injected)
    from ldpipe.stages.manifolds import run_map_manifolds  # inside, so an import failure is logged too

    run_map_manifolds(
        **snakemake.params.stage,  # noqa: F821
        equilibria=snakemake.input.equilibria,  # noqa: F821
        output=snakemake.output[0],  # noqa: F821
    )
