"""CPU seconds per CALiPPSO LP, per LP path, fitted to the measured runs in benchmarks/records/calippso/ (issue 46).

    python benchmarks/calippso_cost_fit.py

The cost model (``spherejam.workflow.cost_model``, docs/cluster.md §3) prices a certification as its LP count times
``A (N / 1000)^b`` CPU seconds per LP, per LP path: the vertex path (every LP a vertex; the default below
``core.calippso_path.INTERIOR_STEPS_MIN_N``) and interior steps (the default from there on). Each law is a power law
through two anchors; the vertex path's is two, joined at N = 4096, where its LPs become cold HiPO solves. Every
other measured row is printed against the model (model / measured), so that the rows not in the fit check it. Two
kinds of row:

* a whole run: its CPU seconds (start-up of the run, every LP and the force LP) over its LPs, from the per-input
  records of ``calippso_paths_stats.py`` (``paths/<set>/<input>/<path>.json``, pooled: total CPU over total LPs);
* LPs of a run that has not ended: the mean ``iteration_cpu_s`` of its LPs of one method from its per-LP CSV
  (``calippso/lp_log.py``); without the final vertex LPs and the force LP this is a lower bound of a whole run's
  mean.

CPU seconds are those of one process on the shared 2-core machine at the lowest priority (load 3-11): CPU time, not
wall time, but a loaded machine's caches make them somewhat larger than on an idle core.
"""

from __future__ import annotations

import csv
import glob
import json
import math
import sys
from pathlib import Path

RECORDS = Path(__file__).resolve().parent / "records" / "calippso"


def pooled(group: str, path: str) -> tuple[int, float, int, int]:
    """(N, CPU s per LP, inputs, LPs) over the ``paths/<group>/*/<path>.json`` records: total CPU over total LPs."""
    recs = [json.loads(Path(f).read_text()) for f in sorted(glob.glob(str(RECORDS / "paths" / group / "*" /
                                                                          f"{path}.json")))]
    lps = sum(r["lps"] for r in recs)
    return (recs[0]["n"] if recs else 0), (sum(r["cpu_s"] for r in recs) / lps if lps else math.nan), len(recs), lps


def lp_rows(csv_name: str, method: str | None, n: int, exclude: str | None = None) -> tuple[int, float, int]:
    """(N, mean CPU s of its LPs of ``method`` (None: every LP but those of ``exclude``), LPs) from a per-LP CSV."""
    with open(RECORDS / csv_name) as fh:
        cpu = [float(r["iteration_cpu_s"]) for r in csv.DictReader(fh)
               if method in (None, r["method"]) and r["method"] != exclude]
    return n, (sum(cpu) / len(cpu) if cpu else math.nan), len(cpu)


def whole_run(summary: str, key: str = "clean") -> tuple[int, float, int]:
    """(N, CPU s per LP, LPs) of a whole certification from its summary JSON: every LP and the force LP over its LPs."""
    rec = json.loads((RECORDS / summary).read_text())[key]
    if not rec.get("converged"):
        raise ValueError(f"{summary}: not converged")
    return rec["n"], rec["lp_cpu_s_with_force_lp"] / rec["iterations"], rec["iterations"]


def whole_runs_pooled(summaries: list[tuple[str, str]]) -> tuple[int, float, int]:
    """(N, CPU s per LP, LPs) of whole certifications at one N pooled: their CPU over their LPs."""
    runs = [whole_run(summary, key) for summary, key in summaries]
    lps = sum(r[2] for r in runs)
    return runs[0][0], sum(r[1] * r[2] for r in runs) / lps, lps


def lp_count(summary: str, key: str = "clean") -> tuple[int, float]:
    """(N, LPs) of a whole certification from its summary JSON."""
    rec = json.loads((RECORDS / summary).read_text())[key]
    if not rec.get("converged"):
        raise ValueError(f"{summary}: not converged")
    return rec["n"], float(rec["iterations"])


def power_law(a: tuple[int, float], b: tuple[int, float]) -> tuple[float, float]:
    """(A, b) of A (N / 1000)^b through two (N, seconds) points."""
    exponent = math.log(b[1] / a[1]) / math.log(b[0] / a[0])
    return a[1] / (a[0] / 1000.0) ** exponent, exponent


