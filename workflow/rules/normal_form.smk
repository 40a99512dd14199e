# Normal form: one study per entry under `normal_form:` in the configuration, its file
# results/normal_form/<study>.nc and figure results/figures/normal_form_<study>.png. Targets:
# `snakemake normal_form_<study>` for one study, `snakemake normal_form` for all of them.


rule normal_form_study:
    """The saddle's normal form: the flux by energy and order, the NHIM points, the divisors."""
    wildcard_constraints:
        study=_one_of(NORMAL_FORM_STUDIES),
    input:
        unpack(normal_form_inputs),
        code=library_code("ldpipe.stages.normal_form"),
    output:
        f"{RESULTS}/normal_form/{{study}}.nc",
    params:
        stage=normal_form_params,
    log:
        f"{RESULTS}/logs/normal_form/{{study}}.log",
    benchmark:
        f"{RESULTS}/benchmarks/normal_form/{{study}}.tsv"
    conda:
        "../envs/ldpipe.yaml"
    threads: 1
    # A science job with figures after it: before the short jobs, so it does not end a run.
    priority: 1
    resources:
        mem_mb=2000,
        runtime=30,
    script:
        "../scripts/normal_form_study.py"


rule normal_form_figure:
    """Flux against excess energy by every method, relative to the normal form, and against order."""
    wildcard_constraints:
        study=_one_of(NORMAL_FORM_STUDIES),
    input:
        study=f"{RESULTS}/normal_form/{{study}}.nc",
        code=library_code("ldpipe.figures.normal_form"),
    output:
        png=report(
            f"{RESULTS}/figures/normal_form_{{study}}.png",
            caption="../report/normal_form.rst",
            category="Transport",
            labels={"study": "{study}"},
        ),
        pdf=f"{RESULTS}/figures/normal_form_{{study}}.pdf",
    params:
        study=normal_form_params,
    log:
        f"{RESULTS}/logs/figures/normal_form_{{study}}.log",
    benchmark:
        f"{RESULTS}/benchmarks/figures/normal_form_{{study}}.tsv"
    conda:
        "../envs/ldpipe.yaml"
    threads: 1
    resources:
        mem_mb=1000,
        runtime=10,
    script:
        "../scripts/normal_form_figure.py"


for _study in NORMAL_FORM_STUDIES:

    rule:
        name:
            f"normal_form_{_study}"
        input:
            f"{RESULTS}/normal_form/{_study}.nc",
            f"{RESULTS}/figures/normal_form_{_study}.png",
            f"{RESULTS}/figures/normal_form_{_study}.pdf",


rule normal_form:
    """Every normal-form study and its figure."""
    input:
        normal_form_targets(),
