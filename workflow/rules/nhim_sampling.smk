rule nhim_sampling:
    """The NHIM sampled over a family of slices by continuation; degenerate slices recorded, not written as points."""
    wildcard_constraints:
        study=_one_of(NHIM_SAMPLING_STUDIES),
    input:
        equilibria=nhim_sampling_equilibria_file,
        code=library_code("ldpipe.stages.nhim_sampling"),
    output:
        f"{RESULTS}/nhim_sampling/{{study}}.nc",
    params:
        stage=nhim_sampling_params,
    log:
        f"{RESULTS}/logs/nhim_sampling/{{study}}.log",
    benchmark:
        f"{RESULTS}/benchmarks/nhim_sampling/{{study}}.tsv"
    conda:
        "../envs/ldpipe.yaml"
    threads: 2
    resources:
        mem_mb=1500,
        runtime=60,
    script:
        "../scripts/nhim_sampling.py"
