# Packing generation for every (sigma, gamma): Lubachevsky-Stillinger (Fig. 2a) and force-biased (Fig. 2c).


rule generate_ls:
    conda:
        "../envs/spherejam.yaml"
    input:
        f"{R}/packings/ls/sigma{{sigma}}/rate{{rate}}/r{{replica}}/poisson.h5",
    output:
        f"{R}/packings/ls/sigma{{sigma}}/rate{{rate}}/r{{replica}}/initial.h5",
    params:
        seed=lambda w: parse_run("ls", w.sigma, w.rate, w.replica).seed(EXP.master_seed, "ls"),
        p_max=config["ls"]["p_max"],
        checkpoint=f"{R}/checkpoints/ls/sigma{{sigma}}/rate{{rate}}/r{{replica}}.h5",
    log:
        f"{R}/logs/ls/sigma{{sigma}}/rate{{rate}}/r{{replica}}.log",
    benchmark:
        f"{R}/benchmarks/ls/sigma{{sigma}}/rate{{rate}}/r{{replica}}.tsv"
    resources:
        **resources_for("ls"),
    shell:
        "spherejam ls {input} --rate {wildcards.rate} --p-max {params.p_max} --seed {params.seed}"
        " --checkpoint {params.checkpoint} -o {output} > {log} 2>&1"


rule generate_fb:
    conda:
        "../envs/spherejam.yaml"
    input:
        f"{R}/packings/fb/sigma{{sigma}}/rate{{rate}}/r{{replica}}/poisson.h5",
    output:
        f"{R}/packings/fb/sigma{{sigma}}/rate{{rate}}/r{{replica}}/initial.h5",
    params:
        phi_nominal=(
            "" if config["fb"].get("phi_nominal") is None else f"--phi-nominal {config['fb']['phi_nominal']}"
        ),
        checkpoint=f"{R}/checkpoints/fb/sigma{{sigma}}/rate{{rate}}/r{{replica}}.h5",
    log:
        f"{R}/logs/fb/sigma{{sigma}}/rate{{rate}}/r{{replica}}.log",
    benchmark:
        f"{R}/benchmarks/fb/sigma{{sigma}}/rate{{rate}}/r{{replica}}.tsv"
    resources:
        **resources_for("fb"),
    group:
        "generation"
    shell:
        "spherejam fb {input} --rate {wildcards.rate} {params.phi_nominal}"
        " --checkpoint {params.checkpoint} -o {output} > {log} 2>&1"
