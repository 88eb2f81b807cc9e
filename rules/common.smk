# Config validation, the experiment design and the path patterns every rule file uses.
import json
import os

from snakemake.exceptions import WorkflowError

from spherejam.workflow import cost_model as cluster_resources
from spherejam.core.errors import InputError
from spherejam.workflow.experiment import Experiment, parse_run
from spherejam.core.validation import validate_config

try:  # the schema (filling in its defaults), then the limits and consistency rules of spherejam.core.validation
    validate_config(config, workflow.source_path("../config/schema.yaml"))
except InputError as exc:
    raise WorkflowError(str(exc)) from None

EXP = Experiment(config)
R = str(EXP.results)

wildcard_constraints:
    protocol="ls|fb",
    sigma=r"[0-9][0-9.e+-]*",
    rate=r"[0-9][0-9.e+-]*",
    replica=r"\d+",
    factor=r"[0-9][0-9.e+-]*",
    g0=r"[0-9][0-9.e+-]*",
    gf=r"[0-9][0-9.e+-]*",

RUN = "{protocol}/sigma{sigma}/rate{rate}/r{replica}"
PACKING = f"{R}/packings/{RUN}"
GRID_RUN = "ls/sigma{sigma}/rate{rate}/r{replica}/f{factor}_g{g0}_gf{gf}"

DATASET = f"{R}/dataset.nc"
TABLE_NAMES = ["table2", "table3", "table4"]
TABLES = expand(f"{R}/tables/{{name}}.{{ext}}", name=TABLE_NAMES, ext=["csv", "md", "tex"])
FIGURE_NAMES = ["fig2", "fig3", "fig4", "fig5", "fig6", "fig7", "structure", "forces"]
FIGURES = expand(f"{R}/figures/{{name}}.{{ext}}", name=FIGURE_NAMES, ext=["png", "pdf"])


def run_of(wildcards):
    return parse_run(wildcards.protocol, wildcards.sigma, wildcards.rate, wildcards.replica)


def run_seed(purpose):
    return lambda wildcards: run_of(wildcards).seed(EXP.master_seed, purpose)


def mls_options():
    """The MLS stall-rule and cut-off flags of the config (the schema has filled in the defaults)."""
    mls = config["mls"]
    stall = mls["stall_windows"]
    flags = ["--no-stall-rule" if stall is None else f"--stall-windows {stall}"]
    if mls.get("max_collisions_per_particle") is not None:
        flags.append(f"--max-collisions-per-particle {mls['max_collisions_per_particle']}")
    if mls.get("max_wall_time") is not None:
        flags.append(f"--max-wall-time {mls['max_wall_time']}")
    return " ".join(flags)


def resources_for(stage, mls_parameters=None):
    """SLURM resources of a job, estimated from N, gamma and the protocol (spherejam.workflow.cost_model).

    ``mls_parameters(wildcards)`` gives the MLS initial rate, decrease factor and final rate of MLS jobs.
    """

    def runtime(wildcards, attempt):
        extra = mls_parameters(wildcards) if mls_parameters else {}
        return cluster_resources.runtime_minutes(stage, EXP.n, _rate(wildcards), attempt, **extra)

    def mem_mb(wildcards, attempt):
        return cluster_resources.mem_mb(stage, EXP.n, attempt)

    return {"runtime": runtime, "mem_mb": mem_mb, "cpus_per_task": cluster_resources.cpus_per_task(stage, EXP.n)}


def _rate(wildcards):
    return float(wildcards.rate) if hasattr(wildcards, "rate") else None


def dataset_inputs(wildcards):
    files = []
    for run in EXP.runs():
        files += [str(EXP.path(run, "initial")), str(EXP.path(run, "jammed"))]
        if config["analysis"]["enabled"]:
            files.append(str(EXP.path(run, "structure")))
        if config["calippso"]["enabled"]:
            files.append(str(EXP.path(run, "calippso")))
    files += [str(EXP.grid_path(g)) for g in EXP.grid_runs()]
    return files
