# Tables 2-4 (GCP fits, fast-compression bands, LT/RCP/GCP) from the dataset alone, as CSV, Markdown and LaTeX, each
# next to the paper's values; comparison.{csv,md}: every cell set against the paper (the report's own section).


rule tables:
    conda:
        "../envs/spherejam.yaml"
    input:
        DATASET,
    output:
        report(
            expand(f"{R}/tables/{{name}}.csv", name=TABLE_NAMES),
            caption="../report/tables.rst",
            category="Tables",
        ),
        expand(f"{R}/tables/{{name}}.{{ext}}", name=TABLE_NAMES, ext=["md", "tex"]),
        report(f"{R}/tables/comparison.csv", caption="../report/comparison.rst", category="Comparison with the paper"),
        f"{R}/tables/comparison.md",
    params:
        outdir=lambda w, output: os.path.dirname(output[0]),
    log:
        f"{R}/logs/tables.log",
    localrule: True
    shell:
        "spherejam tables {input} --outdir {params.outdir} > {log} 2>&1"
