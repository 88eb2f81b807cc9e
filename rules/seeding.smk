# Poisson seeding: one independent configuration per (protocol, distribution, gamma, replica). A table: or list:
# distribution's file is an input, so editing it reruns everything that depends on it.


rule seed:
    conda:
        "../envs/spherejam.yaml"
    input:
        EXP.psd_files,
    output:
        PATHS.packing("poisson"),
    wildcard_constraints:
        container=EXP.container_pattern(periodic_cube=True),
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


# Seeding in a container (docs/containers.md): centres inside the walls; the lengths the spec leaves free are sized
# for the expected final packing fraction (the seed command's default), not for phi_nominal, which sets the length
# unit of the periodic cube only. A rule of its own, so that the periodic cube's seeding stays as it was.
rule seed_in_container:
    conda:
        "../envs/spherejam.yaml"
    input:
        EXP.psd_files,
    output:
        PATHS.packing("poisson", container=True),
    wildcard_constraints:
        container=EXP.container_pattern(periodic_cube=False),
    params:
        n=EXP.size_of,
        seed=EXP.run_seed("poisson"),
        psd=EXP.psd,
        container=EXP.seed_container,
    log:
        PATHS.log("seed", container=True),
    resources:
        **job_resources("seed", EXP.size_of),
    group:
        "generation"
    shell:
        "spherejam seed --n {params.n} --psd {params.psd:q} --seed {params.seed}"
        " --container {params.container:q} -o {output} > {log} 2>&1"
