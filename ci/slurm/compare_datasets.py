"""Check that two results datasets (results/dataset.nc) hold the same numbers: e.g. a SLURM run and a local run.

Every variable and coordinate must exist in both, with the same dimensions and values (exactly, unless --rtol is
given; NaN equals NaN). Wall-time-like variables differ between any two runs and are left out: names containing
``wall_time``, ``cpu_time``, ``solve_time``, ``lp_time`` or ``elapsed``, and variables whose long_name says "wall".
Of the global attributes, those that depend on when and where the run was made (created, history, git_commit,
package_versions, config_hash) are ignored, and the config is compared without its ``results`` folder.

Usage: python ci/slurm/compare_datasets.py A.nc B.nc [--rtol 0]
Exit status 0 when equal, 1 when they differ (every difference is listed), 2 when a file cannot be read.
"""

from __future__ import annotations

import argparse
import json
import re
import sys

import numpy as np

TIMING = re.compile(r"wall_time|cpu_time|solve_time|lp_time|elapsed")
RUN_ATTRS = {"created", "history", "git_commit", "package_versions", "config_hash"}


def is_timing(name: str, attrs: dict) -> bool:
    return bool(TIMING.search(name)) or "wall" in str(attrs.get("long_name", "")).lower()


def _config_without_results(text: str):
    try:
        config = json.loads(text)
    except (TypeError, ValueError):
        return text
    if isinstance(config, dict):
        config.pop("results", None)
    return config


def _same_values(a: np.ndarray, b: np.ndarray, rtol: float) -> tuple[bool, str]:
    if a.shape != b.shape:
        return False, f"shape {a.shape} != {b.shape}"
    if a.dtype.kind in "fiub" and b.dtype.kind in "fiub":
        a64, b64 = a.astype(np.float64), b.astype(np.float64)
        close = (a64 == b64) if rtol == 0 else np.isclose(a64, b64, rtol=rtol, atol=0.0)
        bad = ~(close | (np.isnan(a64) & np.isnan(b64)))
        if bad.any():
            diff = np.abs(a64 - b64)[bad]
            return False, f"{int(bad.sum())} of {a.size} values differ (max |diff| {np.nanmax(diff):.3g})"
        return True, ""
    bad = a != b
    return (False, f"{int(np.sum(bad))} of {a.size} values differ") if np.any(bad) else (True, "")


def compare(path_a: str, path_b: str, rtol: float = 0.0) -> list[str]:
    """The differences between the datasets at ``path_a`` and ``path_b`` (empty if they agree)."""
    import xarray as xr

    a = xr.load_dataset(path_a, engine="h5netcdf")
    b = xr.load_dataset(path_b, engine="h5netcdf")
    problems: list[str] = []
    names_a = set(a.variables)
    names_b = set(b.variables)
    for name in sorted(names_a ^ names_b):
        problems.append(f"variable {name!r} only in {'A' if name in names_a else 'B'}")
    compared, skipped = [], []
    for name in sorted(names_a & names_b):
        va, vb = a[name], b[name]
        if is_timing(name, va.attrs):
            skipped.append(name)
            continue
        if va.dims != vb.dims:
            problems.append(f"{name}: dimensions {va.dims} != {vb.dims}")
            continue
        ok, why = _same_values(np.asarray(va.values), np.asarray(vb.values), rtol)
        if not ok:
            problems.append(f"{name}: {why}")
        compared.append(name)
    for key in sorted((set(a.attrs) | set(b.attrs)) - RUN_ATTRS):
        va, vb = a.attrs.get(key), b.attrs.get(key)
        if key == "config":
            va, vb = _config_without_results(va), _config_without_results(vb)
        if isinstance(va, np.ndarray) or isinstance(vb, np.ndarray):
            same = np.array_equal(np.asarray(va), np.asarray(vb))
        else:
            same = va == vb
        if not same:
            problems.append(f"global attribute {key!r} differs")
    if not compared:
        problems.append("no variable was compared")
    print(f"compared {len(compared)} variables/coordinates of {path_a} and {path_b}"
          f" ({sum(a[n].size for n in compared)} values); left out as timings: {', '.join(skipped) or 'none'}")
    return problems


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("a")
    ap.add_argument("b")
    ap.add_argument("--rtol", type=float, default=0.0, help="relative tolerance for floats (default 0: exact)")
    args = ap.parse_args(argv)
    try:
        problems = compare(args.a, args.b, args.rtol)
    except (OSError, ValueError) as exc:
        print(f"cannot compare: {exc}", file=sys.stderr)
        return 2
    for p in problems:
        print(f"DIFFERENT: {p}")
    print("datasets agree" if not problems else f"datasets differ ({len(problems)} problems)")
    return 1 if problems else 0


if __name__ == "__main__":
    sys.exit(main())