#: The vertex path's mean per LP at N = 1e4 over the three inputs measured there in issue 30 (docs/calippso.md §9:
#: 389, 357 and 194 s), the anchor of the model until 2026-12-05. The same LS input's vertex LP
#: took 60 s with today's code (ls10000_p1e12_s0.interior.lps.csv, LP 1), so it is shown for the record, not fitted.
VERTEX_1E4_ISSUE30 = (10_000, 313.0)


def main() -> int:
    rows: dict[str, list[tuple[str, object]]] = {
        "vertex": [
            ("30 archived N = 1000 MLS outputs, whole runs (paths/mls1000, auto)", lambda: pooled("mls1000", "auto")),
            ("10 N = 1024 LS starts at p = 1e5, whole runs (paths/ls1024, auto)", lambda: pooled("ls1024", "auto")),
            ("ls4096_p1e12 (N = 4096), every LP of the vertex path so far (run not ended)",
             lambda: lp_rows("ls4096_p1e12.vertex.lps.csv", None, 4096)),
            ("ls10000_p1e12_s0 (N = 1e4), its LPs on the default path (run not ended)",
             lambda: lp_rows("ls10000_p1e12_s0.lps.csv", None, 10_000)),
            ("ls10000_p1e12_s03_gamma1e-3 (N = 1e4, sigma = 0.3), its LPs on the default path (run not ended)",
             lambda: lp_rows("ls10000_p1e12_s03_gamma1e-3.lps.csv", None, 10_000)),
            ("three N = 1e4 inputs, 52 LPs, issue 30's code (docs/calippso.md §9; not fitted)",
             lambda: VERTEX_1E4_ISSUE30),
            ("ls16384_p1e5 (N = 16384), its LPs on the vertex path (LP 1, LPs 43 on; run not ended)",
             lambda: lp_rows("ls16384_p1e5.lps.csv", None, 16_384, exclude="interior")),
            ("mls10000_s0 (N = 1e4 MLS output), whole run on the default path",
             lambda: whole_run("mls10000_s0.summary.json")),
            ("mls10000_s0_seed2 (N = 1e4 MLS output, seed 2), whole run on the default path (the check's held-out run)",
             lambda: whole_run("mls10000_s0_seed2.summary.json", "resumed")),
            ("both N = 1e4 MLS outputs, whole runs pooled (the refit after the check failed, docs/calippso.md §10.21)",
             lambda: whole_runs_pooled([("mls10000_s0.summary.json", "clean"),
                                        ("mls10000_s0_seed2.summary.json", "resumed")])),
        ],
        "interior": [
            ("30 archived N = 1000 MLS outputs, whole runs (paths/mls1000, auto+interior)",
             lambda: pooled("mls1000", "auto+interior")),
            ("10 N = 1024 LS starts at p = 1e5, whole runs (paths/ls1024, auto+interior)",
             lambda: pooled("ls1024", "auto+interior")),
            ("ls4096_p1e12 (N = 4096), its interior steps so far (run not ended)",
             lambda: lp_rows("ls4096_p1e12.interior.lps.csv", "interior", 4096)),
            ("ls10000_p1e12_s0 (N = 1e4), its interior steps so far (run not ended)",
             lambda: lp_rows("ls10000_p1e12_s0.interior.lps.csv", "interior", 10_000)),
            ("ls16384_p1e5 (N = 16384), its interior steps so far (run not ended)",
             lambda: lp_rows("ls16384_p1e5.lps.csv", "interior", 16_384)),
        ],
    }
    # anchors, as a chain of segments: the vertex path bends at N = 4096, where its LPs become cold HiPO solves (no
    # warm start, no active-set shortcut: spherejam.calippso.lp.WARM_START_MAX_N), so it has one power law through the
    # whole runs at N = 1000 and the N = 4096 LPs, and another from there through the largest N measured; interior
    # steps are one law through N = 1000 and the largest N
    # (the upper anchor of the vertex path is the workflow's own case at the paper's N, an MLS output certified whole,
    # since 2026-12-07; it was the N = 16384 LS run's LPs, a kind of input whose LPs the shortcut does not reach)
    anchors = {"vertex": [0, 2, 9], "interior": [0, 4]}
    for path, candidates in rows.items():
        measured = []
        for label, get in candidates:
            try:
                n, t, *count = get()
            except (OSError, ValueError):  # a record not (yet) in the repo
                print(f"({path}: no record for {label})")
                n, t, count = 0, math.nan, []
            measured.append((label, n, t, count))
        chain = anchors[path]
        segments = [(measured[i][1], *power_law(measured[i][1:3], measured[j][1:3]))
                    for i, j in zip(chain, chain[1:])]
        for k, (n0, a, b) in enumerate(segments):
            print(f"\n{path}, segment {k + 1} (from N = {n0}): A = {a:.3g} s, b = {b:.3f}  "
                  f"(through rows {chain[k] + 1} and {chain[k + 1] + 1})")
        print("| row | N | measured CPU s / LP | (inputs,) LPs | model | model / measured | in the fit |")
        print("|---|---|---|---|---|---|---|")
        for k, (label, n, t, count) in enumerate(measured):
            if not n:
                continue
            _, a, b = [seg for seg in segments if seg[0] <= n or seg is segments[0]][-1]
            model = a * (n / 1000.0) ** b
            print(f"| {label} | {n} | {t:.3g} | {', '.join(map(str, count)) or '-'} | {model:.3g} | "
                  f"{model / t:.2f} | {'yes' if k in chain else 'no'} |")
    lp_counts()
    return 0


