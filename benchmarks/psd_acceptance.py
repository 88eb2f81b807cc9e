"""The acceptance table of docs/psd.md from the tables that `spherejam rcp` wrote.

    python benchmarks/psd_acceptance.py RESULTS [RESULTS ...] [--rows mono,bi14,...]

Reads ``RESULTS/tables/table3.csv`` and ``table4.csv`` of each results folder (a later folder's row of the same
distribution replaces an earlier one) and prints one Markdown row per distribution: N, the fast packings, our phi_LT
and phi_RCP (with their intervals, or "not estimable (n = ...)"), the three models and ours - model.
"""

from __future__ import annotations

import argparse
import math
from pathlib import Path

import pandas as pd


def _cell(value, half, n) -> str:
    if not math.isfinite(value):
        return f"not estimable (n = {n})"
    return f"{value:.4f} ± {half:.4f}" if math.isfinite(half) else f"{value:.4f} (no CI, n = {n})"


def rows(folder: Path) -> dict[str, dict]:
    t3 = pd.read_csv(folder / "tables" / "table3.csv")
    t4 = pd.read_csv(folder / "tables" / "table4.csv")
    import xarray as xr

    ds = xr.open_dataset(folder / "dataset.nc", engine="h5netcdf")
    n_spheres = int(ds.attrs["n"])
    out = {}
    for (_, r3), (_, r4) in zip(t3.iterrows(), t4.iterrows()):
        out[r4.distribution] = {"r3": r3, "r4": r4, "n": n_spheres}
    return out


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("results", type=Path, nargs="+")
    ap.add_argument("--rows", help="comma-separated distribution keys, in the order to print")
    args = ap.parse_args()
    table: dict[str, dict] = {}
    for folder in args.results:
        table.update(rows(folder))
    order = args.rows.split(",") if args.rows else list(table)
    print("| distribution | spec | N | fast packings (LS + FB) | φ_LT | φ_RCP | Farr–Groot | ours − FG | "
          "Desmond–Weeks | ours − DW | Santos et al. | ours − S |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|")
    for key in order:
        if key not in table:
            print(f"| {key} | | | not measured | | | | | | | | |")
            continue
        r3, r4, n = table[key]["r3"], table[key]["r4"], table[key]["n"]
        fast = f"{int(r3.ls_n_fast)} + {int(r3.fb_n_fast)}"
        cells = [key, f"`{r4.psd}`", str(n), fast, _cell(r4.phi_LT, r4.phi_LT_half_width, fast),
                 _cell(r4.phi_RCP, r4.phi_RCP_half_width, fast)]
        for m in ("farr_groot", "desmond_weeks", "santos"):
            d = r4[f"phi_RCP_minus_{m}"]
            cells += [f"{r4[f'model_{m}']:.4f}", f"{d:+.4f}" if math.isfinite(d) else "–"]
        print("| " + " | ".join(cells) + " |")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
