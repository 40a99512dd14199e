rule nhim_study:
    """NHIM points of one study: detected on the LD grids, refined below the grid, compared with their references."""
    wildcard_constraints:
        study=_one_of(NHIM_STUDIES),
    input:
        maps=nhim_map_files,
        equilibria=nhim_equilibria_files,
        references=nhim_reference_files,
        code=library_code("ldpipe.stages.nhim"),
    output:
        f"{RESULTS}/nhim/{{study}}.nc",
    params:
        stage=nhim_params,
    log:
        f"{RESULTS}/logs/nhim/{{study}}.log",
    benchmark:
        f"{RESULTS}/benchmarks/nhim/{{study}}.tsv"
    conda:
        "../envs/ldpipe.yaml"
    threads: 2
    resources:
        mem_mb=nhim_memory_mb,
        runtime=30,
    script:
        "../scripts/nhim_study.py"


rule nhim_validation:
    """The validation tables of every NHIM study; fails when a point is farther from its reference than the tolerance."""
    input:
        studies=nhim_study_files(),
        code=library_code("ldpipe.stages.nhim_validation"),
    output:
        csv=f"{RESULTS}/nhim/validation.csv",
        markdown=f"{RESULTS}/nhim/validation.md",
    params:
        tolerance=config["nhim"]["validation"]["tolerance"],
        residence_ratio=config["nhim"]["validation"]["residence_ratio"],
    log:
        f"{RESULTS}/logs/nhim/validation.log",
    benchmark:
        f"{RESULTS}/benchmarks/nhim/validation.tsv"
    conda:
        "../envs/ldpipe.yaml"
    threads: 1
    resources:
        mem_mb=1000,
        runtime=10,
    script:
        "../scripts/nhim_validation.py"


rule nhim_figure:
    """Detected, refined and reference NHIM points on the LD maps, and the distances of every study."""
    input:
        studies=nhim_study_files(),
        maps=nhim_figure_maps(),
        code=library_code("ldpipe.figures.nhim"),
    output:
        png=report(f"{RESULTS}/figures/nhim_validation.png", caption="../report/nhim_validation.rst", category="NHIM"),
        pdf=f"{RESULTS}/figures/nhim_validation.pdf",
    params:
        tolerance=config["nhim"]["validation"]["tolerance"],
    log:
        f"{RESULTS}/logs/figures/nhim_validation.log",
    benchmark:
        f"{RESULTS}/benchmarks/figures/nhim_validation.tsv"
    conda:
        "../envs/ldpipe.yaml"
    threads: 1
    resources:
        mem_mb=nhim_figure_memory_mb(),
        runtime=10,
    script:
        "../scripts/nhim_figure.py"
