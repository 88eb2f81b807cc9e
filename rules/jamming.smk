# The closest-jamming search (MLS, the paper's modified LS) of every generated packing: Figs. 2b and 2d.


rule mls:
    conda:
        "../envs/spherejam.yaml"
    input:
        PATHS.packing("initial"),
    output:
        PATHS.packing("jammed"),
    params:
        seed=EXP.run_seed("mls"),
        checkpoint=PATHS.checkpoint("mls"),
        initial_rate=EXP.mls["initial_rate"],
        decrease_factor=EXP.mls["decrease_factor"],
        final_rate=EXP.mls["final_rate"],
        p_max=EXP.mls["p_max"],
        max_eq=EXP.mls["max_equilibration_windows"],
        options=EXP.mls_options(),
    log:
        PATHS.log("mls"),
    benchmark:
        PATHS.benchmark("mls")
    resources:
        **job_resources("mls", EXP.size_of, lambda w: EXP.mls_ladder, load=EXP.load_of),
    shell:
        mls_command("{params.initial_rate}", "{params.decrease_factor}", "{params.final_rate}")
