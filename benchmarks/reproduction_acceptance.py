"""The acceptance of the reproduction run (docs/reproduction.md): our Tables 2-4 against the paper's, and the run's
measured cost.

    python benchmarks/reproduction_acceptance.py results-reproduction

reads ``RESULTS/tables/table{2,3,4}.csv`` (written by ``spherejam tables``, with the paper's values beside ours) and
the Snakemake benchmark files ``RESULTS/benchmarks/<stage>/**/*.tsv``, and prints two Markdown tables:

* one row per criterion, for sigma = 0 and 0.3: phi_LT and phi_RCP within +- 0.003 of Table 4; the Table 3 minima
  and maxima within +- 0.004; phi_GCP of the LS-initial and FB-initial rows of Table 2 at sigma = 0.3 within +- 0.004
  with a 95 % half-width below 0.004; phi_GCP - phi_RCP within +- 0.003 of the paper's. A criterion whose paper cell
  or our cell is missing is "not decidable";
* the CPU time per stage (jobs, CPU hours, mean, median and largest CPU seconds per job) and the total.
"""

from __future__ import annotations

import argparse
import csv
import math
import statistics
import sys
from pathlib import Path

SIGMAS = (0.0, 0.3)
TABLE4_TOLERANCE = 0.003
TABLE3_TOLERANCE = 0.004
GCP_TOLERANCE = 0.004
GCP_MAX_HALF_WIDTH = 0.004
GAP_TOLERANCE = 0.003


def _number(text) -> float | None:
    try:
        value = float(text)
    except (TypeError, ValueError):
        return None
    return value if math.isfinite(value) else None


def _fmt(value: float | None) -> str:
    return "–" if value is None else f"{value:.4f}"


def _rows(tables: Path, name: str) -> list[dict[str, str]]:
    path = tables / f"{name}.csv"
    if not path.is_file():
        raise SystemExit(f"{path}: not found (run the workflow, or `spherejam tables`, first)")
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


def _by_sigma(rows: list[dict[str, str]]) -> dict[float, dict[str, str]]:
    return {round(float(r["sigma"]), 6): r for r in rows}


def criterion(name: str, sigma: float, paper: float | None, ours: float | None, tolerance: float,
              also: bool = True, detail: str = "") -> dict:
    """One acceptance row: met iff |ours - paper| <= tolerance and ``also``; "not decidable" if a value is missing."""
    if paper is None or ours is None:
        verdict, diff = "not decidable", None
    else:
        diff = ours - paper
        verdict = "yes" if abs(diff) <= tolerance and also else "**no**"
    return {"criterion": name, "sigma": sigma, "paper": paper, "ours": ours, "detail": detail, "diff": diff,
            "met": verdict}


