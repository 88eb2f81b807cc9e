# CALiPPSO certification of every MLS result: LP jamming with contact forces and a proof of jamming.


rule calippso:
    conda:
        "../envs/spherejam.yaml"
    input:
        PATHS.packing("jammed"),
    output:
        packing=PATHS.packing("calippso_packing"),
        summary=PATHS.packing("calippso"),
    params:
        # at N = 1e4 one certification takes tens of minutes: a job cut at its time limit resumes from here
        checkpoint=PATHS.checkpoint("calippso"),
        # calippso.interior_steps forces the LP path; absent, the package chooses it by N
        options=EXP.calippso_options(),
    log:
        PATHS.log("calippso"),
    benchmark:
        PATHS.benchmark("calippso")
    threads: EXP.calippso_threads
    resources:
        **job_resources("calippso", EXP.size_of, threads=EXP.calippso_threads,
                        interior_steps=EXP.calippso_interior_steps),
    group:
        "analysis"
    shell:
        "spherejam calippso {input} --threads {threads} --checkpoint {params.checkpoint} --discard-stale-checkpoint"
        " {params.options}"
        " -o {output.packing}"
        " --summary {output.summary} > {log} 2>&1"
