"""A checkpoint of an older input: refused by a hand-run command, discarded (and logged) by the workflow's jobs."""

import subprocess
import sys
from pathlib import Path

import pytest
import yaml

from spherejam.workflow.experiment import Experiment

ROOT = Path(__file__).resolve().parents[2]


def spherejam(*args):
    return subprocess.run([sys.executable, "-m", "spherejam.cli", *map(str, args)], capture_output=True, text=True)


LADDERS = {"ls": ["--rate", "0.1"], "mls": ["--initial-rate", "4", "--final-rate", "1"]}


def leave_checkpoint(start: Path, checkpoint: Path, out: Path, command: str = "ls"):
    """A run of ``start`` cut after its first window by its time limit, which keeps its checkpoint."""
    r = spherejam(command, start, *LADDERS[command], "--checkpoint", checkpoint, "--checkpoint-interval", "0",
                  "--max-wall-time", "1e-9", "-o", out)
    assert r.returncode == 0 and "stop=max_wall_time" in r.stdout, r.stdout + r.stderr
    assert checkpoint.exists()
    out.unlink()


@pytest.fixture
def two_starts(tmp_path):
    a, b = tmp_path / "a.h5", tmp_path / "b.h5"
    for seed, path in ((1, a), (2, b)):
        r = spherejam("seed", "--n", 40, "--sigma", 0.1, "--seed", seed, "-o", path)
        assert r.returncode == 0, r.stderr
    return a, b


def test_hand_run_refuses_a_stale_checkpoint(two_starts, tmp_path):
    a, b = two_starts
    ckpt, out = tmp_path / "c.h5", tmp_path / "out.h5"
    leave_checkpoint(a, ckpt, tmp_path / "cut.h5")
    r = spherejam("ls", b, "--rate", "0.1", "--checkpoint", ckpt, "-o", out)
    assert r.returncode == 2
    assert "checkpoint of a different input or parameters" in r.stderr and str(ckpt) in r.stderr
    assert ckpt.exists() and not out.exists()  # the library's refusal stays: nothing deleted, nothing written


@pytest.mark.parametrize("command", ["ls", "mls"])
def test_discard_flag_starts_over_and_logs(command, two_starts, tmp_path):
    a, b = two_starts
    ckpt, out = tmp_path / "c.h5", tmp_path / "out.h5"
    leave_checkpoint(a, ckpt, tmp_path / "cut.h5", command)
    ladder = LADDERS[command]
    r = spherejam(command, b, *ladder, "--checkpoint", ckpt, "--discard-stale-checkpoint", "-o", out)
    assert r.returncode == 0, r.stderr
    assert "discarded stale checkpoint" in r.stderr and str(ckpt) in r.stderr
    assert out.exists() and not ckpt.exists()
    # the run started over: the same as a run that never met a checkpoint
    fresh = tmp_path / "fresh.h5"
    assert spherejam(command, b, *ladder, "-o", fresh).returncode == 0
    import h5py
    import numpy as np
    with h5py.File(out) as f, h5py.File(fresh) as g:
        assert np.array_equal(f["positions"][()], g["positions"][()])


def test_workflow_job_whose_input_changed_completes(tmp_path):
    """A job rerun after its input changed meets the old run's checkpoint, discards it and completes."""
    cfg = yaml.safe_load((ROOT / "config" / "tiny.yaml").read_text())
    cfg["results"] = str(tmp_path / "results")
    (tmp_path / "c.yaml").write_text(yaml.safe_dump(cfg))
    exp = Experiment(cfg)
    run = next(r for r in exp.runs("ls") if r.rate == max(x.rate for x in exp.runs("ls")))
    start = Path(exp.paths.packing("poisson", run.key))
    target = Path(exp.paths.packing("initial", run.key))
    ckpt = Path(exp.paths.checkpoint("ls", run.key))
    def smk(target):  # the target first: --configfile takes every word after it
        return subprocess.run([sys.executable, "-m", "snakemake", str(target), "--cores", "1", "--configfile",
                               str(tmp_path / "c.yaml")], cwd=ROOT, capture_output=True, text=True, timeout=600)

    r = smk(start)
    assert r.returncode == 0, r.stderr[-3000:]
    # the checkpoint an earlier LS job left, from the input as it was before it changed
    old = tmp_path / "old.h5"
    assert spherejam("seed", "--n", cfg["n"], "--sigma", 0.0, "--seed", 99, "-o", old).returncode == 0
    ckpt.parent.mkdir(parents=True, exist_ok=True)
    leave_checkpoint(old, ckpt, tmp_path / "unused.h5")
    r = smk(target)
    assert r.returncode == 0, r.stderr[-3000:]
    assert target.exists() and not ckpt.exists()
    assert "discarded stale checkpoint" in Path(exp.paths.log("ls", run.key)).read_text()
