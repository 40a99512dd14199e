"""Snakemake script of the nhim_figure rule: one call to the figure function."""

from ldpipe.logs import log_to

with log_to(snakemake.log[0]):  # noqa: F821 (snakemake is injected)
    from ldpipe.figures.nhim import draw_nhim_validation  # inside, so an import failure is logged too

    draw_nhim_validation(
        studies=list(snakemake.input.studies),  # noqa: F821
        maps=list(snakemake.input.maps),  # noqa: F821
        tolerance=snakemake.params.tolerance,  # noqa: F821
        png=snakemake.output.png,  # noqa: F821
        pdf=snakemake.output.pdf,  # noqa: F821
    )
