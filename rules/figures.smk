# Figures 2-5 and 7 of the paper, plus structure and contact-force figures, each rebuildable alone:
#   snakemake --cores 2 results/figures/fig4.pdf


rule figure:
    input:
        DATASET,
    output:
        png=report(f"{R}/figures/{{name}}.png", caption="../report/{name}.rst", category="Figures"),
        pdf=f"{R}/figures/{{name}}.pdf",
    wildcard_constraints:
        name="|".join(FIGURE_NAMES),
    log:
        f"{R}/logs/figures/{{name}}.log",
    localrule: True
    shell:
        "spherejam figure {wildcards.name} {input} -o {R}/figures/{wildcards.name} > {log} 2>&1"
