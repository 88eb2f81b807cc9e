# Poisson seeding: one independent configuration per (protocol, sigma, gamma, replica).


rule seed:
    conda:
        "../envs/spherejam.yaml"
    output:
        f"{PACKING}/poisson.h5",
    params:
        n=EXP.n,
        phi_nominal=config["phi_nominal"],
        seed=run_seed("poisson"),
    log:
        f"{R}/logs/seed/{RUN}.log",
    resources:
        **resources_for("seed"),
    group:
        "generation"
    shell:
        "spherejam seed --n {params.n} --sigma {wildcards.sigma} --seed {params.seed}"
        " --phi-nominal {params.phi_nominal} -o {output} > {log} 2>&1"
