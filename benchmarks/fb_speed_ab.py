"""CPU time of FB in the periodic cube, checkout against checkout, in one run (issue 45: FB's speed in the cube must
stay within noise when containers land).

Each checkout's ``src`` runs in fresh processes, in turn (the order alternates between rounds): the kernels are
loaded first, then the best of 2 CPU times of ``run_fb`` at gamma = 1e-3 from Poisson starts N = 10^4 (sigma 0 and
0.3) and N = 10^3. The median over rounds and the ratios against the first checkout are printed.

Usage: python benchmarks/fb_speed_ab.py --rounds 4 NAME=SRC [NAME=SRC ...]
  e.g. base=/work/wt/base/src branch=/work/wt/fbwalls/src
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys

CASES = ((10000, 0.0), (10000, 0.3), (1000, 0.0))
CODE = f"""
import time
CASES = {CASES!r}
from spherejam.core.seeding import poisson_packing
from spherejam.engines.force_biased import run_fb
run_fb(poisson_packing(200, 0.1, seed=0), 1e-2, progress_interval=1e9)
out = []
for n, sigma in CASES:
    p = poisson_packing(n, sigma, seed=0)
    best = 1e9
    for _ in range(2):
        t = time.process_time()
        run_fb(p, 1e-3, progress_interval=1e9)
        best = min(best, time.process_time() - t)
    out.append(best)
print(*out)
"""


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rounds", type=int, default=4)
    ap.add_argument("trees", nargs="+", metavar="NAME=SRC")
    args = ap.parse_args()
    trees = dict(t.split("=", 1) for t in args.trees)
    times: dict[str, list[list[float]]] = {name: [] for name in trees}
    for r in range(args.rounds):
        order = list(trees.items()) if r % 2 == 0 else list(trees.items())[::-1]
        for name, src in order:
            env = {**os.environ, "PYTHONPATH": src}
            out = subprocess.run([sys.executable, "-c", CODE], env=env, capture_output=True, text=True, check=True)
            times[name].append([float(v) for v in out.stdout.split()])
            print(f"round {r} {name}: " + ", ".join(f"{v:.3f}" for v in times[name][-1]) + " CPU s", flush=True)
    first = next(iter(trees))
    for k, (n, sigma) in enumerate(CASES):
        med = {name: statistics.median(v[k] for v in times[name]) for name in trees}
        ratios = ", ".join(f"{name}/{first} {med[name] / med[first]:.3f}" for name in trees if name != first)
        print(f"N={n} sigma={sigma}: " + ", ".join(f"{name} {t:.3f} s" for name, t in med.items())
              + f" (median CPU over {args.rounds} rounds); {ratios}")


if __name__ == "__main__":
    main()
