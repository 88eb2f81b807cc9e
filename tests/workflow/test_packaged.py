"""The workflow shipped in the package: the same files as the repository's, in an editable install and in a wheel,
and ``spherejam run``/``init``/``rcp`` from a folder that is not the repository."""

import os
import subprocess
import sys
import tomllib
import zipfile
from pathlib import Path

import pytest
import yaml

from spherejam.cli import main
from spherejam.workflow import packaged

ROOT = Path(__file__).resolve().parents[2]


def repository_files() -> set[str]:
    """The workflow's files in the repository's root, by path relative to it."""
    out = set()
    for entry in packaged.ENTRIES:
        top = ROOT / entry
        if top.is_file():
            out.add(entry)
        out.update(p.relative_to(ROOT).as_posix() for p in top.rglob("*")
                   if p.is_file() and "__pycache__" not in p.parts)
    return out


def test_packaged_workflow_is_the_repository_own_files():
    files = packaged.packaged_files()
    assert set(files) == repository_files()
    assert {"Snakefile", "rules/common.smk", "config/schema.yaml", "config/tiny.yaml", "profiles/default/config.yaml",
            "report/workflow.rst"} <= set(files)
    for rel, path in files.items():  # the same file, not a copy that could drift
        assert os.path.samefile(path, ROOT / rel), rel


def test_package_data_patterns_take_every_packaged_file():
    """pyproject's package-data globs must match every file, or the wheel would lack one (a deeper folder, say)."""
    patterns = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["setuptools"]["package-data"]["spherejam"]
    base = ROOT / "src" / "spherejam"
    matched = {p.relative_to(base).as_posix() for pattern in patterns for p in base.glob(pattern) if p.is_file()}
    assert {m.removeprefix("workflow_files/") for m in matched if m.startswith("workflow_files/")} == set(
        packaged.packaged_files())
    assert "workflow/packing_view.html" in matched  # the viewer's page template


def test_wheel_carries_the_repository_files():
    """CI builds the wheel and runs this with SPHEREJAM_WHEEL=<the .whl> (.ci/run); its files must be the
    repository's, byte for byte, and all of them."""
    wheel = os.environ.get("SPHEREJAM_WHEEL")
    if not wheel:
        pytest.skip("SPHEREJAM_WHEEL not set (CI's wheel step sets it after building the wheel)")
    prefix = "spherejam/workflow_files/"
    with zipfile.ZipFile(wheel) as z:
        shipped = {name[len(prefix):]: z.read(name) for name in z.namelist() if name.startswith(prefix)}
    assert set(shipped) == repository_files()
    for rel, data in shipped.items():
        assert data == (ROOT / rel).read_bytes(), rel


def test_init_writes_an_editable_experiment_and_never_overwrites(tmp_path, capsys):
    folder = tmp_path / "exp"
    assert main(["init", str(folder), "--from", "tiny"]) == 0
    config = (folder / "config.yaml").read_text()
    assert config.startswith("# A spherejam experiment") and "spherejam run --configfile config.yaml" in config
    assert yaml.safe_load(config) == yaml.safe_load(packaged.config_file("tiny").read_text())
    assert (folder / "profiles" / "default" / "config.yaml").read_bytes() == (
        ROOT / "profiles" / "default" / "config.yaml").read_bytes()
    assert (folder / "powder.csv").is_file()
    (folder / "config.yaml").write_text("# edited\n")
    capsys.readouterr()
    assert main(["init", str(folder)]) == 2
    assert "already holds config.yaml" in capsys.readouterr().err
    assert (folder / "config.yaml").read_text() == "# edited\n"
    assert main(["init", str(tmp_path / "other"), "--from", "nope"]) == 2
    assert "--from='nope'" in capsys.readouterr().err


def spherejam(*args, cwd):
    env = dict(os.environ, PYTHONPATH=str(ROOT / "src") + os.pathsep + os.environ.get("PYTHONPATH", ""))
    return subprocess.run([sys.executable, "-m", "spherejam.cli", *args], cwd=cwd, capture_output=True, text=True,
                          timeout=300, env=env)


def test_run_dry_run_from_an_empty_folder_takes_results_and_snakemake_options(tmp_path):
    # a results folder whose name YAML reads as a number stays a folder name
    r = spherejam("run", "--configfile", str(ROOT / "config" / "tiny.yaml"), "-o", "1e3", "-n", "--cores", "1",
                  cwd=tmp_path)
    assert r.returncode == 0, r.stderr[-3000:]
    text = r.stdout + r.stderr
    assert "1e3/dataset.nc" in text and "results-tiny" not in text  # -o replaces the config's results folder
    assert "This was a dry-run" in text
    assert f"--snakefile {packaged.snakefile()}" in text
    run_config = yaml.safe_load((tmp_path / "1e3" / "run_config.yaml").read_text())  # the config as run
    assert run_config == {**yaml.safe_load((ROOT / "config" / "tiny.yaml").read_text()), "results": "1e3"}
    assert sorted(p.name for p in (tmp_path / "1e3").iterdir()) == ["run_config.yaml"]  # a dry run makes nothing


def test_run_refuses_a_missing_config_and_other_commands_refuse_unknown_options(tmp_path, capsys):
    assert main(["run", "--configfile", str(tmp_path / "missing.yaml")]) == 2
    assert "--configfile=" in capsys.readouterr().err
    assert main(["info", str(tmp_path / "x.h5"), "--bogus"]) == 2
    assert "unrecognized arguments: --bogus" in capsys.readouterr().err


def test_rcp_dry_run_from_an_empty_folder(tmp_path):
    r = spherejam("rcp", "bidisperse:ratio=1.4,small=0.5,by=number", "--dry-run", cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    assert f"results in {tmp_path / 'results' / 'psd'}" in r.stdout
    assert "bidisperse-ratio-1-4-small-0-5-by-number" in r.stdout
