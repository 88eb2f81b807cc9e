"""The acceptance of the reproduction run (docs/reproduction.md): our Tables 2-4 against the paper's, and the run's
measured cost.

    python benchmarks/reproduction_acceptance.py results-reproduction            # a ladder: at N = 10^4, extrapolated
    python benchmarks/reproduction_acceptance.py results-reproduction --n 1000   # at one measured N of it

reads ``RESULTS/tables/table{2,3,4}.csv`` (written by ``spherejam tables``, with the paper's values beside ours) and
the Snakemake benchmark files ``RESULTS/benchmarks/**/*.tsv``, and prints two Markdown tables. Tables with a column
``n`` (a ladder of N) are judged on the rows of ``--n``: by default the rows extrapolated to the paper's N = 10^4
(docs/finite_size.md), with the tolerances unchanged.

* one row per criterion, for sigma = 0 and 0.3: phi_LT and phi_RCP within +- 0.003 of Table 4; the Table 3 minima
  and maxima within +- 0.004; phi_GCP of the LS-initial and FB-initial rows of Table 2 at sigma = 0.3 within +- 0.004
  with a 95 % half-width below 0.004; phi_GCP - phi_RCP within +- 0.003 of the paper's. A criterion whose paper cell
  or our cell is missing is "not decidable";
* the cost per N and stage from the benchmark files (jobs, core-hours of job wall time, mean, median and largest
  seconds per job) and the total;
* the cost per N and size distribution from ``RESULTS/dataset.nc`` (or the part datasets given with ``--datasets``):
  the times each packing's runs record (generation, MLS, CALiPPSO), which add up over a run stopped and resumed
  from its checkpoint and travel with the dataset, where the benchmark files count a job's last run only and stay
  on the machine that ran it.
"""

from __future__ import annotations

import argparse
import csv
import math
import re
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


def _at_n(rows: list[dict[str, str]], n: float | None) -> list[dict[str, str]]:
    """The rows of one N (tables of a ladder have a column n); all rows of a table without it."""
    if not rows or "n" not in rows[0] or n is None:
        return rows
    return [r for r in rows if float(r["n"]) == n]


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


#: The paper's N: the rows a ladder's tables are judged on by default (extrapolated there).
PAPER_N = 10_000.0


