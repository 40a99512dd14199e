"""Snakemake script of the nhim_study rule: one call to the stage function."""

from ldpipe.logs import log_to

with log_to(snakemake.log[0]):  # noqa: F821 (snakemake is injected)
    from ldpipe.stages.nhim import run_nhim_study  # inside, so an import failure is logged too

    run_nhim_study(
        **snakemake.params.stage,  # noqa: F821
        maps=list(snakemake.input.maps),  # noqa: F821
        equilibria=(snakemake.input.equilibria[0] if snakemake.input.equilibria else None),  # noqa: F821
        reference_files=list(snakemake.input.references),  # noqa: F821
        threads=snakemake.threads,  # noqa: F821
        output=snakemake.output[0],  # noqa: F821
    )
