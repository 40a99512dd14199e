rule ld_tile:
    """One band of rows of an LD map, integrated forward and backward."""
    input:
        equilibria=ld_equilibria_file,
        velocity_data=ld_velocity_data_file,
        code=library_code("ldpipe.stages.ld"),
    output:
        temp(f"{RESULTS}/ld/{{map}}/tile-{{tile}}-of-{{tiles}}.nc"),
    params:
        stage=ld_params,
    log:
        f"{RESULTS}/logs/ld/{{map}}/tile-{{tile}}-of-{{tiles}}.log",
    benchmark:
        f"{RESULTS}/benchmarks/ld/{{map}}/tile-{{tile}}-of-{{tiles}}.tsv"
    conda:
        "../envs/ldpipe.yaml"
    threads: STAGE_THREADS
    # After the longest jobs (priority 2), before the short ones that read the maps.
    priority: 1
    resources:
        mem_mb=ld_tile_memory_mb,
        runtime=ld_tile_runtime_min,
    script:
        "../scripts/ld_tile.py"


rule ld_map:
    """An LD map of one tile, computed and finished in one job (no tile file, no gather)."""
    input:
        equilibria=ld_equilibria_file,
        velocity_data=ld_velocity_data_file,
        code=library_code("ldpipe.stages.ld"),
    output:
        f"{RESULTS}/ld/{{map}}.nc",
    wildcard_constraints:
        map=_one_of(ONE_TILE_MAPS),
    params:
        stage=ld_params,
    log:
        f"{RESULTS}/logs/ld/{{map}}/map.log",
    benchmark:
        f"{RESULTS}/benchmarks/ld/{{map}}/map.tsv"
    conda:
        "../envs/ldpipe.yaml"
    threads: STAGE_THREADS
    priority: 1  # as a tile's
    resources:
        mem_mb=ld_map_memory_mb,
        runtime=ld_map_runtime_min,
    script:
        "../scripts/ld_map.py"


rule ld_gather:
    """An LD map from its tiles."""
    input:
        tiles=ld_tile_files,
        code=library_code("ldpipe.stages.ld"),
    output:
        f"{RESULTS}/ld/{{map}}.nc",
    wildcard_constraints:
        map=_one_of(TILED_MAPS),
    log:
        f"{RESULTS}/logs/ld/{{map}}/gather.log",
    benchmark:
        f"{RESULTS}/benchmarks/ld/{{map}}/gather.tsv"
    conda:
        "../envs/ldpipe.yaml"
    threads: 1
    resources:
        mem_mb=ld_gather_memory_mb,
        runtime=10,
    script:
        "../scripts/ld_gather.py"


rule structures:
    """An LD map's structures: its singular curves and FTLE ridges as polylines."""
    input:
        ld_map=f"{RESULTS}/ld/{{map}}.nc",
        code=library_code("ldpipe.stages.structures"),
    output:
        f"{RESULTS}/structures/{{map}}.nc",
    wildcard_constraints:
        map=_one_of(STRUCTURE_MAPS),
    params:
        stage=structures_params,
    log:
        f"{RESULTS}/logs/structures/{{map}}.log",
    benchmark:
        f"{RESULTS}/benchmarks/structures/{{map}}.tsv"
    conda:
        "../envs/ldpipe.yaml"
    threads: 1
    resources:
        mem_mb=ld_gather_memory_mb,
        runtime=10,
    script:
        "../scripts/structures.py"

