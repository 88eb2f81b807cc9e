# Poisson seeding: one independent configuration per (protocol, sigma, gamma, replica).


rule seed:
    conda:
        "../envs/spherejam.yaml"
    output:
        PATHS.packing("poisson"),
    params:
        n=EXP.n,
        phi_nominal=config["phi_nominal"],
        seed=EXP.run_seed("poisson"),
    log:
        PATHS.log("seed"),
    resources:
        **job_resources("seed", EXP.n),
    group:
        "generation"
    shell:
        "spherejam seed --n {params.n} --sigma {wildcards.sigma} --seed {params.seed}"
        " --phi-nominal {params.phi_nominal} -o {output} > {log} 2>&1"
