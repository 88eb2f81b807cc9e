"""The acceptance table of docs/psd.md (section 8): measured by `spherejam rcp`, one row at a time.

    python benchmarks/psd_acceptance.py run RESULTS --n 200 [--rows mono,powder,...] [--replicas 1] [--cores 2]
    python benchmarks/psd_acceptance.py table RESULTS [RESULTS ...] [--rows mono,bi14,...]

``run`` calls the one command, ``spherejam rcp``, once per row into the one results folder RESULTS, each call with
the rows before it and the new one: the finished rows' jobs are resumed (not redone), so a call's CPU time is the
new row's, and Santos et al. use the mono row's phi_RCP (its own monodisperse value) for every later row. The CPU
time of each call (user + sys of the workflow and all its jobs) is recorded in ``RESULTS/acceptance_cpu.json`` after
the call; a row already recorded there is skipped, so an interrupted run continues. Stop it between rows, not in one:
the call that is cut would record only the CPU time of its second part.

``table`` reads ``RESULTS/tables/table3.csv`` and ``table4.csv`` of each results folder (a later folder's row of the
same distribution replaces an earlier one) and prints one Markdown row per distribution: N, the fast packings, our
phi_LT and phi_RCP (with their intervals, or "not estimable (n = ...)"), the three models, ours - model, and the
row's CPU minutes.
"""

from __future__ import annotations

import argparse
import json
import math
import resource
import subprocess
import sys
import time
from pathlib import Path

import pandas as pd

#: The rows of docs/psd.md, section 8: name -> spec. Default order: the most informative first, so that a run cut
#: short by its time budget has those.
ROWS = {
    "mono": "lognormal:sigma=0",
    "powder": "table:examples/powder.csv",
    "bi14": "bidisperse:ratio=1.4,small=0.5,by=number",
    "bi2": "bidisperse:ratio=2,small=0.3,by=volume",
    "gauss02": "gaussian:delta=0.2",
    "uniform2": "uniform:ratio=2",
    "gauss01": "gaussian:delta=0.1",
    "bi4": "bidisperse:ratio=4,small=0.3,by=volume",
}
CPU_FILE = "acceptance_cpu.json"
ROOT = Path(__file__).resolve().parents[1]  # the repository: its Snakefile, and the example powder's path


def _children_cpu() -> float:
    r = resource.getrusage(resource.RUSAGE_CHILDREN)
    return r.ru_utime + r.ru_stime


def run(args) -> int:
    from spherejam.core.atomic import atomic_output

    names = args.rows.split(",") if args.rows else list(ROWS)
    unknown = [n for n in names if n not in ROWS]
    if unknown:
        print(f"--rows: unknown row {unknown[0]!r} (one of {', '.join(ROWS)})", file=sys.stderr)
        return 2
    cpu_path = args.results / CPU_FILE
    record = json.loads(cpu_path.read_text()) if cpu_path.is_file() else {}
    for k, name in enumerate(names):
        if name in record:
            print(f"{name}: recorded already ({record[name]['cpu_s'] / 60:.1f} CPU-min), skipped", flush=True)
            continue
        specs = [f"{n}={ROWS[n]}" for n in names[: k + 1]]
        cmd = ["spherejam", "rcp", *specs, "--n", str(args.n), "--replicas", str(args.replicas), "--cores",
               str(args.cores), "-o", str(args.results.resolve())]
        print(f"{time.strftime('%H:%M:%S')} row {name}: {' '.join(cmd)}", flush=True)
        cpu0, wall0 = _children_cpu(), time.time()
        code = subprocess.call(cmd, cwd=ROOT)
        cpu, wall = _children_cpu() - cpu0, time.time() - wall0
        print(f"{time.strftime('%H:%M:%S')} row {name}: exit {code}, {cpu / 60:.1f} CPU-min, {wall / 60:.1f} min "
              "wall", flush=True)
        if code != 0:
            return code
        record[name] = {"spec": ROWS[name], "n": args.n, "replicas": args.replicas, "cpu_s": round(cpu, 1),
                        "wall_s": round(wall, 1)}
        args.results.mkdir(parents=True, exist_ok=True)
        with atomic_output(cpu_path, ".json") as tmp:
            Path(tmp).write_text(json.dumps(record, indent=1) + "\n")
    return 0


def _cell(value, half, n) -> str:
    if not math.isfinite(value):
        return f"not estimable (n = {n})"
    return f"{value:.4f} ± {half:.4f}" if math.isfinite(half) else f"{value:.4f} (no CI, n = {n})"


def rows(folder: Path) -> dict[str, dict]:
    import xarray as xr

    t3 = pd.read_csv(folder / "tables" / "table3.csv")
    t4 = pd.read_csv(folder / "tables" / "table4.csv")
    ds = xr.open_dataset(folder / "dataset.nc", engine="h5netcdf")
    n_spheres = int(ds.attrs["n"])
    cpu_path = folder / CPU_FILE
    cpu = json.loads(cpu_path.read_text()) if cpu_path.is_file() else {}
    out = {}
    for (_, r3), (_, r4) in zip(t3.iterrows(), t4.iterrows()):
        seconds = cpu.get(r4.distribution, {}).get("cpu_s")
        out[r4.distribution] = {"r3": r3, "r4": r4, "n": n_spheres,
                                "cpu": f"{seconds / 60:.1f}" if seconds is not None else "–"}
    return out


def table(args) -> int:
    merged: dict[str, dict] = {}
    for folder in args.results:
        merged.update(rows(folder))
    order = args.rows.split(",") if args.rows else list(merged)
    print("| distribution | spec | N | fast packings (LS + FB) | φ_LT | φ_RCP | Farr–Groot | ours − FG | "
          "Desmond–Weeks | ours − DW | Santos et al. | ours − S | CPU min |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|---|")
    for key in order:
        if key not in merged:
            print(f"| {key} | `{ROWS.get(key, '')}` | | not measured | | | | | | | | | |")
            continue
        r3, r4, n = merged[key]["r3"], merged[key]["r4"], merged[key]["n"]
        fast = f"{int(r3.ls_n_fast)} + {int(r3.fb_n_fast)}"
        cells = [key, f"`{r4.psd}`", str(n), fast, _cell(r4.phi_LT, r4.phi_LT_half_width, fast),
                 _cell(r4.phi_RCP, r4.phi_RCP_half_width, fast)]
        for m in ("farr_groot", "desmond_weeks", "santos"):
            d = r4[f"phi_RCP_minus_{m}"]
            cells += [f"{r4[f'model_{m}']:.4f}", f"{d:+.4f}" if math.isfinite(d) else "–"]
        cells.append(merged[key]["cpu"])
        print("| " + " | ".join(cells) + " |")
    return 0


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    sub = ap.add_subparsers(dest="mode", required=True)
    r = sub.add_parser("run", help="measure the rows with spherejam rcp, one call per row")
    r.add_argument("results", type=Path)
    r.add_argument("--n", type=int, required=True)
    r.add_argument("--replicas", type=int, default=1)
    r.add_argument("--cores", type=int, default=2)
    r.add_argument("--rows", help=f"comma-separated rows, in the order to run (default: {','.join(ROWS)})")
    t = sub.add_parser("table", help="print the Markdown table from the results folders")
    t.add_argument("results", type=Path, nargs="+")
    t.add_argument("--rows", help="comma-separated distribution keys, in the order to print")
    args = ap.parse_args()
    return run(args) if args.mode == "run" else table(args)


if __name__ == "__main__":
    raise SystemExit(main())
