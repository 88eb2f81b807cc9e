"""The cost model's size-distribution factor (issue 47): fit and validation.

    python benchmarks/cost_fit.py RUN.jsonl [RUN.jsonl ...] [--fit bi1.4,bi2,bi3,bi4,bi5,bi10]

RUN.jsonl are the figures of ``benchmarks/bench_ls.py counts --out RUN.jsonl`` (LS at gamma = 1e-2 to p = 1e12 from
phi = 0.58, one file per N). For each distribution: the pair load W of its start's diameters
(:func:`spherejam.workflow.cost_model.pair_load`) and the measured slow-down S = rate of mono / rate (collisions per
CPU second, the same run). The coefficient b of S = 1 + b (W - 1) is fitted (least squares in log S) to the ``--fit``
rows only and the others are reported as held out; the time to jam relative to mono, T = S x (collisions per sphere
/ mono's), is printed beside it. Then the PSD acceptance rows of docs/psd.md §8 (their recorded CPU minutes, whole
``spherejam rcp`` calls) against the cost model as it is in the package (:func:`spherejam.workflow.cost_model.plan`
of each row's config), absolute and relative to the mono row of the same N.
"""

from __future__ import annotations

import argparse
import copy
import json
import math
import sys
from pathlib import Path

import numpy as np
import yaml

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_ls import wide_start  # noqa: E402

from spherejam.workflow import cost_model  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]

def _psd_rows(path: Path) -> dict[str, tuple[str, int, float]]:
    import csv

    with open(path, newline="") as f:
        rows = csv.DictReader(line for line in f if not line.startswith("#"))
        return {r["row"]: (r["spec"], int(r["n"]), float(r["cpu_minutes"])) for r in rows}


#: The PSD acceptance rows, row -> (spec, N, measured CPU minutes) (docs/psd.md §8).
PSD_ROWS = _psd_rows(ROOT / "benchmarks" / "records" / "psd_acceptance_cpu.csv")


def psd_row_minutes(spec: str, n: int) -> float:
    """The cost model's CPU minutes of one acceptance row: `spherejam rcp NAME=SPEC --n N --replicas 1`."""
    config = yaml.safe_load((ROOT / "config" / "psd.yaml").read_text())
    config = copy.deepcopy(config)
    config.update(distributions={"row": spec}, n=n, replicas=1, results="/nonexistent")
    [table] = cost_model.plan(config).values()
    return 60.0 * sum(r["cpu_hours"] for r in table.values())


def rows(paths) -> list[dict]:
    out = []
    for path in paths:
        for line in Path(path).read_text().splitlines():
            r = json.loads(line)
            t, n = r["timed"], r["timed"]["n"]
            mono_cpp = r["mono_collisions"] / n
            slow = r["mono_per_s"] / t["per_s"]
            load = cost_model.pair_load(wide_start(n, t["dist"], prepare=False).diameters.tolist())
            out.append({"n": n, "dist": t["dist"], "load": load, "slow": slow,
                        "time_ratio": slow * (t["collisions"] / n) / mono_cpp,
                        "rate_ratio": t["per_s"] / r["mono_per_s"], "collision_ratio": t["collisions"] / n / mono_cpp})
    return out


def fit(data: list[dict]) -> float:
    """b minimising sum (log S - log(1 + b (W - 1)))^2 over ``data`` (a dense 1-d search, then refined)."""
    def loss(a):
        return sum((math.log(d["slow"]) - math.log(1.0 + a * (d["load"] - 1.0))) ** 2 for d in data)

    grid = np.linspace(0.0, 3.0, 3001)
    best = grid[int(np.argmin([loss(a) for a in grid]))]
    fine = np.linspace(max(best - 1e-3, 0.0), best + 1e-3, 201)
    return float(fine[int(np.argmin([loss(a) for a in fine]))])


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("runs", nargs="+")
    ap.add_argument("--fit", default="bi1.4,bi2,bi3,bi4,bi5,bi10", help="distributions in the fit (others: held out)")
    args = ap.parse_args()
    data = rows(args.runs)
    in_fit = [d for d in data if d["dist"] in args.fit.split(",")]
    a = fit(in_fit)
    print(f"fit on {len(in_fit)} rows ({args.fit}): S = 1 + b (W - 1), b = {a:.3f} "
          f"(the package's DISTRIBUTION_COEFFICIENT = {cost_model.DISTRIBUTION_COEFFICIENT})")
    print("| N | distribution | W | rate / mono | S = 1 / that | model 1 + b (W - 1) | model / S | in fit | "
          "collisions / mono | time / mono |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    held = []
    for d in data:
        model = 1.0 + a * (d["load"] - 1.0)
        inside = d in in_fit
        if not inside and d["dist"] != "mono":
            held.append(model / d["slow"] - 1.0)
        print(f"| {d['n']} | {d['dist']} | {d['load']:.2f} | {d['rate_ratio']:.3f} | {d['slow']:.2f} | {model:.2f} | "
              f"{model / d['slow']:.2f} | {'yes' if inside else 'no'} | {d['collision_ratio']:.2f} | "
              f"{d['time_ratio']:.2f} |")
    if held:
        print(f"held-out rows: {len(held)}, error of the model: mean {np.mean(held):+.1%}, largest "
              f"{max(held, key=abs):+.1%}")
    print("\nPSD acceptance rows (docs/psd.md §8), the package's model:")
    print("| row | N | W | measured CPU min | estimate | estimate / measured | row / mono row (measured) | "
          "estimate / mono estimate |")
    print("|---|---|---|---|---|---|---|---|")
    from spherejam.core.size_distribution import parse

    mono = {n: (measured, psd_row_minutes(spec, n)) for spec, n, measured in PSD_ROWS.values()
            if spec == "lognormal:sigma=0"}
    for name, (spec, n, measured) in PSD_ROWS.items():
        load = cost_model.pair_load(parse(spec).draw(n, np.random.default_rng(0)).tolist())
        est = psd_row_minutes(spec, n)
        print(f"| {name} | {n} | {load:.2f} | {measured:.1f} | {est:.1f} | {est / measured:.2f} | "
              f"{measured / mono[n][0]:.2f} | {est / mono[n][1]:.2f} |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
