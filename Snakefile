# spherejam: from Poisson points to the tables and figures of Baranau & Tallarek, Soft Matter 10, 3826 (2014).
#
#   snakemake --cores 2                                  # the default experiment (config/config.yaml)
#   snakemake --cores 2 results/figures/fig4.pdf         # rebuild one figure from the dataset
#   snakemake --cores 2 --configfile config/paper.yaml   # the paper's own experiment (a cluster job)
#   snakemake --report results/report.html               # all figures and tables with captions

# A --configfile is the whole experiment (checked complete by itself in rules/common.smk); only without one does the
# default config apply. Snakemake would otherwise merge the user's file over config/config.yaml key by key.
if not workflow.overwrite_configfiles:

    configfile: "config/config.yaml"


report: "report/workflow.rst"


include: "rules/common.smk"
include: "rules/seeding.smk"
include: "rules/generation.smk"
include: "rules/jamming.smk"
include: "rules/validation_grid.smk"
include: "rules/structure.smk"
include: "rules/calippso.smk"
include: "rules/dataset.smk"
include: "rules/tables.smk"
include: "rules/figures.smk"


rule all:
    default_target: True
    input:
        PATHS.dataset,
        PATHS.tables(),
        PATHS.figures(EXP.figure_names),
        EXP.extra_figures(),  # Fig. 1, the packed column, the interactive pages: as the config's `figures` switches
