# The results database: one xarray dataset (netCDF, h5netcdf engine) with every run's scalars and provenance.


rule experiment_manifest:
    conda:
        "../envs/spherejam.yaml"
    output:
        PATHS.manifest,
    params:
        config=json.dumps(config, sort_keys=True),
    log:
        PATHS.experiment_log("experiment_manifest"),
    localrule: True
    shell:
        "spherejam manifest --config-json {params.config:q} -o {output} > {log} 2>&1"


rule dataset:
    conda:
        "../envs/spherejam.yaml"
    input:
        manifest=PATHS.manifest,
        runs=EXP.dataset_inputs(),
        psd=EXP.psd_inputs(),  # the dataset records each distribution's descriptors, read from its file
    output:
        PATHS.dataset,
    log:
        PATHS.experiment_log("dataset"),
    localrule: True
    shell:
        "spherejam dataset {input.manifest} -o {output} > {log} 2>&1"


# One cell of the experiment (one N, one size distribution) on its own: `snakemake <results>/parts/n<N>/<key>/dataset.nc`
# runs only that cell's packings; `spherejam merge` joins the cells' datasets into the whole run's (docs/cluster.md).
rule dataset_part:
    conda:
        "../envs/spherejam.yaml"
    input:
        manifest=PATHS.manifest,
        runs=lambda w: EXP.dataset_inputs(EXP.part([int(w.n)], [w.dist])),
        psd=EXP.psd_inputs(),
    output:
        PATHS.dataset_part(),
    log:
        PATHS.experiment_log("dataset_n{n}_{dist}"),
    localrule: True
    shell:
        "spherejam dataset {input.manifest} --n {wildcards.n} --distribution {wildcards.dist} -o {output} > {log} 2>&1"
