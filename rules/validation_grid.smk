# The paper's parameter-validation grid (Section IV.B, Fig. 3): MLS with every (decrease factor, initial rate,
# final rate) on selected LS packings at sigma = 0 and 0.3.


rule jam_validation_grid:
    conda:
        "../envs/spherejam.yaml"
    input:
        f"{R}/packings/ls/sigma{{sigma}}/rate{{rate}}/r{{replica}}/initial.h5",
    output:
        f"{R}/validation/{GRID_RUN}.h5",
    params:
        seed=lambda w: parse_run("ls", w.sigma, w.rate, w.replica).seed(
            EXP.master_seed, f"grid-{w.factor}-{w.g0}-{w.gf}"
        ),
        checkpoint=f"{R}/checkpoints/validation/{GRID_RUN}.h5",
        p_max=MLS["p_max"],
        max_eq=MLS["max_equilibration_windows"],
        options=mls_options(),
    log:
        f"{R}/logs/validation/{GRID_RUN}.log",
    benchmark:
        f"{R}/benchmarks/validation/{GRID_RUN}.tsv"
    resources:
        **resources_for(
            "mls",
            lambda w: {"initial_rate": float(w.g0), "decrease_factor": float(w.factor), "final_rate": float(w.gf)},
        ),
    shell:
        "spherejam mls {input} --initial-rate {wildcards.g0} --decrease-factor {wildcards.factor}"
        " --final-rate {wildcards.gf} --p-max {params.p_max} --max-equilibration-windows {params.max_eq}"
        " --seed {params.seed} {params.options} --checkpoint {params.checkpoint} -o {output} > {log} 2>&1"
