"""Issue 49, data loss: `spherejam archive -o DIR` replaces only an archive it wrote, never a user's folder, a sibling
or a symlink's folder, and at every instant (also under SIGTERM and kill -9) DIR holds the old or the new archive.

The results folder is a copy of the tracked reproduction (its dataset, tables and figures). Every user folder holds
marker files, and each test checks that every marker survives with its content."""

import contextlib
import io
import os
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from spherejam.cli import main

ROOT = Path(__file__).resolve().parents[2]
SRC = str(ROOT / "src")
REPRODUCTION = ROOT / "archive" / "reproduction"
#: The manifest an archive holds (docs/robustness.md, "Replacing a folder").
MANIFEST = "archive.json"


def cli(*args):
    err, out = io.StringIO(), io.StringIO()
    with contextlib.redirect_stderr(err), contextlib.redirect_stdout(out):
        code = main([str(a) for a in args])
    return code, err.getvalue().strip().splitlines(), out.getvalue()


@pytest.fixture
def results(tmp_path):
    res = tmp_path / "res"
    res.mkdir()
    shutil.copy(REPRODUCTION / "dataset.nc", res / "dataset.nc")
    shutil.copytree(REPRODUCTION / "tables", res / "tables")
    return res


def user_folder(path: Path, with_dataset: bool = True) -> dict[str, bytes]:
    """A user's folder: notes, a sub-folder, and (as the issue's) a dataset.nc; returns {relative path: content}."""
    files = {"notes.txt": b"my notes\n", "sub/deep/marker.bin": os.urandom(64), "logs/run.log": b"log\n"}
    if with_dataset:
        files["dataset.nc"] = (REPRODUCTION / "dataset.nc").read_bytes()
    for rel, content in files.items():
        (path / rel).parent.mkdir(parents=True, exist_ok=True)
        (path / rel).write_bytes(content)
    return files


def survives(path: Path, files: dict[str, bytes]) -> bool:
    return all((path / rel).is_file() and (path / rel).read_bytes() == content for rel, content in files.items())


def snapshot(folder: Path) -> dict[str, bytes]:
    return {str(p.relative_to(folder)): p.read_bytes() for p in sorted(folder.rglob("*")) if p.is_file()}


@pytest.mark.parametrize("kind", ["results run", "user folder", "archive with a note", "edited archive"])
def test_archive_replaces_only_an_archive_it_wrote(tmp_path, results, kind):
    target = tmp_path / "out"
    if kind == "results run":  # cp -r archive/reproduction run2: holds dataset.nc, packings, README, no manifest
        shutil.copytree(REPRODUCTION, target, ignore=shutil.ignore_patterns("packings"))
        (target / "packings" / "n250").mkdir(parents=True)
        (target / "packings" / "n250" / "jammed.h5").write_bytes(b"a packing")
    elif kind == "user folder":
        target.mkdir()
        user_folder(target)
    else:
        assert cli("archive", results, "-o", target)[0] == 0
        if kind == "archive with a note":
            (target / "tables" / "my-note.txt").write_text("mine")
        else:
            (target / "README.md").write_text("my edited README")
    before = snapshot(target)
    code, err, _ = cli("archive", results, "-o", target)
    assert code == 2 and len(err) == 1 and "-o/--output=" in err[0] and "nothing replaced" in err[0], err
    assert snapshot(target) == before
    assert sorted(os.listdir(tmp_path)) == ["out", "res"]  # no temporary folder left beside it


def test_an_archive_it_wrote_is_replaced_as_a_whole(tmp_path, results):
    target = tmp_path / "out"
    assert cli("archive", results, "-o", target)[0] == 0
    assert (target / MANIFEST).is_file() and (target / "tables" / "table2.md").is_file()
    (results / "tables" / "table2.md").unlink()
    assert cli("archive", results, "-o", target)[0] == 0
    assert not (target / "tables" / "table2.md").exists()  # no file of the older archive lingers
    assert sorted(os.listdir(tmp_path)) == ["out", "res"]


