# Tables 2-4 (GCP fits, fast-compression bounds, LT/RCP/GCP) from the dataset alone, as CSV, Markdown and LaTeX.


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
    params:
        outdir=lambda w, output: os.path.dirname(output[0]),
    log:
        f"{R}/logs/tables.log",
    localrule: True
    shell:
        "spherejam tables {input} --outdir {params.outdir} > {log} 2>&1"
