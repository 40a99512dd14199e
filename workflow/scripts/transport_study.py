"""Snakemake script of the transport_study rule: one call to the stage function."""

from ldpipe.logs import log_to

with log_to(snakemake.log[0]):  # noqa: F821 (snakemake is injected)
    from ldpipe.stages.transport import run_transport  # inside, so an import failure is logged too

    run_transport(
        **snakemake.params.stage,  # noqa: F821
        upo=snakemake.input.upo,  # noqa: F821
        equilibria=snakemake.input.equilibria,  # noqa: F821
        threads=snakemake.threads,  # noqa: F821
        output=snakemake.output[0],  # noqa: F821
    )