def acceptance(tables: Path, n: float | None = PAPER_N) -> list[dict]:
    """The criteria of docs/reproduction.md, evaluated on a folder of ``spherejam tables`` CSV files (at N = ``n``
    if the tables have rows per N)."""
    t2 = _at_n(_rows(tables, "table2"), n)
    t3, t4 = (_by_sigma(_at_n(_rows(tables, name), n)) for name in ("table3", "table4"))
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
            extrapolated = r.get("extrapolated") == "True"
            for p in ("ls", "fb"):
                what = "expected for" if extrapolated else "n ="
                n_fast = f" ({what} {r[f'{p}_n_fast']}"
                for side, edge in (("low", "min"), ("high", "max")):
                    half = _number(r.get(f"{p}_phi_{side}_half_width")) if extrapolated else None
                    detail = n_fast + (f"; ± {half:.4f}" if half is not None else "") + ")"
                    out.append(criterion(f"Table 3 {p.upper()} φ_{edge}^fast ± {TABLE3_TOLERANCE}", s,
                                         _number(r[f"{p}_phi_{side}_paper"]), _number(r[f"{p}_phi_{edge}_fast"]),
                                         TABLE3_TOLERANCE, detail=detail))
    for r in t2:
        if abs(float(r["sigma"]) - 0.3) < 1e-9 and r["curve"] in ("LS, initial", "FB, initial"):
            # a measured fit's own value (before the max_half_width cut); an extrapolated one has only its own
            fit = "" if r.get("extrapolated") == "True" else "_fit"
            hw = _number(r[f"half_width{fit}"])
            detail = f" ± {_fmt(hw)} (n = {r['n_points']}; {r['status'] or 'estimable'})"
            out.append(criterion(f"φ_GCP {r['curve']} ± {GCP_TOLERANCE}, half-width < {GCP_MAX_HALF_WIDTH}", 0.3,
                                 _number(r["paper_phi_gcp"]), _number(r[f"phi_gcp{fit}"]), GCP_TOLERANCE,
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


_SIZE = re.compile(r"n(\d+)")


def _stage_and_n(relative: Path) -> tuple[str, str]:
    """A benchmark file's stage and N from its path below ``benchmarks/``: ``mls/n250/ls/...`` or, for LS and FB
    jobs (filed by run key), ``n250/ls/...``; ``-`` for the N of a single-N run."""
    parts = relative.parts
    sizes = [m.group(1) for p in parts[:2] if (m := _SIZE.fullmatch(p))]
    stage = parts[1] if _SIZE.fullmatch(parts[0]) else parts[0]
    return stage, sizes[0] if sizes else "-"


def cost_markdown(benchmarks: Path) -> str:
    """Core-hours per N and workflow stage from Snakemake's benchmark files (the last line of each file: its last
    run): the job's wall time ``s``, one core each (every job is single-threaded at ``calippso.threads: 1``).

    Not the files' ``cpu_time``: Snakemake samples it every 30 s after a job's first 15 s, so the CPU of a job's last
    sampling gap is lost (half of a one-minute MLS search; docs/reproduction.md, "Measured cost"). The wall time is
    exact, and equals the CPU time when the jobs do not share a core."""
    lines = ["| N | stage | jobs | core-h | mean s | median s | max s |",
             "| --- | --- | ---: | ---: | ---: | ---: | ---: |"]
    seconds: dict[tuple[str, str], list[float]] = {}
    for f in sorted(benchmarks.rglob("*.tsv")) if benchmarks.is_dir() else []:
        with open(f, newline="") as fh:
            rows = list(csv.DictReader(fh, delimiter="\t"))
        if rows and _number(rows[-1].get("s")) is not None:
            stage, n = _stage_and_n(f.relative_to(benchmarks))
            seconds.setdefault((n, stage), []).append(float(rows[-1]["s"]))
    key = sorted(seconds, key=lambda k: (int(k[0]) if k[0].isdigit() else 0, k[1]))
    for n, stage in key:
        c = seconds[n, stage]
        lines.append(f"| {n} | {stage} | {len(c)} | {sum(c) / 3600:.2f} | {statistics.mean(c):.1f} | "
                     f"{statistics.median(c):.1f} | {max(c):.1f} |")
    sizes = sorted({n for n, _ in seconds}, key=lambda n: int(n) if n.isdigit() else 0)
    if len(sizes) > 1:
        for n in sizes:
            lines.append(f"| {n} | all | | {sum(sum(c) for k, c in seconds.items() if k[0] == n) / 3600:.2f} | | | |")
    lines.append(f"| total | | | {sum(sum(c) for c in seconds.values()) / 3600:.2f} | | | |")
    return "\n".join(lines)


#: The dataset's per-packing run times (seconds) and the stage each belongs to.
RUN_TIMES = {"generation": "generation_wall_time", "MLS": "mls_wall_time", "CALiPPSO": "calippso_wall_time"}


def dataset_cost_markdown(paths: list[Path]) -> str:
    """Core-hours per N and size distribution from the run times recorded in datasets (``spherejam dataset`` or
    the parts of a run), one row per (N, distribution), a total row."""
    import numpy as np
    import xarray as xr

    lines = ["| N | distribution | packings | " + " | ".join(f"{stage} h" for stage in RUN_TIMES) + " | total h |",
             "| ---: | --- | ---: | " + " | ".join("---:" for _ in RUN_TIMES) + " | ---: |"]
    rows = []
    for path in paths:
        with xr.open_dataset(path) as ds:
            for n, dist in sorted({(int(n), str(d)) for n, d in zip(ds["n"].values, ds["distribution"].values)}):
                pick = (ds["n"].values == n) & (ds["distribution"].values == dist)
                rows.append((n, dist, int(pick.sum()), {stage: float(np.nansum(ds[var].values[pick])) / 3600
                                                        if var in ds else 0.0 for stage, var in RUN_TIMES.items()}))
    totals = dict.fromkeys(RUN_TIMES, 0.0)
    for n, dist, count, hours in sorted(rows, key=lambda r: r[:2]):
        for stage, h in hours.items():
            totals[stage] += h
        lines.append(f"| {n} | {dist} | {count} | " + " | ".join(f"{h:.2f}" for h in hours.values())
                     + f" | {sum(hours.values()):.2f} |")
    lines.append("| total | | | " + " | ".join(f"{h:.2f}" for h in totals.values())
                 + f" | {sum(totals.values()):.2f} |")
    return "\n".join(lines)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("results", type=Path, help="the run's results folder (e.g. results-reproduction)")
    ap.add_argument("--n", type=float, default=PAPER_N,
                    help="with a ladder of N: the rows to judge (default 10000, extrapolated; inf for the limit)")
    ap.add_argument("--datasets", type=Path, nargs="+", metavar="NC",
                    help="the datasets whose recorded run times to sum (default: RESULTS/dataset.nc, if there)")
    args = ap.parse_args(argv)
    print(f"### Acceptance at N = {args.n:g}\n")
    if (args.results / "tables").is_dir():
        print(acceptance_markdown(acceptance(args.results / "tables", args.n)))
    else:  # a run still in parts: its cost only
        print(f"not decidable: no {args.results / 'tables'} yet")
    print("\n### Measured cost (Snakemake benchmark files: job wall time, one core each)\n")
    print(cost_markdown(args.results / "benchmarks"))
    datasets = args.datasets or [p for p in [args.results / "dataset.nc"] if p.is_file()]
    if datasets:
        print("\n### Measured cost (the run times each packing records, summed over resumes)\n")
        print(dataset_cost_markdown(datasets))
    return 0


if __name__ == "__main__":
    sys.exit(main())
