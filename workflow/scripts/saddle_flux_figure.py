"""Snakemake script of the saddle_flux_figure rule: one call to the figure function."""

from ldpipe.logs import log_to

with log_to(snakemake.log[0]):  # noqa: F821 (snakemake is injected)
    from ldpipe.figures.saddle_flux import draw_saddle_flux  # inside, so an import failure is logged too

    draw_saddle_flux(
        study=snakemake.input.study,  # noqa: F821
        png=snakemake.output.png,  # noqa: F821
        pdf=snakemake.output.pdf,  # noqa: F821
    )
