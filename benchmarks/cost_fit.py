"""The cost model's fit (issue 47): its N-part and its size-distribution part, fitted, then validated.

    python benchmarks/cost_fit.py fit WIDE.jsonl [WIDE.jsonl ...] [--fit bi3,bi5,bi10] [--records CSV ...]
    python benchmarks/cost_fit.py rows

Two fits, each on its own measurements, none on the PSD acceptance rows (docs/algorithms.md §7.9):

1. *MLS collisions per particle against N* (equal spheres): A (N / 1000)^e, least squares in log, on the reproduction
   ladder's MLS searches from fast starts at sigma = 0 (``archive/reproduction/dataset.nc``: N = 250, 500, 1000, 32
   each) and the five N = 10^4 searches of the band check (:data:`MLS_1E4`). The package holds A as
   ``MLS_PHASE_FRACTION`` times the paper ladder's summed LS collisions, and e as ``MLS_SIZE_EXPONENT``.
2. *The size distribution's slow-down against N*: S = 1 + b (N / 1000)^-beta (W - 1), W the pair load of the start's
   diameters (the lists' load, times M where the largest sphere spans enough of the box for the engine's multi-image
   mode: b and beta fitted on the single-image rows, then M on the multi-image ones), S = the monodisperse rate of
   the same invocation over the distribution's (LS at gamma = 1e-2 from phi = 0.58 to p = 1e12;
   ``benchmarks/bench_ls.py wide --n N --out WIDE.jsonl``, one invocation per N), fitted in log S to the ``--fit``
   distributions at every N; the others are held out.

``fit`` prints the two fits and the tables; ``rows`` prints the PSD acceptance rows (docs/psd.md §8, their recorded
CPU minutes of whole ``spherejam rcp`` calls) against the package's model as it is: the out-of-fit check.
"""

from __future__ import annotations

import argparse
import copy
import json
import math
import os
import statistics
import sys
from pathlib import Path

import numpy as np
import yaml

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_ls import wide_start  # noqa: E402

from spherejam.workflow import cost_model, pair_load  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
#: MLS collisions of the five N = 10^4 searches of the band check (sigma = 0, fast LS start, the paper's ladder;
#: docs/cluster.md §3, `benchmarks/mls_science.py`).
MLS_1E4 = (5.98e9, 11.33e9, 9.19e9, 11.33e9, 16.0e9)


def _psd_rows(path: Path) -> dict[str, tuple[str, int, float]]:
    import csv

    with open(path, newline="") as f:
        rows = csv.DictReader(line for line in f if not line.startswith("#"))
        return {r["row"]: (r["spec"], int(r["n"]), float(r["cpu_minutes"])) for r in rows}


#: The PSD acceptance rows, row -> (spec, N, measured CPU minutes) (docs/psd.md §8).
PSD_ROWS = _psd_rows(ROOT / "benchmarks" / "records" / "psd_acceptance_cpu.csv")


def _config(spec: str, n: int) -> dict:
    config = copy.deepcopy(yaml.safe_load((ROOT / "config" / "psd.yaml").read_text()))
    config.update(distributions={"row": spec}, n=n, replicas=1, results="/nonexistent")
    return config


def psd_row_minutes(spec: str, n: int) -> float:
    """The cost model's CPU minutes of one acceptance row, `spherejam rcp NAME=SPEC --n N --replicas 1`: its jobs'
    work (:func:`spherejam.workflow.cost_model.plan`; the jobs' start-up is not in the model's expected CPU)."""
    [table] = cost_model.plan(_config(spec, n)).values()
    return 60.0 * sum(r["cpu_hours"] for r in table.values())


# --- 1. MLS collisions per particle against N ----------------------------------------------------------------------
def mls_points() -> list[tuple[int, float, int]]:
    """(N, mean MLS collisions per particle, searches): the reproduction ladder's fast starts at sigma = 0, and the
    N = 10^4 searches."""
    import xarray as xr

    ds = xr.open_dataset(ROOT / "archive" / "reproduction" / "dataset.nc", engine="h5netcdf")
    n, proto, sigma = ds["n"].values, ds["protocol"].values, ds["sigma"].values
    inv, coll = ds["inverse_rate"].values, ds["mls_collisions"].values
    fast = ((proto == "ls") & (inv < 5)) | ((proto == "fb") & (inv < 1000))
    out = []
    for size in sorted(set(n.tolist())):
        pick = fast & (sigma == 0.0) & (n == size)
        out.append((int(size), float(np.mean(coll[pick] / size)), int(pick.sum())))
    out.append((10000, float(np.mean(MLS_1E4)) / 10000, len(MLS_1E4)))
    return out


def fit_mls(points) -> tuple[float, float]:
    """A, e of A (N / 1000)^e through the means (least squares in log, each N one point)."""
    x = np.log([p[0] / 1000.0 for p in points])
    y = np.log([p[1] for p in points])
    e, a = np.polyfit(x, y, 1)
    return float(math.exp(a)), float(e)


