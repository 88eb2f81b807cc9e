# CALiPPSO certification of every MLS result: LP jamming with contact forces and a proof of jamming.


rule certify:
    conda:
        "../envs/spherejam.yaml"
    input:
        f"{PACKING}/jammed.h5",
    output:
        packing=f"{PACKING}/calippso.h5",
        summary=f"{PACKING}/calippso.json",
    params:
        # at N = 1e4 one certification takes tens of minutes: a job cut at its time limit resumes from here
        checkpoint=f"{R}/checkpoints/calippso/{RUN}.h5",
    log:
        f"{R}/logs/calippso/{RUN}.log",
    benchmark:
        f"{R}/benchmarks/calippso/{RUN}.tsv"
    resources:
        **resources_for("calippso"),
    group:
        "analysis"
    shell:
        "spherejam calippso {input} --checkpoint {params.checkpoint} -o {output.packing}"
        " --summary {output.summary} > {log} 2>&1"
