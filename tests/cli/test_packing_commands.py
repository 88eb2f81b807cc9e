import subprocess
import sys

import pytest

from spherejam.cli import main


def run(*args):
    return subprocess.run([sys.executable, "-m", "spherejam.cli", *args], capture_output=True, text=True)


def test_seed_check_export_chain(tmp_path):
    p = tmp_path / "p.h5"
    assert main(["seed", "--n", "1000", "--sigma", "0.3", "--seed", "1", "-o", str(p)]) == 0
    assert main(["check", str(p)]) == 0
    assert main(["export", str(p), "--format", "xyz"]) == 0
    assert (tmp_path / "p.xyz").exists()
    assert main(["info", str(p), "--json"]) == 0


@pytest.mark.parametrize(
    "args, needle",
    [
        (["seed", "--n", "0", "-o", "x.h5"], "--n"),
        (["seed", "--n", "10", "--sigma", "-1", "-o", "x.h5"], "sigma"),
        (["check", "does-not-exist.h5"], "does-not-exist.h5"),
        (["seed", "--n", "ten", "-o", "x.h5"], "--n"),
    ],
)
def test_bad_arguments_one_line_error(tmp_path, args, needle):
    r = subprocess.run([sys.executable, "-m", "spherejam.cli", *args], capture_output=True, text=True, cwd=tmp_path)
    assert r.returncode == 2
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1 and needle in lines[0] and "Traceback" not in r.stderr


def test_check_fails_on_overlap(tmp_path):
    import h5py

    p = tmp_path / "p.h5"
    main(["seed", "--n", "50", "--seed", "2", "-o", str(p)])
    with h5py.File(p, "r+") as f:
        f["positions"][1] = f["positions"][0]
    r = run("check", str(p))
    assert r.returncode == 1 and "FAIL" in r.stdout


def test_help_lists_commands():
    r = run("--help")
    assert r.returncode == 0 and "seed" in r.stdout and "export" in r.stdout
