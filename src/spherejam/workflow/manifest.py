"""The experiment manifest (``<results>/experiment.json``): the validated config, its hash and the provenance,
which the dataset builder reads; and the check that keeps it the manifest of the config the workflow runs."""

from __future__ import annotations

import json
import os
from pathlib import Path
from typing import Any

from ..core.atomic import atomic_output
from ..core.provenance import provenance
from .config import check_config
from .experiment import Experiment, config_hash


def write_manifest(config: dict[str, Any], path: str | os.PathLike) -> Path:
    """Write the resolved experiment (config, hash, provenance) that the dataset builder reads.

    The config passes :func:`spherejam.workflow.config.check_config` (every limit and consistency rule) and makes
    an :class:`Experiment` (the design's own checks) first."""
    check_config(config)
    Experiment(config)  # its constructor checks the design (the sigmas of the extra rates and of the grid)
    manifest = {"config": config, "config_hash": config_hash(config), "provenance": provenance()}
    with atomic_output(path, ".json") as tmp:
        Path(tmp).write_text(json.dumps(manifest, indent=1, sort_keys=True, default=str))
    return Path(path)


def stale_manifest(path: str | os.PathLike, config: dict[str, Any]) -> str | None:
    """Why the manifest at ``path`` no longer describes ``config`` (another config's hash, or unreadable), or None
    if it does or does not exist. Snakemake reruns the manifest job on a config change only while its metadata
    (``.snakemake/``) lasts; the workflow asks this at every start, so a moved results folder or a new working
    directory cannot leave a dataset built from an older config."""
    path = Path(path)
    if not path.is_file():
        return None
    try:
        recorded = json.loads(path.read_text()).get("config_hash")
    except (OSError, ValueError, AttributeError):
        return "unreadable"
    now = config_hash(config)
    return None if recorded == now else f"config_hash {recorded}, the config's is {now}"


def renew_stale_manifest(path: str | os.PathLike, config: dict[str, Any]) -> str | None:
    """Write the manifest at ``path`` anew if it was written for another config (:func:`stale_manifest`): newer
    than the dataset, it makes Snakemake remake the dataset, tables and figures. Returns the line to log, or None."""
    why = stale_manifest(path, config)
    if why is None:
        return None
    write_manifest(json.loads(json.dumps(config)), path)  # the config as the manifest job gets it: through JSON
    return (f"spherejam: {path} was written for another config ({why}): written anew, so the dataset, tables and "
            "figures are made again")
