"""Provenance of every output: package versions, git commit and creation time."""

from __future__ import annotations

import datetime as _dt
import functools
import importlib.metadata
import os
import platform
import subprocess
import tomllib
from pathlib import Path

_PACKAGES = ("numpy", "numba", "scipy", "h5py", "xarray", "pandas", "highspy", "freud-analysis", "snakemake")


@functools.cache
def spherejam_version() -> str:
    """The installed distribution's version (pyproject.toml is its one source), or, for a source tree on the path
    without an install, the version in that tree's pyproject.toml; ``"0+unknown"`` if neither exists."""
    try:
        return importlib.metadata.version("spherejam")
    except importlib.metadata.PackageNotFoundError:
        pass
    try:
        with open(Path(__file__).resolve().parents[3] / "pyproject.toml", "rb") as f:
            return str(tomllib.load(f)["project"]["version"])
    except (OSError, KeyError, tomllib.TOMLDecodeError):
        return "0+unknown"


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
    versions = {"python": platform.python_version(), "spherejam": spherejam_version()}
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
        "spherejam_version": spherejam_version(),
        "git_commit": git_commit(),
        "created": now_utc(),
        "package_versions": package_versions(),
    }
