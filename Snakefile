# ldpipe: the paper's figures from one `snakemake` command. See README.md.
from snakemake.utils import min_version

min_version("8.0")


configfile: "config.yaml"


include: "workflow/rules/common.smk"


rule all:
    input:
        all_targets(),
    default_target: True


include: "workflow/rules/equilibria.smk"
include: "workflow/rules/ld.smk"
include: "workflow/rules/orbits.smk"
include: "workflow/rules/nhim.smk"
include: "workflow/rules/nhim_sampling.smk"
include: "workflow/rules/accuracy.smk"
include: "workflow/rules/transport.smk"
include: "workflow/rules/saddle_flux.smk"
include: "workflow/rules/velocity_data.smk"
include: "workflow/rules/normal_form.smk"
include: "workflow/rules/figures.smk"  # last: it checks figure names against every rule
