# Packing generation for every (sigma, gamma): Lubachevsky-Stillinger (Fig. 2a) and force-biased (Fig. 2c).


rule ls:
    conda:
        "../envs/spherejam.yaml"
    input:
        PATHS.packing("poisson"),
    output:
        PATHS.packing("initial"),
    wildcard_constraints:
        protocol="ls",
    params:
        seed=EXP.run_seed("ls"),
        p_max=config["ls"]["p_max"],
        checkpoint=PATHS.checkpoint("ls"),
    log:
        PATHS.log("ls"),
    benchmark:
        PATHS.benchmark("ls")
    resources:
        **job_resources("ls", EXP.size_of, load=EXP.load_of),
    shell:
        "spherejam ls {input} --rate {wildcards.rate} --p-max {params.p_max} --seed {params.seed}"
        " --checkpoint {params.checkpoint} --discard-stale-checkpoint -o {output} > {log} 2>&1"


rule fb:
    conda:
        "../envs/spherejam.yaml"
    input:
        PATHS.packing("poisson"),
    output:
        PATHS.packing("initial"),
    wildcard_constraints:
        protocol="fb",
    params:
        phi_nominal=EXP.fb_options(),
        checkpoint=PATHS.checkpoint("fb"),
    log:
        PATHS.log("fb"),
    benchmark:
        PATHS.benchmark("fb")
    resources:
        **job_resources("fb", EXP.size_of),
    group:
        "generation"
    shell:
        "spherejam fb {input} --rate {wildcards.rate} {params.phi_nominal}"
        " --checkpoint {params.checkpoint} --discard-stale-checkpoint -o {output} > {log} 2>&1"