def acceptance(tables: Path) -> list[dict]:
    """The criteria of docs/reproduction.md, evaluated on a folder of ``spherejam tables`` CSV files."""
    t2, t3, t4 = _rows(tables, "table2"), _by_sigma(_rows(tables, "table3")), _by_sigma(_rows(tables, "table4"))
    out = []
    for s in SIGMAS:
        if s in t4:
            r = t4[s]
            for q in ("LT", "RCP"):
                out.append(criterion(f"φ_{q} ± {TABLE4_TOLERANCE} (Table 4)", s, _number(r[f"phi_{q}_paper"]),
                                     _number(r[f"phi_{q}"]), TABLE4_TOLERANCE))
    for s in SIGMAS:
        if s in t3:
            r = t3[s]
            for p in ("ls", "fb"):
                n = f" (n = {r[f'{p}_n_fast']})"
                out.append(criterion(f"Table 3 {p.upper()} φ_min^fast ± {TABLE3_TOLERANCE}", s,
                                     _number(r[f"{p}_phi_low_paper"]), _number(r[f"{p}_phi_min_fast"]),
                                     TABLE3_TOLERANCE, detail=n))
                out.append(criterion(f"Table 3 {p.upper()} φ_max^fast ± {TABLE3_TOLERANCE}", s,
                                     _number(r[f"{p}_phi_high_paper"]), _number(r[f"{p}_phi_max_fast"]),
                                     TABLE3_TOLERANCE, detail=n))
    for r in t2:
        if abs(float(r["sigma"]) - 0.3) < 1e-9 and r["curve"] in ("LS, initial", "FB, initial"):
            hw = _number(r["half_width_fit"])
            detail = f" ± {_fmt(hw)} (n = {r['n_points']}; {r['status'] or 'estimable'})"
            out.append(criterion(f"φ_GCP {r['curve']} ± {GCP_TOLERANCE}, half-width < {GCP_MAX_HALF_WIDTH}", 0.3,
                                 _number(r["paper_phi_gcp"]), _number(r["phi_gcp_fit"]), GCP_TOLERANCE,
                                 also=hw is not None and hw < GCP_MAX_HALF_WIDTH, detail=detail))
    for s in SIGMAS:
        if s in t4:
            r = t4[s]
            g, rc, gp, rp = (_number(r[k]) for k in ("phi_GCP", "phi_RCP", "phi_GCP_paper", "phi_RCP_paper"))
            out.append(criterion(f"φ_GCP − φ_RCP ≈ 0.01 (± {GAP_TOLERANCE})", s,
                                 None if gp is None or rp is None else gp - rp,
                                 None if g is None or rc is None else g - rc, GAP_TOLERANCE))
    return out


def acceptance_markdown(rows: list[dict]) -> str:
    lines = ["| criterion | σ | paper | ours | ours − paper | met? |", "| --- | --- | --- | --- | --- | --- |"]
    for r in rows:
        diff = "–" if r["diff"] is None else f"{r['diff']:+.4f}"
        lines.append(f"| {r['criterion']} | {r['sigma']:g} | {_fmt(r['paper'])} | {_fmt(r['ours'])}{r['detail']} "
                     f"| {diff} | {r['met']} |")
    met = sum(r["met"] == "yes" for r in rows)
    decidable = sum(r["met"] != "not decidable" for r in rows)
    lines.append("")
    lines.append(f"{met} of {decidable} decidable criteria met ({len(rows) - decidable} not decidable).")
    return "\n".join(lines)


def cost_markdown(benchmarks: Path) -> str:
    """CPU time per workflow stage from Snakemake's benchmark files (the last line of each file: its last run)."""
    lines = ["| stage | jobs | CPU h | mean CPU s | median CPU s | max CPU s |",
             "| --- | ---: | ---: | ---: | ---: | ---: |"]
    total = 0.0
    stages = sorted(p for p in benchmarks.iterdir() if p.is_dir()) if benchmarks.is_dir() else []
    for stage in stages:
        cpu = []
        for f in stage.rglob("*.tsv"):
            with open(f, newline="") as fh:
                rows = list(csv.DictReader(fh, delimiter="\t"))
            if rows and _number(rows[-1].get("cpu_time")) is not None:
                cpu.append(float(rows[-1]["cpu_time"]))
        if cpu:
            total += sum(cpu)
            lines.append(f"| {stage.name} | {len(cpu)} | {sum(cpu) / 3600:.2f} | {statistics.mean(cpu):.1f} | "
                         f"{statistics.median(cpu):.1f} | {max(cpu):.1f} |")
    lines.append(f"| total | | {total / 3600:.2f} | | | |")
    return "\n".join(lines)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("results", type=Path, help="the run's results folder (e.g. results-reproduction)")
    args = ap.parse_args(argv)
    print("### Acceptance, measured\n")
    print(acceptance_markdown(acceptance(args.results / "tables")))
    print("\n### Measured cost (Snakemake benchmark files)\n")
    print(cost_markdown(args.results / "benchmarks"))
    return 0


if __name__ == "__main__":
    sys.exit(main())
