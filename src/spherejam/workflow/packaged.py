"""The Snakemake workflow that ships inside the package, and how to run it from any folder.

The repository's ``Snakefile``, ``rules/``, ``config/``, ``report/``, ``profiles/``, ``envs/`` and ``examples/`` are
the one source. ``spherejam/workflow_files/`` holds relative symlinks to them, so an editable install reads the
repository's own files, and a built wheel carries the files the links point to (``[tool.setuptools.package-data]``
in pyproject.toml; tests/workflow/test_packaged.py compares a wheel's files with the repository's).

Snakemake runs as a separate program (the package never imports it), from the interpreter that runs spherejam and
with that interpreter's ``bin`` folder first on PATH, so the rules' ``spherejam ...`` commands are this
installation's even when its virtual environment is not activated. Its working directory is the caller's: relative
``results`` folders and ``table:`` files resolve there, as with a plain ``snakemake`` call, and ``.snakemake/`` is
written there.
"""

from __future__ import annotations

import os
import sys
from pathlib import Path

#: The workflow's entries, as in the repository's root (each a file or a folder).
ENTRIES = ("Snakefile", "rules", "config", "report", "profiles", "envs", "examples")
#: Configs of ``config/`` that are experiments (``schema.yaml`` is not one).
SCHEMA = "schema.yaml"


def workflow_dir() -> Path:
    """The folder holding the packaged workflow (``Snakefile``, ``rules/``, ``config/``, ...)."""
    return Path(__file__).resolve().parent.parent / "workflow_files"


def snakefile() -> Path:
    return workflow_dir() / "Snakefile"


def schema() -> Path:
    return workflow_dir() / "config" / SCHEMA


def config_file(name: str) -> Path:
    """The packaged experiment config ``config/<name>.yaml`` (``config``, ``tiny``, ``paper``, ``psd``, ...)."""
    return workflow_dir() / "config" / f"{name}.yaml"


def experiment_names() -> list[str]:
    """Names of the packaged experiment configs, the default (``config``) first."""
    names = sorted(p.stem for p in (workflow_dir() / "config").glob("*.yaml") if p.name != SCHEMA)
    return sorted(names, key=lambda n: n != "config")


def packaged_files() -> dict[str, Path]:
    """Every file of the packaged workflow by its path relative to the workflow folder (``rules/common.smk``)."""
    root = workflow_dir()
    out: dict[str, Path] = {}
    for entry in ENTRIES:
        top = root / entry
        if top.is_file():
            out[entry] = top
            continue
        for path in sorted(top.rglob("*")):
            if path.is_file() and "__pycache__" not in path.parts:
                out[path.relative_to(root).as_posix()] = path
    return out


def snakemake_command() -> tuple[list[str], dict[str, str]]:
    """The command that starts Snakemake of this installation, and the environment to start it in."""
    env = dict(os.environ)
    bindir = str(Path(sys.executable).parent)
    env["PATH"] = bindir + os.pathsep + env.get("PATH", "")
    return [sys.executable, "-m", "snakemake"], env
