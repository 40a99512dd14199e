"""Snakemake script of the figure rules: one call to the stage function."""

from ldpipe.logs import log_to

with log_to(snakemake.log[0]):  # noqa: F821 (snakemake is injected)
    from ldpipe.stages.figures import run_figure  # inside, so an import failure is logged too

    inputs = {role: snakemake.input[role] for role in snakemake.input.keys() if role != "code"}  # noqa: F821
    run_figure(
        **snakemake.params.figure,  # noqa: F821
        inputs=inputs,
        png=snakemake.output.png,  # noqa: F821
        pdf=snakemake.output.pdf,  # noqa: F821
        gif=getattr(snakemake.output, "gif", None),  # noqa: F821 (animated kinds only)
    )
