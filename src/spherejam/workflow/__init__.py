"""The experiment behind the Snakemake workflow: runs, paths and seeds (:mod:`.experiment`), the results dataset,
fits, bands, the paper's tables, figures and the cost model. Snakemake is never imported here."""
