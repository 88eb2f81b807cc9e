"""Two CALiPPSO paths compared over many packings: phi_J, Z and the rattler fraction, pairwise (issue 46, item 3).

    python benchmarks/calippso_paths_stats.py --out DIR                     # both input sets, auto vs auto/reference
    python benchmarks/calippso_paths_stats.py --out DIR --summarize          # the tables from the records in DIR
    python benchmarks/calippso_paths_stats.py --out DIR --paths auto auto+interior --sets ls1024
    python benchmarks/calippso_paths_stats.py --out DIR --paths auto auto+interior --shard 1/3   # one of 3 processes

A path that changes the trajectory may end on another valid jammed state, so two paths are compared by statistics
over many inputs, not bitwise (docs/calippso.md §10.5). The inputs:

* ``mls1000``: the archived reproduction's N = 1000 MLS outputs (``archive/reproduction/packings/n1000/*/*/*/r0``,
  p ~ 10^12), ``--mls-count`` of them (30) taken evenly over the four protocol x sigma cells;
* ``ls1024``: N = 1024, sigma = 0, LS at gamma = 10^-2 to p = 10^5, seeds 1 ... ``--ls-count`` (10): the creeping start
  of docs/calippso.md §8.1, where the bounds schedules differ most.

Each certificate is checked on its own (``bench_calippso.validity``: converged under the unchanged criteria,
isostatic, force balance <= 1e-10, no overlap). One JSON record per input and path in ``--out`` (written atomically; a
rerun skips the records it has), so the run resumes. The summary gives, per input set, each path's LPs and CPU (means),
and for every other path against the first: the mean paired difference of phi_J, Z (mean contacts per stable sphere)
and the rattler fraction with its 95 % t-interval and the Wilcoxon signed-rank p (or "not estimable (n = ...)").
CPU seconds are this process's; the machine is shared, so only ratios within one run mean anything.
"""

from __future__ import annotations

import argparse
import glob
import json
import math
import os
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_calippso import Certificate, ls_start, parse_path, validity  # noqa: E402

from spherejam.core.atomic import atomic_output  # noqa: E402
from spherejam.core.packing_io import read_packing  # noqa: E402

REPO = Path(__file__).resolve().parent.parent
ARCHIVE = REPO / "archive" / "reproduction" / "packings" / "n1000"
SETS = ("mls1000", "ls1024")
#: Paired differences this small are round-off of one state (phi_J agrees to ~1e-12 when the contacts agree).
SAME = 1e-9


