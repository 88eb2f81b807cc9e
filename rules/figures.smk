# Figures 2-7 of the paper, plus structure and contact-force figures, each rebuildable alone:
#   snakemake --cores 2 results/figures/fig4.pdf
# Fig. 1 (a rendered packing) needs OVITO (pip install 'spherejam[render]'); it is part of `all` only with
# figures.render_fig1: true, and can always be asked for by name: snakemake --cores 1 results/figures/fig1.png
FIG1 = expand(f"{R}/figures/fig1.{{ext}}", ext=["png", "pdf"]) if config["figures"]["render_fig1"] else []


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


rule render_fig1:
    conda:
        "../envs/spherejam.yaml"
    input:
        str(EXP.path(EXP.figure1_run(), "jammed")),
    output:
        png=report(f"{R}/figures/fig1.png", caption="../report/fig1.rst", category="Figures"),
        pdf=f"{R}/figures/fig1.pdf",
    params:
        sigma=EXP.figure1_run().sigma,
    log:
        f"{R}/logs/figures/fig1.log",
    localrule: True
    shell:
        "spherejam render {input} --sigma {params.sigma} -o {output.png} -o {output.pdf} > {log} 2>&1"