#: The LP count's first segment, fitted to the reproduction ladder's mean LPs per certification at N = 250, 500 and
#: 1000 (3.9, 6.8, 14.7; archive/reproduction/dataset.nc): 14.2 (N / 1000)^0.96 (docs/cluster.md §3).
LADDER_LPS = (14.2, 0.96)


def lp_counts() -> None:
    """The LP count per certification: the ladder's law up to N = 1000, then a power law from its value there
    through the mean of the whole N = 1e4 MLS runs in the fit; every other whole run is printed against it."""
    a, b = LADDER_LPS
    # both whole N = 1e4 MLS runs since the second, held out, failed the model's check (docs/calippso.md §10.21)
    fitted = [("mls10000_s0 (N = 1e4 MLS output)", lambda: lp_count("mls10000_s0.summary.json")),
              ("mls10000_s0_seed2 (N = 1e4 MLS output, seed 2)",
               lambda: lp_count("mls10000_s0_seed2.summary.json", "resumed"))]
    held_out = [("30 archived N = 1000 MLS outputs on today's path (paths/mls1000, auto)",
                 lambda: (lambda r: (r[0], r[3] / r[2]))(pooled("mls1000", "auto")))]
    n_fit = [get() for _, get in fitted]
    n_big = n_fit[0][0]
    mean = sum(lps for _, lps in n_fit) / len(n_fit)
    exponent = math.log(mean / a) / math.log(n_big / 1000.0)
    print(f"\nLP count: {a:g} (N/1000)^{b:g} up to N = 1000, then {a:g} (N/1000)^{exponent:.3f} "
          f"(through the mean of {len(n_fit)} whole run(s) at N = {n_big}: {mean:.1f} LPs)")
    print("| row | N | LPs | model | model / measured | in the fit |")
    print("|---|---|---|---|---|---|")
    for (label, _), (n, lps) in zip(fitted, n_fit):
        model = a * (n / 1000.0) ** (b if n <= 1000 else exponent)
        print(f"| {label} | {n} | {lps:.1f} | {model:.1f} | {model / lps:.2f} | yes |")
    for label, get in held_out:
        try:
            n, lps = get()
        except (OSError, ValueError):
            print(f"(LP count: no record for {label})")
            continue
        model = a * (n / 1000.0) ** (b if n <= 1000 else exponent)
        print(f"| {label} | {n} | {lps:.1f} | {model:.1f} | {model / lps:.2f} | no |")


if __name__ == "__main__":
    sys.exit(main())
