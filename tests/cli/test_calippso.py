"""`spherejam calippso` (cli/calippso.py): the summary, the written packing, the solver choice it records."""

import json

import pytest

from packings import rsa_packing


def test_cli_calippso(tmp_path, capsys):
    from spherejam.cli import main
    from spherejam.core.packing_io import read_packing, write_packing

    src, out = tmp_path / "in.h5", tmp_path / "out.h5"
    write_packing(src, rsa_packing(96, 0.35, 3, seed=5))
    assert main(["calippso", str(src), "-o", str(out), "--json"]) == 0
    summary = json.loads(capsys.readouterr().out)
    assert summary["is_isostatic"] == 1.0
    jammed = read_packing(out)
    assert jammed.metadata["algorithm"] == "calippso"
    assert jammed.phi == pytest.approx(summary["phi"])
    assert jammed.metadata["parameters"]["constraint_generation"] is False
    out2 = tmp_path / "out2.h5"
    assert main(["calippso", str(src), "-o", str(out2), "--json", "--constraint-generation"]) == 0
    assert json.loads(capsys.readouterr().out)["is_isostatic"] == 1.0
    assert read_packing(out2).metadata["parameters"]["constraint_generation"] is True
    # the LP path: by N when not given (N = 96 is below the rule's N: vertices), forced by --interior-steps
    assert jammed.metadata["parameters"]["interior_steps"] is False
    assert main(["calippso", str(src), "-o", str(out2), "--interior-steps"]) == 0
    assert read_packing(out2).metadata["parameters"]["interior_steps"] is True


def test_cli_solver_choice_is_recorded(tmp_path, capsys, ls_jammed_256):
    from spherejam.calippso.lp import SOLVERS
    from spherejam.calippso.solution import SOLVER_CODES
    from spherejam.cli import build_parser, main
    from spherejam.core.packing_io import read_packing, write_packing

    src, out = tmp_path / "in.h5", tmp_path / "out.h5"
    write_packing(src, ls_jammed_256)
    assert main(["calippso", str(src), "-o", str(out), "--solver", "ipx", "--crossover", "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["is_isostatic"] == 1.0
    parameters = read_packing(out).metadata["parameters"]
    assert parameters["solver"] == "ipx" and parameters["crossover"] is True and parameters["threads"] == 1
    assert main(["calippso", str(src), "-o", str(out), "--solver", "gurobi"]) == 2
    assert "--solver" in capsys.readouterr().err
    # the CLI's choices (not imported from calippso, to keep --help fast) are the solver list
    action = next(a for a in build_parser()._subparsers._group_actions[0].choices["calippso"]._actions
                  if a.dest == "solver")
    assert tuple(action.choices) == ("auto", *SOLVERS)
    assert set(SOLVER_CODES) == {"none", *SOLVERS}


def test_cli_lp_log_survives_a_resume(tmp_path, capsys):
    """--lp-log: one CSV row per LP; a run stopped at --max-iterations and resumed from its checkpoint continues the
    file, which then holds the uninterrupted run's rows; --schedule is recorded."""
    import csv

    from spherejam.cli import main
    from spherejam.core.packing_io import read_packing, write_packing

    src, out, ckpt = tmp_path / "in.h5", tmp_path / "out.h5", tmp_path / "c.h5"
    write_packing(src, rsa_packing(96, 0.35, 3, seed=5))
    whole, part = tmp_path / "whole.csv", tmp_path / "part.csv"
    assert main(["calippso", str(src), "-o", str(out), "--schedule", "reference", "--lp-log", str(whole)]) == 0
    assert read_packing(out).metadata["parameters"]["schedule"] == "reference"
    args = ["calippso", str(src), "-o", str(out), "--schedule", "reference", "--lp-log", str(part),
            "--checkpoint", str(ckpt)]
    assert main([*args, "--max-iterations", "5"]) == 1 and ckpt.exists()
    assert main(args) == 0 and not ckpt.exists()
    capsys.readouterr()

    def rows(path):
        with open(path, newline="") as fh:
            return [{k: v for k, v in r.items() if not k.endswith("_s")} for r in csv.DictReader(fh)]  # no timings

    assert len(rows(whole)) > 5 and rows(part) == rows(whole)
