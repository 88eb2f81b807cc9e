"""Provenance of every output: package versions, git commit and creation time."""

from __future__ import annotations

import datetime as _dt
import functools
import importlib.metadata
import os
import platform
import subprocess
from pathlib import Path

from .. import __version__

_PACKAGES = ("numpy", "numba", "scipy", "h5py", "xarray", "pandas", "highspy", "freud-analysis", "snakemake")


@functools.cache
def git_commit() -> str:
    """The commit of the source tree spherejam runs from, or ``"unknown"``.

    ``SPHEREJAM_GIT_COMMIT`` overrides (useful for installs from a wheel, where no checkout exists).
    """
    env = os.environ.get("SPHEREJAM_GIT_COMMIT")
    if env:
        return env
    here = Path(__file__).resolve().parent
    try:
        out = subprocess.run(
            ["git", "-C", str(here), "rev-parse", "HEAD"], capture_output=True, text=True, timeout=5, check=True
        ).stdout.strip()
        dirty = subprocess.run(
            ["git", "-C", str(here), "status", "--porcelain", "--untracked-files=no"],
            capture_output=True, text=True, timeout=5, check=True,
        ).stdout.strip()
        return out + ("-dirty" if dirty else "") if out else "unknown"
    except (OSError, subprocess.SubprocessError):
        return "unknown"


@functools.cache
def package_versions() -> dict[str, str]:
    versions = {"python": platform.python_version(), "spherejam": __version__}
    for name in _PACKAGES:
        try:
            versions[name] = importlib.metadata.version(name)
        except importlib.metadata.PackageNotFoundError:
            pass
    return versions


def now_utc() -> str:
    return _dt.datetime.now(_dt.UTC).isoformat(timespec="seconds")


def provenance() -> dict[str, object]:
    """A JSON-serialisable record of what produced an output, and when."""
    return {
        "spherejam_version": __version__,
        "git_commit": git_commit(),
        "created": now_utc(),
        "package_versions": package_versions(),
    }
