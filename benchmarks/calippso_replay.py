"""Replay a CALiPPSO LP whose interior point's vertex was not certified (issue 46, docs/calippso.md §10.21).

    python benchmarks/calippso_replay.py capture FIXTURE.h5 CHECKPOINT.h5 LP.pkl
    python benchmarks/calippso_replay.py certify LP.pkl
    python benchmarks/calippso_replay.py interior LP.pkl

``capture`` resumes a *copy* of a run's checkpoint (the run's own files are never touched) on the code it is run
with, and stops at the first LP whose HiPO interior point the active-set solve does not certify, after saving that
LP and HiGHS's solution to ``LP.pkl`` (exit status 3; 0 if the run converged first). Checkpoints are written every
300 s, so the LPs between the checkpoint and the failing one are solved again: resumed runs are deterministic, so it
is the run's own LP. ``certify`` times the certification of the saved interior point (``lp._certified_vertex``, as
the run calls it) on the code it is run with, so a change to the prediction or to the pivots can be judged on the
LP that failed without a HiPO solve; ``interior`` checks the interior point as a step (``lp._interior_point``) and
prints its sqrt(Gamma) - 1 and largest displacement.
"""

from __future__ import annotations

import argparse
import math
import os
import pickle
import shutil
import sys
import time
from types import SimpleNamespace

import numpy as np

CAPTURED = 3


def capture(fixture: str, checkpoint: str, out: str) -> int:
    from spherejam.calippso import lp
    from spherejam.cli import main

    work = out + ".ckpt.h5"
    shutil.copy(checkpoint, work)
    certified_vertex = lp._certified_vertex

    def saving(h, model, tolerance):
        found = certified_vertex(h, model, tolerance)
        if found[2] is not None:
            sol = h.getSolution()
            args = {k: getattr(model, k) for k in ("rij", "sigma2", "pi", "pj", "n", "s_bound", "pinned",
                                                   "inflation_bounds", "scale")}
            with open(out + ".tmp", "wb") as fh:
                pickle.dump({"args": args, "tolerance": tolerance, "problem": found[2],
                             "col": np.asarray(sol.col_value), "row": np.asarray(sol.row_value),
                             "row_dual": np.asarray(sol.row_dual), "col_dual": np.asarray(sol.col_dual)}, fh)
            os.replace(out + ".tmp", out)
            print(f"captured in {out}: {found[2]}", flush=True)
            os._exit(CAPTURED)  # the run must not go on to a fallback
        return found

    lp._certified_vertex = saving
    return main(["calippso", fixture, "-o", out + ".out.h5", "--lp-log", out + ".lps.csv", "--checkpoint", work])


def _load(path: str):
    from spherejam.calippso import lp

    with open(path, "rb") as fh:
        saved = pickle.load(fh)
    model = lp._Model.build(**saved["args"])
    sol = SimpleNamespace(value_valid=True, dual_valid=True, col_value=saved["col"], row_value=saved["row"],
                          row_dual=saved["row_dual"], col_dual=saved["col_dual"])
    print(f"captured: {saved['problem']}")
    return saved, model, sol


def certify(path: str) -> int:
    from spherejam.calippso import lp

    saved, model, sol = _load(path)
    t = time.process_time()
    vertex, _, problem = lp._certified_vertex(SimpleNamespace(getSolution=lambda: sol), model, saved["tolerance"])
    cpu = time.process_time() - t
    if problem is None:
        print(f"certified in {cpu:.1f} CPU-s: {vertex.method}, sqrt(Gamma) - 1 = {math.sqrt(vertex.inflation) - 1:.4e}")
        return 0
    print(f"not certified ({cpu:.1f} CPU-s): {problem}")
    return 1


def interior(path: str) -> int:
    import highspy

    from spherejam.calippso import lp

    saved, model, sol = _load(path)
    h = SimpleNamespace(getSolution=lambda: sol, getModelStatus=lambda: highspy.HighsModelStatus.kOptimal)
    step, problem = lp._interior_point(h, model, saved["tolerance"])
    if problem is not None:
        print(f"not a step: {problem}")
        return 1
    print(f"a step: sqrt(Gamma) - 1 = {math.sqrt(step.inflation) - 1:.4e}, max |s| = {np.abs(step.s).max():.3e} "
          "(the LP's units: initial largest diameters)")
    return 0


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    sub = parser.add_subparsers(dest="command", required=True)
    c = sub.add_parser("capture", help="resume a copy of a checkpoint up to its first uncertified interior point")
    c.add_argument("fixture")
    c.add_argument("checkpoint")
    c.add_argument("out")
    for name in ("certify", "interior"):
        sub.add_parser(name).add_argument("lp")
    args = parser.parse_args(argv)
    if args.command == "capture":
        return capture(args.fixture, args.checkpoint, args.out)
    return {"certify": certify, "interior": interior}[args.command](args.lp)


if __name__ == "__main__":
    sys.exit(main())