def mls_inputs(count: int) -> list[tuple[str, str]]:
    """``count`` archived N = 1000 MLS outputs, shared out over the protocol x sigma cells and, within a cell, spread
    evenly over its compression rates (name, path)."""
    outputs = glob.glob(str(ARCHIVE / "*" / "*" / "*" / "r0" / "jammed.h5"))
    cells = sorted({Path(p).parent.parent.parent for p in outputs})
    chosen = []
    for k, cell in enumerate(cells):
        files = sorted(glob.glob(str(cell / "*" / "r0" / "jammed.h5")))
        m = min(len(files), count // len(cells) + (k < count % len(cells)))
        chosen += [files[int(i)] for i in np.unique(np.linspace(0, len(files) - 1, m).round())]
    return [(str(Path(p).parent.parent.relative_to(ARCHIVE)).replace("/", "_"), p) for p in chosen]


def record_of(cert: Certificate, n: int, start_phi: float) -> dict:
    ok, failed = validity(cert)
    stable = n - cert.n_rattlers
    return {"phi_start": start_phi, "phi_J": cert.phi, "contacts": int(cert.n_contacts),
            "rattlers": int(cert.n_rattlers), "n": n, "Z": 2.0 * cert.n_contacts / stable if stable else math.nan,
            "rattler_fraction": cert.n_rattlers / n, "lps": int(cert.iterations), "cpu_s": cert.cpu,
            "solver_path": cert.solver_path(), "valid": ok, "failed": failed,
            "force_balance": cert.force_balance_residual, "isostatic": bool(cert.isostatic)}


def _recorded_cpu(out: Path, group: str, name: str, path: str) -> float:
    """CPU s of the record of ``path`` on an input (inf if there is none)."""
    f = out / group / name / f"{path.replace('/', '_')}.json"
    return json.loads(f.read_text())["cpu_s"] if f.exists() else math.inf


def run(out: Path, paths: list[str], sets: list[str], mls_count: int, ls_count: int,
        shard: tuple[int, int] = (0, 1)) -> None:
    """Certify every input with every path it has no record of yet. Inputs go cheapest first by the first path's
    record where it has one (so that a sitting cut short leaves the most pairs), and ``shard`` (i, k) takes every
    k-th of them from the i-th, so that k processes share the inputs without overlap."""
    from spherejam.calippso.run import run_calippso

    inputs: list[tuple[str, str, object]] = []
    if "mls1000" in sets:
        inputs += [("mls1000", name, path) for name, path in mls_inputs(mls_count)]
    if "ls1024" in sets:
        inputs += [("ls1024", f"seed{s}", s) for s in range(1, ls_count + 1)]
    inputs.sort(key=lambda g: _recorded_cpu(out, g[0], g[1], paths[0]))  # stable: the listed order among equals
    inputs = inputs[shard[0]::shard[1]]
    for k, (group, name, source) in enumerate(inputs, 1):
        todo = [p for p in paths if not (out / group / name / f"{p.replace('/', '_')}.json").exists()]
        if not todo:
            continue
        start = (read_packing(source) if isinstance(source, str)
                 else ls_start(1024, 1e5, 1e-2, int(source), kind="ls")[0])
        for path in todo:
            cpu0 = time.process_time()
            result = run_calippso(start, progress_interval=600.0, **parse_path(path))
            rec = record_of(Certificate.of(result, time.process_time() - cpu0), start.n, start.phi)
            rec.update(input=name, group=group, path=path,
                       source=source if isinstance(source, str) else f"LS N=1024 gamma=1e-2 p=1e5 seed {source}")
            target = out / group / name / f"{path.replace('/', '_')}.json"
            with atomic_output(target) as tmp:
                tmp.write_text(json.dumps(rec, indent=1, default=float))
            print(f"[{k}/{len(inputs)}] {group} {name} {path}: phi_J {rec['phi_J']:.10f} LPs {rec['lps']} "
                  f"CPU {rec['cpu_s']:.1f} s valid {rec['valid']} {rec['failed']}", flush=True)


def paired(a: list[float], b: list[float]) -> str:
    d = np.asarray(b, float) - np.asarray(a, float)
    d[np.abs(d) <= SAME] = 0.0  # the same state reached by two paths differs by round-off only
    n = d.size
    if n < 5:
        return f"not estimable (n = {n})"
    from scipy import stats

    mean, sd = float(d.mean()), float(d.std(ddof=1))
    if sd == 0.0:
        return f"{mean:+.3g} in all {n} (interval and test not estimable, zero spread)"
    half = stats.t.ppf(0.975, n - 1) * sd / math.sqrt(n)
    nonzero = d[d != 0]
    w = f"Wilcoxon p = {stats.wilcoxon(nonzero).pvalue:.3g}" if nonzero.size >= 5 else \
        f"Wilcoxon not estimable (n = {nonzero.size} nonzero)"
    return f"{mean:+.3g}, 95 % CI [{mean - half:+.3g}, {mean + half:+.3g}]; {w} (n = {n})"


def _mean_ratio(other: dict, first: dict, inputs: list[str], key: str) -> float:
    """The mean of ``key`` over ``inputs`` for one path, over the same mean for the first."""
    return float(np.mean([other[i][key] for i in inputs]) / np.mean([first[i][key] for i in inputs]))


def summarize(out: Path) -> None:
    for group in SETS:
        recs: dict[str, dict[str, dict]] = {}
        for f in sorted(glob.glob(str(out / group / "*" / "*.json"))):
            r = json.loads(Path(f).read_text())
            recs.setdefault(r["path"], {})[r["input"]] = r
        if not recs:
            continue
        paths = list(recs)
        first = "auto" if "auto" in recs else paths[0]
        print(f"\n#### {group}\n")
        print("| path | inputs | valid | LPs (mean) | CPU s (mean) | LPs, CPU / first's (ratio of means) | "
              "LPs, CPU / first's (median of the per-input ratios) |")
        print("|---|---|---|---|---|---|---|")
        for p in [first] + [q for q in paths if q != first]:
            rs = list(recs[p].values())
            common = sorted(set(recs[p]) & set(recs[first]))
            ratio = "(first)" if p == first else (
                f"{_mean_ratio(recs[p], recs[first], common, 'lps'):.2f}, "
                f"{_mean_ratio(recs[p], recs[first], common, 'cpu_s'):.2f} (n = {len(common)})")
            median = "(first)" if p == first else (
                f"{np.median([recs[p][i]['lps'] / recs[first][i]['lps'] for i in common]):.2f}, "
                f"{np.median([recs[p][i]['cpu_s'] / recs[first][i]['cpu_s'] for i in common]):.2f}")
            print(f"| {p} | {len(rs)} | {sum(r['valid'] for r in rs)} | {np.mean([r['lps'] for r in rs]):.1f} | "
                  f"{np.mean([r['cpu_s'] for r in rs]):.1f} | {ratio} | {median} |")
        for p in paths:
            if p == first:
                continue
            common = sorted(set(recs[p]) & set(recs[first]))
            same = sum(recs[p][i]["contacts"] == recs[first][i]["contacts"]
                       and recs[p][i]["rattlers"] == recs[first][i]["rattlers"]
                       and abs(recs[p][i]["phi_J"] - recs[first][i]["phi_J"]) <= 1e-9 for i in common)
            print(f"\n{p} - {first}, paired over {len(common)} inputs ({same} end on the same state: equal contacts "
                  f"and rattlers, |delta phi_J| <= 1e-9):")
            moved = [i for i in common if abs(recs[p][i]["phi_J"] - recs[first][i]["phi_J"]) > SAME]
            if moved:
                print("  on other states: " + ", ".join(
                    f"{i} (delta phi_J {recs[p][i]['phi_J'] - recs[first][i]['phi_J']:+.2e}, LPs "
                    f"{recs[first][i]['lps']} -> {recs[p][i]['lps']})" for i in moved))
            for key in ("phi_J", "Z", "rattler_fraction", "lps"):
                print(f"- {key}: " + paired([recs[first][i][key] for i in common], [recs[p][i][key] for i in common]))


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--out", required=True, type=Path, help="folder of the per-input records (resumable)")
    ap.add_argument("--paths", nargs="+", default=["auto", "auto/reference"],
                    help="bench_calippso paths; the first is the baseline (auto auto/reference)")
    ap.add_argument("--sets", nargs="+", choices=SETS, default=list(SETS))
    ap.add_argument("--mls-count", type=int, default=30)
    ap.add_argument("--ls-count", type=int, default=10)
    ap.add_argument("--shard", default="0/1", metavar="I/K",
                    help="take every K-th input from the I-th (0/1: all), so that K processes share the inputs")
    ap.add_argument("--summarize", action="store_true", help="only print the tables from the records")
    args = ap.parse_args(argv)
    try:
        i, k = (int(v) for v in args.shard.split("/"))
        assert 0 <= i < k
    except (ValueError, AssertionError):
        ap.error(f"--shard={args.shard}: must be I/K with 0 <= I < K")
    if not args.summarize:
        os.environ.setdefault("OMP_NUM_THREADS", "1")
        run(args.out, args.paths, args.sets, args.mls_count, args.ls_count, (i, k))
    summarize(args.out)
    return 0


if __name__ == "__main__":
    sys.exit(main())
