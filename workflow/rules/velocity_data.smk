rule example_velocity_data:
    """The example's ocean currents (an analytic meandering jet by a coast, CF netCDF): the file
    a velocity_data system of the configuration names as results/data/example_currents.nc."""
    input:
        code=library_code("ldpipe.data.example"),
    output:
        f"{RESULTS}/data/example_currents.nc",
    log:
        f"{RESULTS}/logs/example_velocity_data.log",
    conda:
        "../envs/ldpipe.yaml"
    resources:
        mem_mb=1000,
        runtime=5,
    script:
        "../scripts/example_velocity_data.py"