# --- 2. the size distribution's slow-down --------------------------------------------------------------------------
def ls_rows(paths, records=()) -> list[dict]:
    """Per (N, distribution) over the invocations given: the median slow-down S against the monodisperse run of the
    same invocation, the median collisions per sphere relative to it, and W of the start's diameters. ``records``:
    CSV files of earlier invocations' figures (``n,dist,rate_over_mono,collisions_over_mono,source``), used for an
    (N, distribution) that no invocation given measured."""
    import csv

    cwd = os.getcwd()
    os.chdir(ROOT)  # the powder's table is relative to the repository
    try:
        runs: dict[tuple[int, str], list[dict]] = {}
        for path in records:
            with open(path, newline="") as f:
                for r in csv.DictReader(line for line in f if not line.startswith("#")):
                    runs.setdefault((int(r["n"]), r["dist"]), []).append(
                        {"slow": 1.0 / float(r["rate_over_mono"]), "coll": float(r["collisions_over_mono"]),
                         "per_s": float("nan"), "record": True})
        for path in paths:
            for line in Path(path).read_text().splitlines():
                r = json.loads(line)
                if r.get("tree", "after") != "after":
                    continue
                t = r["timed"]
                if t.get("stop") != "p_max":  # e.g. 1:10 at N = 300 stops at self-contact: no jamming to price
                    print(f"left out: N = {t['n']} {t['dist']} stopped by {t.get('stop')}")
                    continue
                key = (t["n"], t["dist"])
                if any(x.get("record") for x in runs.get(key, [])):
                    runs[key] = []  # measured here: the record is not needed
                runs.setdefault(key, []).append(
                    {"slow": r["mono_per_s"] / t["per_s"], "coll": t["collisions"] / r["mono_collisions"],
                     "per_s": t["per_s"]})
        out = []
        for (n, dist), rs in sorted(runs.items()):
            diameters = wide_start(n, dist, prepare=False).diameters.tolist()
            span = pair_load.image_span(diameters)
            out.append({"n": n, "dist": dist, "lists": pair_load.list_load(diameters), "span": span,
                        "multi": span >= pair_load.MULTI_IMAGE_SPAN,
                        "runs": "record" if rs[0].get("record") else len(rs),
                        "slow": statistics.median(r["slow"] for r in rs),
                        "coll": statistics.median(r["coll"] for r in rs),
                        "per_s": statistics.median(r["per_s"] for r in rs)})
        return out
    finally:
        os.chdir(cwd)


def _factor(d: dict, b: float, beta: float, multi: float) -> float:
    load = d["lists"] * (multi if d["multi"] else 1.0)
    return 1.0 + b * (d["n"] / 1000.0) ** (-beta) * max(load - 1.0, 0.0)


def fit_distribution(data: list[dict]) -> tuple[float, float, float]:
    """b, beta on the single-image rows, then the multi-image factor on the others (given b, beta), each minimising
    sum (log S - log(1 + b (N / 1000)^-beta (W - 1)))^2 (a grid, then refined)."""
    single = [d for d in data if not d["multi"]]
    multi = [d for d in data if d["multi"]]

    def loss(rows, b, beta, m):
        return sum((math.log(d["slow"]) - math.log(_factor(d, b, beta, m))) ** 2 for d in rows)

    _, b0, beta0 = min((loss(single, b, beta, 1.0), b, beta) for b in np.linspace(0.01, 2.0, 200)
                       for beta in np.linspace(-0.5, 1.0, 151))
    _, b, beta = min((loss(single, b, beta, 1.0), b, beta) for b in np.linspace(max(b0 - 0.01, 1e-3), b0 + 0.01, 41)
                     for beta in np.linspace(beta0 - 0.01, beta0 + 0.01, 41))
    m = 1.0
    if multi:
        grid = np.linspace(1.0, 20.0, 1901)
        m = float(grid[int(np.argmin([loss(multi, b, beta, x) for x in grid]))])
    return float(b), float(beta), m


def fit_per_n(data: list[dict]) -> dict[int, float]:
    """b of 1 + b (W - 1) at each N alone (single-image rows, beta = 0), for the table."""
    out = {}
    for n in sorted({d["n"] for d in data}):
        rows = [d for d in data if d["n"] == n and not d["multi"]]
        if not rows:
            continue
        grid = np.linspace(0.0, 3.0, 3001)
        losses = [sum((math.log(d["slow"]) - math.log(1.0 + a * (d["lists"] - 1.0))) ** 2 for d in rows) for a in grid]
        out[n] = float(grid[int(np.argmin(losses))])
    return out


