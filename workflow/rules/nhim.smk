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


rule nhim_orbit_validation:
    """Every NHIM crossing of slices through points of periodic orbits, refined; degenerate slices recorded as such."""
    wildcard_constraints:
        study=_one_of(NHIM_ORBIT_STUDIES),
    input:
        orbits=nhim_orbit_family_files,
        equilibria=nhim_orbit_equilibria_file,
        code=library_code("ldpipe.stages.nhim_orbits"),
    output:
        f"{RESULTS}/nhim/orbits/{{study}}.nc",
    params:
        stage=nhim_orbit_params,
    log:
        f"{RESULTS}/logs/nhim/orbits/{{study}}.log",
    benchmark:
        f"{RESULTS}/benchmarks/nhim/orbits/{{study}}.tsv"
    conda:
        "../envs/ldpipe.yaml"
    threads: 2
    # A science job with figures after it: before the short jobs, so it does not end a run.
    priority: 1
    resources:
        mem_mb=1500,
        runtime=60,
    script:
        "../scripts/nhim_orbit_validation.py"


rule nhim_validation:
    """The validation tables of every NHIM study and orbit validation; fails when a point is farther from its
    reference than the tolerance, or a slice through an orbit has no refined crossing at the orbit point."""
    input:
        studies=nhim_study_files(),
        orbit_studies=nhim_orbit_files(),
        code=library_code("ldpipe.stages.nhim_validation"),
    output:
        csv=f"{RESULTS}/nhim/validation.csv",
        markdown=f"{RESULTS}/nhim/validation.md",
        orbits_csv=f"{RESULTS}/nhim/validation_orbits.csv",
        orbits_markdown=f"{RESULTS}/nhim/validation_orbits.md",
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
