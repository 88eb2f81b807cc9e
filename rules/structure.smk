# Structure of every jammed packing: contacts, rattlers, isostaticity, Q6, Voronoi, pore-size entropy.


rule analyze:
    conda:
        "../envs/spherejam.yaml"
    input:
        f"{PACKING}/jammed.h5",
    output:
        f"{PACKING}/structure.json",
    log:
        f"{R}/logs/structure/{RUN}.log",
    resources:
        **resources_for("analyze"),
    group:
        "analysis"
    shell:
        "spherejam analyze {input} -o {output} > {log} 2>&1"
