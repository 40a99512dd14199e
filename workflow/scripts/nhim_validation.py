"""Snakemake script of the nhim_validation rule: one call to the stage function (raises on a failed check)."""

from ldpipe.logs import log_to

with log_to(snakemake.log[0]):  # noqa: F821 (snakemake is injected)
    from ldpipe.stages.nhim_validation import run_nhim_validation  # inside, so an import failure is logged too

    run_nhim_validation(
        studies=list(snakemake.input.studies),  # noqa: F821
        csv_output=snakemake.output.csv,  # noqa: F821
        markdown_output=snakemake.output.markdown,  # noqa: F821
        tolerance=snakemake.params.tolerance,  # noqa: F821
        residence_ratio=snakemake.params.residence_ratio,  # noqa: F821
        orbit_studies=list(snakemake.input.orbit_studies),  # noqa: F821
        orbits_csv_output=snakemake.output.orbits_csv,  # noqa: F821
        orbits_markdown_output=snakemake.output.orbits_markdown,  # noqa: F821
    )
