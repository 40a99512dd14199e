"""Snakemake script of the normal_form_figure rule: one call to the figure function."""

from ldpipe.logs import log_to

with log_to(snakemake.log[0]):  # noqa: F821 (snakemake is injected)
    from ldpipe.figures.normal_form import draw_normal_form  # inside, so an import failure is logged too

    draw_normal_form(
        study=snakemake.input.study,  # noqa: F821
        png=snakemake.output.png,  # noqa: F821
        pdf=snakemake.output.pdf,  # noqa: F821
    )
