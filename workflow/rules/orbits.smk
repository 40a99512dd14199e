rule upo:
    """A Lyapunov family of unstable periodic orbits at its target energies, with their stability."""
    input:
        equilibria=upo_equilibria_file,
        code=library_code("ldpipe.stages.upo"),
    output:
        f"{RESULTS}/upo/{{family}}.nc",
    params:
        stage=upo_params,
    log:
        f"{RESULTS}/logs/upo/{{family}}.log",
    benchmark:
        f"{RESULTS}/benchmarks/upo/{{family}}.tsv"
    conda:
        "../envs/ldpipe.yaml"
    threads: 1
    resources:
        mem_mb=1000,
        runtime=30,
    script:
        "../scripts/upo.py"


rule manifolds:
    """Stable and unstable manifolds of one periodic orbit, and the curves where they cut a section."""
    input:
        upo=manifold_upo_file,
        code=library_code("ldpipe.stages.manifolds"),
    output:
        f"{RESULTS}/manifolds/{{manifold}}.nc",
    params:
        stage=manifold_params,
    log:
        f"{RESULTS}/logs/manifolds/{{manifold}}.log",
    benchmark:
        f"{RESULTS}/benchmarks/manifolds/{{manifold}}.tsv"
    conda:
        "../envs/ldpipe.yaml"
    threads: STAGE_THREADS
    resources:
        mem_mb=manifold_memory_mb,
        runtime=30,
    script:
        "../scripts/manifolds.py"


rule map_manifolds:
    """Stable and unstable manifolds of the saddle fixed points of a discrete map, from fundamental segments."""
    input:
        equilibria=map_manifold_equilibria_file,
        code=library_code("ldpipe.stages.manifolds"),
    output:
        f"{RESULTS}/manifolds/{{map_manifold}}.nc",
    params:
        stage=map_manifold_params,
    log:
        f"{RESULTS}/logs/manifolds/{{map_manifold}}.log",
    benchmark:
        f"{RESULTS}/benchmarks/manifolds/{{map_manifold}}.tsv"
    conda:
        "../envs/ldpipe.yaml"
    threads: 1
    resources:
        mem_mb=map_manifold_memory_mb,
        runtime=30,
    script:
        "../scripts/map_manifolds.py"


rule poincare:
    """A Poincaré surface of section: crossings of many trajectories on one energy surface."""
    input:
        equilibria=poincare_equilibria_file,
        code=library_code("ldpipe.stages.poincare"),
    output:
        f"{RESULTS}/poincare/{{section}}.nc",
    params:
        stage=poincare_params,
    log:
        f"{RESULTS}/logs/poincare/{{section}}.log",
    benchmark:
        f"{RESULTS}/benchmarks/poincare/{{section}}.tsv"
    conda:
        "../envs/ldpipe.yaml"
    threads: STAGE_THREADS
    resources:
        mem_mb=poincare_memory_mb,
        runtime=60,
    script:
        "../scripts/poincare.py"
