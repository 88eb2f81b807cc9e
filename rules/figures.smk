# Figures 2-7 of the paper, plus structure and contact-force figures (and with containers, the figures containers and
# profiles: docs/containers.md §9), each rebuildable alone:
#   snakemake --cores 2 results/figures/fig4.pdf
# Fig. 1 (a rendered packing) needs OVITO (pip install 'spherejam[render]'); it is part of `all` only with
# figures.render_fig1: true, and can always be asked for by name: snakemake --cores 1 results/figures/fig1.png


rule figure:
    conda:
        "../envs/spherejam.yaml"
    input:
        dataset=PATHS.dataset,
        psd=EXP.psd_inputs(),  # Fig. 5's models read the distributions' files
    output:
        png=report(PATHS.figure("png"), caption="../report/figure.rst", category="Figures"),
        pdf=PATHS.figure("pdf"),
    wildcard_constraints:
        name="|".join(FIGURE_NAMES),
    params:
        stem=lambda w, output: os.path.splitext(output.png)[0],
    log:
        PATHS.figure_log(),
    localrule: True
    shell:
        "spherejam figure {wildcards.name} {input.dataset} -o {params.stem} > {log} 2>&1"


rule render_fig1:
    conda:
        "../envs/spherejam.yaml"
    input:
        PATHS.packing("jammed", EXP.figure1_run().key),
    output:
        png=report(PATHS.figure("png", "fig1"), caption="../report/fig1.rst", category="Figures"),
        pdf=PATHS.figure("pdf", "fig1"),
    params:
        options=EXP.figure1_options(),
    log:
        PATHS.figure_log("fig1"),
    localrule: True
    shell:
        "spherejam render {input} {params.options} -o {output.png} -o {output.pdf} > {log} 2>&1"


# A packed column: the jammed packing of the first cylinder of `containers`, drawn with OVITO like Fig. 1; part of
# `all` with figures.render_column: true.
rule render_column:
    conda:
        "../envs/spherejam.yaml"
    input:
        PATHS.packing("jammed", EXP.column_run().key) if EXP.column_run() else [],
    output:
        png=report(PATHS.figure("png", "column"), caption="../report/column.rst", category="Figures"),
        pdf=PATHS.figure("pdf", "column"),
    log:
        PATHS.figure_log("column"),
    localrule: True
    shell:
        "spherejam render {input} -o {output.png} -o {output.pdf} > {log} 2>&1"


# One jammed packing as an interactive page (spherejam view: rotate, zoom, slice; one self-contained HTML file),
# linked from the report; per cell with figures.view_pages: true (Experiment.view_runs).
rule view_page:
    conda:
        "../envs/spherejam.yaml"
    input:
        PATHS.packing("jammed"),
    output:
        report(PATHS.view(), caption="../report/view.rst", category="Packings (interactive)"),
    log:
        PATHS.log("view"),
    localrule: True
    shell:
        "spherejam view {input} -o {output} > {log} 2>&1"
