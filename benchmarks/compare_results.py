"""Compare two results folders of the same config: every packing file's arrays bitwise and the tables.

    python benchmarks/compare_results.py results-before results-after

Packings: every dataset of every ``packings/**.h5`` (timing histories such as ``wall_time`` are left out: they are
measurements of the machine) and the attributes phi, box and reduced_pressure. Tables: the CSVs' columns that both
have must be identical; columns only the second has are listed; the Markdown/LaTeX layouts are compared as text.
Prints one line per difference and a summary; exit status 1 if any packing differs.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import h5py
import numpy as np
import pandas as pd


def _arrays(group, prefix=""):
    out = {}
    for key, value in group.items():
        if isinstance(value, h5py.Dataset):
            out[prefix + key] = value[()]
        else:
            out.update(_arrays(value, prefix + key + "/"))
    return out


def compare_packings(a: Path, b: Path) -> int:
    files = sorted(p.relative_to(a) for p in a.rglob("packings/**/*.h5"))
    bad = 0
    for rel in files:
        if not (b / rel).exists():
            print(f"missing in {b}: {rel}")
            bad += 1
            continue
        with h5py.File(a / rel) as x, h5py.File(b / rel) as y:
            da, db = _arrays(x), _arrays(y)
            for key in sorted(set(da) ^ set(db)):
                print(f"{rel}: dataset {key} only in one")
                bad += 1
            for key in sorted(set(da) & set(db)):
                if "time" not in key.rsplit("/", 1)[-1] and not np.array_equal(da[key], db[key]):
                    print(f"{rel}: {key} differs")
                    bad += 1
            for key in ("phi", "box", "reduced_pressure"):
                if key in x.attrs and x.attrs[key] != y.attrs.get(key):
                    print(f"{rel}: attribute {key} differs ({x.attrs[key]} vs {y.attrs.get(key)})")
                    bad += 1
    print(f"{len(files)} packing files compared, {bad} differences")
    return bad


def compare_tables(a: Path, b: Path) -> None:
    for csv in sorted((a / "tables").glob("*.csv")):
        ta, tb = pd.read_csv(csv), pd.read_csv(b / "tables" / csv.name)
        common = [c for c in ta.columns if c in tb.columns]
        same = common == list(ta.columns) and ta.equals(tb[common])
        added = [c for c in tb.columns if c not in ta.columns]
        print(f"{csv.name}: {len(ta)} rows, columns of the first {'identical' if same else 'DIFFER'}"
              + (f"; added: {', '.join(added)}" if added else ""))
    for text in sorted([*(a / "tables").glob("*.md"), *(a / "tables").glob("*.tex")]):
        old, new = text.read_text(), (b / "tables" / text.name).read_text()
        state = "identical" if old == new else ("extended (the first is its beginning)" if new.startswith(
            old.rstrip("\n")) else "DIFFERS")
        print(f"{text.name}: {state}")


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("first", type=Path)
    ap.add_argument("second", type=Path)
    args = ap.parse_args()
    bad = compare_packings(args.first, args.second)
    compare_tables(args.first, args.second)
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
