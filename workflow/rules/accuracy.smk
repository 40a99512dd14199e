# Accuracy against cost: the work-precision measurement and its figure. Runs only when the
# configuration has an `accuracy_cost:` section. The measurement times the engine with as many
# threads as an LD tile job (STAGE_THREADS, capped at --cores; the default profile sets both to
# one, so other jobs run beside it); the threads used and the machine's load go into the file. For a
# clean remeasurement run it alone: `snakemake --forcerun accuracy_cost results/figures/accuracy_cost.png`.


rule accuracy_cost:
    """LD error, energy drift and orbit closure against wall time, for a ladder of numerical settings."""
    input:
        equilibria=accuracy_equilibria_files,
        engines=accuracy_engine_files,
        code=library_code("ldpipe.stages.accuracy"),
    output:
        data=f"{RESULTS}/accuracy/accuracy_cost.nc",
        table=report(
            f"{RESULTS}/accuracy/accuracy_cost.md",
            caption="../report/accuracy_table.rst",
            category="Accuracy and cost",
        ),
    params:
        stage=accuracy_params,
    log:
        f"{RESULTS}/logs/accuracy/accuracy_cost.log",
    benchmark:
        f"{RESULTS}/benchmarks/accuracy/accuracy_cost.tsv"
    conda:
        "../envs/ldpipe.yaml"
    threads: STAGE_THREADS
    # The longest job of a run: started as soon as it can be, so the short jobs fill the cores at the end.
    priority: 2
    resources:
        mem_mb=2000,
        runtime=30,
    script:
        "../scripts/accuracy_cost.py"


rule accuracy_figure:
    """The work-precision diagram: error against wall time, one line per scheme, defaults marked."""
    input:
        data=f"{RESULTS}/accuracy/accuracy_cost.nc",
        code=library_code("ldpipe.figures.accuracy"),
    output:
        png=report(
            f"{RESULTS}/figures/accuracy_cost.png",
            caption="../report/accuracy_cost.rst",
            category="Accuracy and cost",
        ),
        pdf=f"{RESULTS}/figures/accuracy_cost.pdf",
    log:
        f"{RESULTS}/logs/figures/accuracy_cost.log",
    benchmark:
        f"{RESULTS}/benchmarks/figures/accuracy_cost.tsv"
    conda:
        "../envs/ldpipe.yaml"
    threads: 1
    resources:
        mem_mb=1000,
        runtime=10,
    script:
        "../scripts/accuracy_figure.py"


rule accuracy_engine:
    """Compile one engine module of the LD ladder before the measurement, a job per module so the cores share them."""
    input:
        equilibria=accuracy_equilibria_files,
        code=library_code("ldpipe.stages.accuracy"),
    output:
        f"{RESULTS}/accuracy/engines/{{engine}}.txt",
    params:
        stage=accuracy_engine_params,
    wildcard_constraints:
        engine=_one_of(accuracy_engines()),
    log:
        f"{RESULTS}/logs/accuracy/engines/{{engine}}.log",
    benchmark:
        f"{RESULTS}/benchmarks/accuracy/engines/{{engine}}.tsv"
    conda:
        "../envs/ldpipe.yaml"
    threads: 1
    # First, so that accuracy_cost (priority 2) can start early.
    priority: 2
    resources:
        mem_mb=1000,
        runtime=10,
    script:
        "../scripts/accuracy_engine.py"
