# Closest jamming (MLS) of every generated packing: Figs. 2b and 2d.

MLS = config["mls"]


rule jam:
    conda:
        "../envs/spherejam.yaml"
    input:
        f"{PACKING}/initial.h5",
    output:
        f"{PACKING}/jammed.h5",
    params:
        seed=run_seed("mls"),
        checkpoint=f"{R}/checkpoints/mls/{RUN}.h5",
        initial_rate=MLS["initial_rate"],
        decrease_factor=MLS["decrease_factor"],
        final_rate=MLS["final_rate"],
        p_max=MLS["p_max"],
        max_eq=MLS["max_equilibration_windows"],
        options=mls_options(),
    log:
        f"{R}/logs/mls/{RUN}.log",
    benchmark:
        f"{R}/benchmarks/mls/{RUN}.tsv"
    resources:
        **resources_for(
            "mls",
            lambda w: {k: MLS[k] for k in ("initial_rate", "decrease_factor", "final_rate")},
        ),
    shell:
        "spherejam mls {input} --initial-rate {params.initial_rate} --decrease-factor {params.decrease_factor}"
        " --final-rate {params.final_rate} --p-max {params.p_max} --max-equilibration-windows {params.max_eq}"
        " --seed {params.seed} {params.options} --checkpoint {params.checkpoint} -o {output} > {log} 2>&1"
