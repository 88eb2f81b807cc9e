"""``benchmarks/calippso_lp_count.py``: an input made by its recipe is certified, the record says so, a rerun skips
it, and the summary table counts it."""

import importlib
import json
import math
import sys
from pathlib import Path

import numpy as np
import pytest

_BENCHMARKS = str(Path(__file__).resolve().parents[2] / "benchmarks")
if _BENCHMARKS not in sys.path:
    sys.path.insert(0, _BENCHMARKS)
lp_count = importlib.import_module("calippso_lp_count")


def test_recipes_are_parsed_and_bad_ones_named():
    assert lp_count.parse_recipe("ls:1e-3") == ("ls", 1e-3)
    assert lp_count.parse_recipe("mls:0.01") == ("mls", 0.01)
    for bad in ("fb:1e-3", "ls", "ls:"):
        with pytest.raises(SystemExit, match="--recipes"):
            lp_count.parse_recipe(bad)


def test_an_input_is_certified_recorded_and_summarized(tmp_path, capsys):
    out = tmp_path / "records"
    assert lp_count.main(["--out", str(out), "--n", "64", "--recipes", "ls:1e-2", "--seeds", "1"]) == 0
    rec = json.loads((out / "ls0.01-n64-s1.json").read_text())
    assert rec["n"] == 64 and rec["input"] == "ls:0.01"
    # a certificate at p = 1e5 raises phi by about d phi / p, never lowers it, and is valid on its own
    assert rec["converged"] and rec["valid"] and rec["lps"] >= 1
    assert 0 < rec["phi_J"] - rec["phi_start"] < 1e-3
    lps_csv = (out / "ls0.01-n64-s1.lps.csv").read_text().splitlines()
    assert len(lps_csv) == 1 + rec["lps"]  # a header and one row per LP
    mtime = (out / "ls0.01-n64-s1.json").stat().st_mtime_ns
    lp_count.main(["--out", str(out), "--n", "64", "--recipes", "ls:1e-2", "--seeds", "1"])
    assert (out / "ls0.01-n64-s1.json").stat().st_mtime_ns == mtime  # done inputs are skipped
    capsys.readouterr()
    lp_count.main(["--out", str(out), "--summarize"])
    table = capsys.readouterr().out
    assert f"| ls:0.01 | 64 | 1 | {rec['lps']} |" in table and "1, 1 of 1" in table


def test_gaps_count_near_contacts_without_certifying(tmp_path, capsys):
    lp_count.main(["--out", str(tmp_path / "none"), "--gaps", "--n", "64", "--recipes", "ls:1e-2", "--seeds", "1"])
    row = next(x for x in capsys.readouterr().out.splitlines() if x.startswith("| ls:0.01 | 64 | 1 |"))
    z = [float(c) for c in row.strip("| ").split(" | ")[4:]]
    # contacts per sphere among ever wider gaps: never fewer, and at p = 1e5 about isostatic (6) by h < 1e-3
    assert len(z) == len(lp_count.GAP_THRESHOLDS) and z == sorted(z) and 4.5 < z[-1] < 7.0
    assert not (tmp_path / "none").exists()  # nothing certified, nothing written


def test_a_killed_certification_resumes_from_its_checkpoint_and_its_kept_input(tmp_path):
    """The input a recipe built is kept in --inputs and read back unchanged; a certification stopped after its first
    LP leaves its checkpoint beside the LP log, and the next call resumes there (the LP log keeps LP 1) and removes
    it on convergence."""
    kept = tmp_path / "inputs"
    packing, build_cpu = lp_count.built("ls0.01-n64-s1", "ls", 1e-2, 64, 1, str(kept))
    assert build_cpu >= 0 and (kept / "ls0.01-n64-s1.h5").exists()
    again, read_cpu = lp_count.built("ls0.01-n64-s1", "ls", 1e-2, 64, 1, str(kept))
    assert math.isnan(read_cpu) and np.array_equal(again.positions, packing.positions)
    log = tmp_path / "ls0.01-n64-s1.lps.csv"
    ckpt = tmp_path / "ls0.01-n64-s1.ckpt.h5"
    first, _ = lp_count.certify(again, log, 1)
    assert not first.completed and ckpt.exists()
    row1 = log.read_text().splitlines()[1]
    done, _ = lp_count.certify(again, log, 1000)
    assert done.completed and done.iterations >= 2 and not ckpt.exists()
    assert log.read_text().splitlines()[1] == row1 and len(log.read_text().splitlines()) == 1 + done.iterations
