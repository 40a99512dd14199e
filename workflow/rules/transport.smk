# Transport: one study per entry under `transport:` in the configuration, its file
# results/transport/<study>.nc and figure results/figures/transport_<study>.png. Targets:
# `snakemake transport_<study>` for one study, `snakemake transport` for all of them.


rule transport_study:
    """The flux over a saddle at each energy of a study: orbit action, reactive-island area, Monte Carlo."""
    wildcard_constraints:
        study=_one_of(TRANSPORT_STUDIES),
    input:
        upo=transport_upo_file,
        equilibria=transport_equilibria_file,
        code=library_code("ldpipe.stages.transport"),
    output:
        f"{RESULTS}/transport/{{study}}.nc",
    params:
        stage=transport_params,
    log:
        f"{RESULTS}/logs/transport/{{study}}.log",
    benchmark:
        f"{RESULTS}/benchmarks/transport/{{study}}.tsv"
    conda:
        "../envs/ldpipe.yaml"
    threads: STAGE_THREADS
    # A long job: started as soon as it can be, so the short jobs fill the cores at the end.
    priority: 2
    resources:
        mem_mb=2000,
        runtime=60,
    script:
        "../scripts/transport_study.py"


rule transport_figure:
    """Flux against excess energy by every method with the harmonic estimate, and the reactive islands."""
    wildcard_constraints:
        study=_one_of(TRANSPORT_STUDIES),
    input:
        study=f"{RESULTS}/transport/{{study}}.nc",
        code=library_code("ldpipe.figures.transport"),
    output:
        png=report(
            f"{RESULTS}/figures/transport_{{study}}.png",
            caption="../report/transport.rst",
            category="Transport",
            labels={"study": "{study}"},
        ),
        pdf=f"{RESULTS}/figures/transport_{{study}}.pdf",
    params:
        study=transport_params,
    log:
        f"{RESULTS}/logs/figures/transport_{{study}}.log",
    benchmark:
        f"{RESULTS}/benchmarks/figures/transport_{{study}}.tsv"
    conda:
        "../envs/ldpipe.yaml"
    threads: 1
    resources:
        mem_mb=1000,
        runtime=10,
    script:
        "../scripts/transport_figure.py"


for _study in TRANSPORT_STUDIES:

    rule:
        name:
            f"transport_{_study}"
        input:
            f"{RESULTS}/transport/{_study}.nc",
            f"{RESULTS}/figures/transport_{_study}.png",
            f"{RESULTS}/figures/transport_{_study}.pdf",


rule transport:
    """Every transport study and its figure."""
    input:
        transport_targets(),
