# Tables 2-4 (GCP fits, fast-compression bands, LT/RCP/GCP) from the dataset alone, as CSV, Markdown and LaTeX, each
# next to the paper's values; comparison.{csv,md}: every cell set against the paper (the report's own section).


rule tables:
    conda:
        "../envs/spherejam.yaml"
    input:
        dataset=PATHS.dataset,
        psd=EXP.psd_inputs(),  # Table 4's models read the distributions' files
    output:
        report(PATHS.tables(["csv"]), caption="../report/tables.rst", category="Tables"),
        PATHS.tables(["md", "tex"]),
        report(
            PATHS.table("comparison", "csv"), caption="../report/comparison.rst", category="Comparison with the paper"
        ),
        PATHS.table("comparison", "md"),
    params:
        outdir=lambda w, output: os.path.dirname(output[0]),
    log:
        PATHS.experiment_log("tables"),
    localrule: True
    shell:
        "spherejam tables {input.dataset} --outdir {params.outdir} > {log} 2>&1"
