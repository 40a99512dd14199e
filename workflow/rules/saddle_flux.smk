# Saddle flux: one study per entry under `saddle_flux:` in the configuration, its file
# results/saddle_flux/<study>.nc and figure results/figures/saddle_flux_<study>.png. Targets:
# `snakemake saddle_flux_<study>` for one study, `snakemake saddle_flux` for all of them.


rule saddle_flux_study:
    """Monte Carlo reactive flux through the dividing surface at a saddle, against the harmonic estimate."""
    wildcard_constraints:
        study=_one_of(SADDLE_FLUX_STUDIES),
    input:
        equilibria=saddle_flux_equilibria_file,
        code=library_code("ldpipe.stages.saddle_flux"),
    output:
        f"{RESULTS}/saddle_flux/{{study}}.nc",
    params:
        stage=saddle_flux_params,
    log:
        f"{RESULTS}/logs/saddle_flux/{{study}}.log",
    benchmark:
        f"{RESULTS}/benchmarks/saddle_flux/{{study}}.tsv"
    conda:
        "../envs/ldpipe.yaml"
    threads: STAGE_THREADS
    # A science job with figures after it: before the short jobs, so it does not end a run.
    priority: 1
    resources:
        mem_mb=2000,
        runtime=60,
    script:
        "../scripts/saddle_flux_study.py"


rule saddle_flux_figure:
    """Flux against excess energy: Monte Carlo, one-way flux and the harmonic estimate, and their ratio."""
    wildcard_constraints:
        study=_one_of(SADDLE_FLUX_STUDIES),
    input:
        study=f"{RESULTS}/saddle_flux/{{study}}.nc",
        code=library_code("ldpipe.figures.saddle_flux"),
    output:
        png=report(
            f"{RESULTS}/figures/saddle_flux_{{study}}.png",
            caption="../report/saddle_flux.rst",
            category="Transport",
            labels={"study": "{study}"},
        ),
        pdf=f"{RESULTS}/figures/saddle_flux_{{study}}.pdf",
    params:
        study=saddle_flux_params,
    log:
        f"{RESULTS}/logs/figures/saddle_flux_{{study}}.log",
    benchmark:
        f"{RESULTS}/benchmarks/figures/saddle_flux_{{study}}.tsv"
    conda:
        "../envs/ldpipe.yaml"
    threads: 1
    resources:
        mem_mb=1000,
        runtime=10,
    script:
        "../scripts/saddle_flux_figure.py"


for _study in SADDLE_FLUX_STUDIES:

    rule:
        name:
            f"saddle_flux_{_study}"
        input:
            f"{RESULTS}/saddle_flux/{_study}.nc",
            f"{RESULTS}/figures/saddle_flux_{_study}.png",
            f"{RESULTS}/figures/saddle_flux_{_study}.pdf",


rule saddle_flux:
    """Every saddle-flux study and its figure."""
    input:
        saddle_flux_targets(),
