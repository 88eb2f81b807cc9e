# The paper's parameter-validation grid (Section IV.B, Fig. 3): MLS with every (decrease factor, initial rate,
# final rate) on selected LS packings at sigma = 0 and 0.3.


rule mls_grid:
    conda:
        "../envs/spherejam.yaml"
    input:
        PATHS.packing("initial"),
    output:
        PATHS.grid(),
    wildcard_constraints:
        protocol="ls",
    params:
        seed=EXP.grid_seed,
        checkpoint=PATHS.checkpoint("mls_grid"),
        p_max=EXP.mls["p_max"],
        max_eq=EXP.mls["max_equilibration_windows"],
        options=EXP.mls_options(),
    log:
        PATHS.log("mls_grid"),
    benchmark:
        PATHS.benchmark("mls_grid")
    resources:
        **job_resources("mls", EXP.size_of, lambda w: GridRun.from_wildcards(w).ladder, load=EXP.load_of),
    shell:
        mls_command("{wildcards.g0}", "{wildcards.factor}", "{wildcards.gf}")
