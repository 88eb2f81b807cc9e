# Structure of every jammed packing: contacts, rattlers, isostaticity, Q6, Voronoi, pore-size entropy.


rule analyze:
    conda:
        "../envs/spherejam.yaml"
    input:
        PATHS.packing("jammed"),
    output:
        PATHS.packing("structure"),
    log:
        PATHS.log("analyze"),
    resources:
        **job_resources("analyze", EXP.size_of),
    group:
        "analysis"
    shell:
        "spherejam analyze {input} -o {output} > {log} 2>&1"