def test_a_sibling_with_the_old_fixed_name_is_untouched(tmp_path, results):
    target = tmp_path / "u2"
    assert cli("archive", results, "-o", target)[0] == 0
    siblings = {}
    for name in (".u2.old", ".u2.tmp", ".u2.abcdefgh.tmp"):
        (tmp_path / name).mkdir()
        siblings[name] = user_folder(tmp_path / name)
    assert cli("archive", results, "-o", target)[0] == 0
    for name, files in siblings.items():
        assert survives(tmp_path / name, files), name
    assert sorted(os.listdir(tmp_path)) == sorted(["u2", "res", *siblings])


def test_a_symlink_to_a_folder_is_followed_and_stays(tmp_path, results):
    real = tmp_path / "real"
    link = tmp_path / "link"
    link.symlink_to(real, target_is_directory=True)
    assert cli("archive", results, "-o", link)[0] == 0  # a dangling link: its target becomes the archive
    assert link.is_symlink() and (real / MANIFEST).is_file()
    assert cli("archive", results, "-o", link)[0] == 0  # and again: the target is replaced, the link stays
    assert link.is_symlink() and os.readlink(link) == str(real) and (real / MANIFEST).is_file()
    assert sorted(os.listdir(tmp_path)) == ["link", "real", "res"]
    mine = tmp_path / "mine"
    mine.mkdir()
    files = user_folder(mine)
    link.unlink()
    link.symlink_to(mine, target_is_directory=True)
    code, err, _ = cli("archive", results, "-o", link)
    assert code == 2 and len(err) == 1 and "not a spherejam archive" in err[0], err
    assert survives(mine, files)


@pytest.mark.parametrize("which", ["empty", "dot", "results", "ancestor", "root"])
def test_bad_archive_folders_are_one_line(tmp_path, results, which, monkeypatch):
    monkeypatch.chdir(results)
    files = user_folder(results, with_dataset=False)
    out = {"empty": "", "dot": ".", "results": str(results), "ancestor": str(tmp_path), "root": "/"}[which]
    code, err, _ = cli("archive", results, "-o", out)
    assert code == 2 and len(err) == 1 and err[0].startswith("spherejam archive: error: -o/--output="), err
    assert survives(results, files) and (results / "dataset.nc").is_file()


def _archive_process(results, target, max_mb=100):
    env = {**os.environ, "PYTHONPATH": SRC}
    return subprocess.Popen([sys.executable, "-m", "spherejam.cli", "archive", str(results), "-o", str(target),
                             "--max-mb", str(max_mb)], env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            text=True)


@pytest.mark.parametrize("sig", [signal.SIGTERM, signal.SIGINT, signal.SIGKILL])
def test_a_signal_mid_copy_leaves_the_old_archive_whole(tmp_path, results, sig):
    """The signal lands while ~2000 files are copied into the new archive (the copy's first log line): the old
    archive stays at DIR, byte for byte; SIGTERM and SIGINT also leave no temporary folder."""
    target = tmp_path / "out"
    assert cli("archive", results, "-o", target)[0] == 0
    old = snapshot(target)
    payload = os.urandom(8192)
    for k in range(2000):  # a run with many table files: the copy takes a while
        (results / "tables" / f"extra{k:04d}.csv").write_bytes(payload)
    proc = _archive_process(results, target)
    deadline = time.monotonic() + 120
    for line in proc.stderr:
        if "copying" in line:
            proc.send_signal(sig)
            break
        assert time.monotonic() < deadline
    err = proc.stderr.read()
    proc.wait(timeout=120)
    if sig == signal.SIGKILL:
        assert proc.returncode == -signal.SIGKILL
    else:
        assert proc.returncode == 128 + sig, err
        assert f"stopped by {signal.Signals(sig).name}" in err and "Traceback" not in err, err
        assert sorted(os.listdir(tmp_path)) == ["out", "res"]
    assert snapshot(target) == old  # the old archive, whole (kill -9 may leave the new one's temporary beside it)
