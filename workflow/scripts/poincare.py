"""Snakemake script of the poincare rule: one call to the stage function."""

from ldpipe.logs import log_to

with log_to(snakemake.log[0]):  # noqa: F821 (snakemake is injected)
    from ldpipe.stages.poincare import run_poincare  # inside, so an import failure is logged too

    run_poincare(
        **snakemake.params.stage,  # noqa: F821
        # a vector field's section has no equilibria input (an empty list)
        equilibria=snakemake.input.equilibria or None,  # noqa: F821
        threads=snakemake.threads,  # noqa: F821
        output=snakemake.output[0],  # noqa: F821
    )
