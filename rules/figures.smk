# Figures 2-5 and 7 of the paper, plus structure and contact-force figures, each rebuildable alone:
#   snakemake --cores 2 results/figures/fig4.pdf


rule figure:
    conda:
        "../envs/spherejam.yaml"
    input:
        DATASET,
    output:
        png=report(f"{R}/figures/{{name}}.png", caption="../report/figure.rst", category="Figures"),
        pdf=f"{R}/figures/{{name}}.pdf",
    wildcard_constraints:
        name="|".join(FIGURE_NAMES),
    params:
        stem=lambda w, output: os.path.splitext(output.png)[0],
    log:
        f"{R}/logs/figures/{{name}}.log",
    localrule: True
    shell:
        "spherejam figure {wildcards.name} {input} -o {params.stem} > {log} 2>&1"
