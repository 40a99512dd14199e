"""Snakemake script of the example_velocity_data rule: one call to the generator."""

from ldpipe.logs import log_to

with log_to(snakemake.log[0]):  # noqa: F821 (snakemake is injected)
    from ldpipe.data.example import write_example

    write_example(snakemake.output[0])  # noqa: F821
