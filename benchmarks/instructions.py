"""Instructions executed by one LS run, counted by valgrind (cachegrind): a speed comparison that the load of a shared
machine cannot disturb (issue 45's "within 3 %"; docs/containers.md §8).

The case is bench_ls.py's: N = 1000 (``--n``), sigma = 0 (``--sigma``), a Poisson start compressed by LS at gamma = 1
to phi = 0.58, then LS at gamma = 1e-2 to p = 1e12. The count of the run is the count of the whole process less that
of the same process stopped before the run (``--start-only``). numba is compiled for a generic CPU
(``NUMBA_CPU_NAME=generic``), so its cache serves valgrind too, and warmed by one run outside valgrind first.

    python benchmarks/instructions.py                                # this tree (the PYTHONPATH's package)
    python benchmarks/instructions.py --src /tmp/k_main/src --src /tmp/k_base/src   # other trees, same invocation
"""

from __future__ import annotations

import argparse
import os
import re
import subprocess
import sys
import tempfile


def case(n: int, sigma: float, start_only: bool) -> None:
    from spherejam.core.seeding import poisson_packing
    from spherejam.engines.lubachevsky_stillinger import run_ls

    start = run_ls(poisson_packing(n, sigma, seed=12345), 1.0, seed=7, target_phi=0.58,
                   progress_interval=1e9).packing
    if start_only:
        return
    r = run_ls(start, 1e-2, seed=3, progress_interval=1e9)
    print(f"phi={r.packing.phi:.15f} collisions={r.stats.collisions}")


def count(src: str, n: int, sigma: float, start_only: bool, keep: str | None = None) -> tuple[int, str]:
    env = dict(os.environ, PYTHONPATH=src, NUMBA_CPU_NAME="generic")
    cmd = [sys.executable, __file__, "case", "--n", str(n), "--sigma", str(sigma)] + (["--start-only"] * start_only)
    subprocess.run(cmd, env=env, check=True, capture_output=True)  # warm numba's cache outside valgrind
    with tempfile.TemporaryDirectory() as tmp:
        name = keep or f"{tmp}/cg.out"  # keep: for cg_annotate (functions of the interpreter and libraries; numba's
        # JIT code has no symbols and counts under "???")
        out = subprocess.run(["valgrind", "--tool=cachegrind", "--cache-sim=no", f"--cachegrind-out-file={name}"]
                             + cmd, env=env, check=True, capture_output=True, text=True)
    refs = re.search(r"I\s+refs:\s+([\d,]+)", out.stderr)
    return int(refs.group(1).replace(",", "")), out.stdout.strip()


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("mode", nargs="?", default="count", choices=["count", "case"])
    ap.add_argument("--n", type=int, default=1000)
    ap.add_argument("--sigma", type=float, default=0.0)
    ap.add_argument("--start-only", action="store_true")
    ap.add_argument("--src", action="append", help="a tree's src directory (default: this PYTHONPATH)")
    ap.add_argument("--keep", help="write cachegrind's files as KEEP.<k>.run and KEEP.<k>.start, k the tree's index")
    args = ap.parse_args()
    if args.mode == "case":
        case(args.n, args.sigma, args.start_only)
        return
    srcs = args.src or [os.environ.get("PYTHONPATH", "")]
    first = None
    for k, src in enumerate(srcs):
        whole, result = count(src, args.n, args.sigma, False, args.keep and f"{args.keep}.{k}.run")
        before, _ = count(src, args.n, args.sigma, True, args.keep and f"{args.keep}.{k}.start")
        run = whole - before
        first = first or run
        print(f"{src}: {run / 1e9:.4f}e9 instructions of the LS run ({run / first:.4f} of the first); {result}",
              flush=True)


if __name__ == "__main__":
    main()
