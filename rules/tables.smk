# Tables 2-4 (GCP fits, fast-compression bands, LT/RCP/GCP) from the dataset alone, as CSV, Markdown and LaTeX, each
# next to the paper's values; comparison.{csv,md}: every cell set against the paper (the report's own section); with a
# ladder of N, finite_size.{csv,md}: the scaling fit and its check (the report's section "Finite-size scaling").


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
        *(  # a ladder of N: the scaling fit and its leave-the-largest-N-out check
            [
                report(
                    PATHS.table("finite_size", "csv"),
                    caption="../report/finite_size.rst",
                    category="Finite-size scaling",
                ),
                PATHS.table("finite_size", "md"),
            ]
            if EXP.several_n
            else []
        ),
    params:
        outdir=lambda w, output: os.path.dirname(output[0]),
    log:
        PATHS.experiment_log("tables"),
    localrule: True
    shell:
        "spherejam tables {input.dataset} --outdir {params.outdir} > {log} 2>&1"
