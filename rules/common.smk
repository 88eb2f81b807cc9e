# Config validation and the experiment design. Every path pattern, seed and config-derived argument of the rules
# comes from EXP (spherejam.workflow.experiment), resources from spherejam.workflow.cost_model.
import json
import os

from snakemake.exceptions import WorkflowError

from spherejam.core.errors import InputError
from spherejam.workflow.config import validate_config
from spherejam.workflow.cost_model import job_resources
from spherejam.workflow.experiment import FIGURE_NAMES, WILDCARD_CONSTRAINTS, Experiment, GridRun, mls_command

try:  # the schema (filling in its defaults), then the limits and consistency rules of spherejam.workflow.config
    validate_config(config, workflow.source_path("../config/schema.yaml"))
except InputError as exc:
    raise WorkflowError(str(exc)) from None

EXP = Experiment(config)
PATHS = EXP.paths


wildcard_constraints:
    **WILDCARD_CONSTRAINTS,
