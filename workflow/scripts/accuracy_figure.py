"""Snakemake script of the accuracy_figure rule: one call to the drawing function."""

from ldpipe.logs import log_to

with log_to(snakemake.log[0]):  # noqa: F821 (snakemake is injected)
    from ldpipe.figures.accuracy import draw_accuracy_cost  # inside, so an import failure is logged too

    draw_accuracy_cost(snakemake.input.data, png=snakemake.output.png, pdf=snakemake.output.pdf)  # noqa: F821
