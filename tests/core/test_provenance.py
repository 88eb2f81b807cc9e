"""core/provenance.py: the package version has one source (pyproject.toml), read through the installed metadata or,
without an install, from the source tree."""

import importlib.metadata
import tomllib
from pathlib import Path

import pytest

import spherejam
from spherejam.core import provenance

PYPROJECT = Path(__file__).resolve().parents[2] / "pyproject.toml"


def _pyproject_version() -> str:
    with open(PYPROJECT, "rb") as f:
        return tomllib.load(f)["project"]["version"]


def test_version_is_pyproject_version():
    assert spherejam.__version__ == provenance.spherejam_version() == _pyproject_version()
    record = provenance.provenance()
    assert record["spherejam_version"] == record["package_versions"]["spherejam"] == spherejam.__version__


def test_version_without_installed_metadata(monkeypatch):
    def missing(name):
        raise importlib.metadata.PackageNotFoundError(name)

    monkeypatch.setattr(importlib.metadata, "version", missing)
    provenance.spherejam_version.cache_clear()
    try:
        assert provenance.spherejam_version() == _pyproject_version()
    finally:
        provenance.spherejam_version.cache_clear()


def test_flat_paths_of_0_1_are_gone():
    with pytest.raises(ModuleNotFoundError):
        __import__("spherejam.lubachevsky_stillinger")


def test_cli_version_is_the_package_version(capsys):
    from spherejam.cli import main

    assert main(["--version"]) == 0
    assert capsys.readouterr().out.strip() == f"spherejam {_pyproject_version()}"
