# Poisson seeding: one independent configuration per (protocol, distribution, gamma, replica). A table: or list:
# distribution's file is an input, so editing it reruns everything that depends on it.


rule seed:
    conda:
        "../envs/spherejam.yaml"
    input:
        EXP.psd_files,
    output:
        PATHS.packing("poisson"),
    params:
        n=EXP.size_of,
        phi_nominal=config["phi_nominal"],
        seed=EXP.run_seed("poisson"),
        psd=EXP.psd,
    log:
        PATHS.log("seed"),
    resources:
        **job_resources("seed", EXP.size_of),
    group:
        "generation"
    shell:
        "spherejam seed --n {params.n} --psd {params.psd:q} --seed {params.seed}"
        " --phi-nominal {params.phi_nominal} -o {output} > {log} 2>&1"
