# Config validation and the experiment design. Every path pattern, seed and config-derived argument of the rules
# comes from EXP (spherejam.workflow.experiment), resources from spherejam.workflow.cost_model.
import json
import os
import sys

from snakemake.exceptions import WorkflowError

from spherejam.core.errors import InputError
from spherejam.workflow.config import load_config_file, validate_config
from spherejam.workflow.cost_model import job_resources
from spherejam.workflow.experiment import (
    FIGURE_NAMES,
    WILDCARD_CONSTRAINTS,
    Experiment,
    GridRun,
    mls_command,
)
from spherejam.workflow.manifest import renew_stale_manifest
from spherejam.workflow.run_hooks import cancel_pending_timers

try:  # the schema (filling in its defaults), the limits and consistency rules of spherejam.workflow.config, and
    # the design (paths that must not collide)
    for path in workflow.configfiles:  # Snakemake's loader keeps the last of a repeated key: refuse the file
        load_config_file(path)
    validate_config(config, workflow.source_path("../config/schema.yaml"))
    EXP = Experiment(config)
except InputError as exc:
    raise WorkflowError(str(exc)) from None
PATHS = EXP.paths

# A manifest of another config (Snakemake's metadata in .snakemake/ lost: a new working directory, a moved results
# folder) is written anew here: newer than the dataset, it remakes the dataset, tables and figures from this config,
# which Snakemake's params trigger would not do without that metadata. The packings do not depend on it.
_renewed = renew_stale_manifest(PATHS.manifest, config)
if _renewed:
    print(_renewed, file=sys.stderr)


# Without this the process lingers up to the profile's timespan (60 s) after its last job (run_hooks).
onsuccess:
    cancel_pending_timers()


onerror:
    cancel_pending_timers()


wildcard_constraints:
    **WILDCARD_CONSTRAINTS,
