# CALiPPSO certification of every MLS result: LP jamming with contact forces and a proof of jamming.


rule certify:
    conda:
        "../envs/spherejam.yaml"
    input:
        f"{PACKING}/jammed.h5",
    output:
        packing=f"{PACKING}/calippso.h5",
        summary=f"{PACKING}/calippso.json",
    log:
        f"{R}/logs/calippso/{RUN}.log",
    benchmark:
        f"{R}/benchmarks/calippso/{RUN}.tsv"
    resources:
        **resources_for("calippso"),
    group:
        "analysis"
    shell:
        "spherejam calippso {input} -o {output.packing} --summary {output.summary} > {log} 2>&1"
