# The results database: one xarray dataset (netCDF, h5netcdf engine) with every run's scalars and provenance.


def dataset_inputs(wildcards):
    files = []
    for run in EXP.runs():
        files += [str(EXP.path(run, "initial")), str(EXP.path(run, "jammed"))]
        if config["analysis"]["enabled"]:
            files.append(str(EXP.path(run, "structure")))
        if config["calippso"]["enabled"]:
            files.append(str(EXP.path(run, "calippso")))
    files += [str(EXP.grid_path(g)) for g in EXP.grid_runs()]
    return files


rule experiment_manifest:
    output:
        f"{R}/experiment.json",
    params:
        config_hash=config_hash(config),
    log:
        f"{R}/logs/experiment_manifest.log",
    localrule: True
    run:
        from spherejam.dataset import write_manifest

        write_manifest(config, output[0])


rule dataset:
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
