# The results database: one xarray dataset (netCDF, h5netcdf engine) with every run's scalars and provenance.


rule experiment_manifest:
    conda:
        "../envs/spherejam.yaml"
    output:
        f"{R}/experiment.json",
    params:
        config=json.dumps(config, sort_keys=True),
    log:
        f"{R}/logs/experiment_manifest.log",
    localrule: True
    shell:
        "spherejam manifest --config-json {params.config:q} -o {output} > {log} 2>&1"


rule dataset:
    conda:
        "../envs/spherejam.yaml"
    input:
        manifest=f"{R}/experiment.json",
        runs=dataset_inputs,
    output:
        DATASET,
    log:
        f"{R}/logs/dataset.log",
    localrule: True
    shell:
        "spherejam dataset {input.manifest} -o {output} > {log} 2>&1"
