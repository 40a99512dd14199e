"""Snakemake script of the normal_form_study rule: one call to the stage function."""

from ldpipe.logs import log_to

with log_to(snakemake.log[0]):  # noqa: F821 (snakemake is injected)
    from ldpipe.stages.normal_form import run_normal_form  # inside, so an import failure is logged too

    run_normal_form(
        **snakemake.params.stage,  # noqa: F821
        equilibria=snakemake.input.equilibria,  # noqa: F821
        transport_file=snakemake.input.get("transport"),  # noqa: F821
        saddle_flux_file=snakemake.input.get("saddle_flux"),  # noqa: F821
        output=snakemake.output[0],  # noqa: F821
    )