def print_rows() -> None:
    from spherejam.core.size_distribution import parse

    print("PSD acceptance rows (docs/psd.md §8; never in a fit), the package's model:")
    print("| row | N | W | measured CPU min | estimate | estimate / measured | row / mono row (measured) | "
          "estimate / mono estimate |")
    print("|---|---|---|---|---|---|---|---|")
    cwd = os.getcwd()
    os.chdir(ROOT)
    try:
        mono = {n: (measured, psd_row_minutes(spec, n)) for spec, n, measured in PSD_ROWS.values()
                if spec == "lognormal:sigma=0"}
        errors, inside = [], 0
        for name, (spec, n, measured) in PSD_ROWS.items():
            load = cost_model.pair_load(parse(spec).draw(n, np.random.default_rng(0)).tolist())
            est = psd_row_minutes(spec, n)
            errors.append(est / measured - 1.0)
            inside += measured / 1.3 < est < measured * 1.3
            print(f"| {name} | {n} | {load:.2f} | {measured:.1f} | {est:.1f} | {est / measured:.2f} | "
                  f"{measured / mono[n][0]:.2f} | {est / mono[n][1]:.2f} |")
        print(f"within a factor 1.3 either way (the tests' band): {inside} of {len(errors)}; mean error "
              f"{np.mean(errors):+.1%}, largest "
              f"{max(errors, key=abs):+.1%}")
    finally:
        os.chdir(cwd)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("mode", choices=("fit", "rows"))
    ap.add_argument("runs", nargs="*", help="fit: `bench_ls.py wide --out` files, one or more per N")
    ap.add_argument("--fit", default="bi3,bi5,bi10", help="distributions in the slow-down's fit (others: held out)")
    ap.add_argument("--records", nargs="*", default=[str(ROOT / "benchmarks" / "records" / "cost_fit" /
                                                           "ls_slowdown_n10000.csv")],
                    help="CSV records of earlier invocations, for what the runs given do not measure")
    args = ap.parse_args()
    if args.mode == "rows":
        print_rows()
        return 0

    points = mls_points()
    a, e = fit_mls(points)
    paper = sum(cost_model.ls_collisions_per_particle(g) for g in cost_model.mls_rates(10.0, 2.0, 1e-4))
    print(f"1. MLS collisions per particle (sigma = 0, fast starts, paper ladder) = A (N/1000)^e: A = {a:.4g}, "
          f"e = {e:.3f}; MLS_PHASE_FRACTION = A / {paper:.4g} (the ladder's summed LS collisions) = {a / paper:.3f}")
    print("| N | searches | measured mean per particle | fit | package |")
    print("|---|---|---|---|---|")
    for n, mean, k in points:
        print(f"| {n} | {k} | {mean:.3g} | {a * (n / 1000) ** e:.3g} | "
              f"{cost_model.mls_collisions_per_particle(n=n):.3g} |")

    if args.runs or args.records:
        data = ls_rows(args.runs, args.records)
        fit_set = args.fit.split(",")
        in_fit = [d for d in data if d["dist"] in fit_set]
        b, beta, m = fit_distribution(in_fit)
        print(f"\n2. slow-down S = 1 + b (N/1000)^-beta (W - 1), W = the lists' load x M where the largest "
              f"sphere spans >= {pair_load.MULTI_IMAGE_SPAN} L; fitted to {len(in_fit)} rows ({args.fit} at every N): "
              f"b = {b:.3f}, beta = {beta:.3f} (single-image rows), M = {m:.2f} (multi-image rows) (package: "
              f"{cost_model.DISTRIBUTION_COEFFICIENT}, {cost_model.DISTRIBUTION_SIZE_EXPONENT}, "
              f"{pair_load.MULTI_IMAGE_FACTOR}); b at each N alone: "
              + ", ".join(f"{n}: {v:.3f}" for n, v in fit_per_n(in_fit).items()))
        monos = {d["n"]: d["per_s"] for d in data if d["dist"] == "mono" and math.isfinite(d["per_s"])}
        print("monodisperse LS rate, M collisions per CPU second: "
              + ", ".join(f"N = {n}: {v / 1e6:.3f}" for n, v in sorted(monos.items())))
        print("| N | distribution | lists' load | D_max / L | runs | rate / mono | S | model S | model / S | in fit | "
              "collisions / mono |")
        print("|---|---|---|---|---|---|---|---|---|---|---|")
        errors = {True: [], False: []}
        for d in data:
            model = _factor(d, b, beta, m)
            inside = d in in_fit
            if d["dist"] != "mono":
                errors[inside].append(model / d["slow"] - 1.0)
            print(f"| {d['n']} | {d['dist']} | {d['lists']:.2f} | {d['span']:.2f}{' (multi)' if d['multi'] else ''} | "
                  f"{d['runs']} | {1 / d['slow']:.3f} | {d['slow']:.2f} | {model:.2f} | {model / d['slow']:.2f} | "
                  f"{'yes' if inside else 'no'} | {d['coll']:.2f} |")
        for inside, errs in errors.items():
            if errs:
                within = sum(abs(x) <= 0.3 for x in errs)
                print(f"{'in-fit' if inside else 'held-out'} rows: {len(errs)}, model error: mean "
                      f"{np.mean(errs):+.1%}, largest {max(errs, key=abs):+.1%}, within +-30 %: {within}")

    print()
    print_rows()
    return 0


if __name__ == "__main__":
    sys.exit(main())
