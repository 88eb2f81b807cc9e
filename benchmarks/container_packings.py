"""Jammed packings in a container for docs/containers_structure.md §7: a Poisson start in the container, LS at
gamma = 0.1, then MLS (find_closest_jamming) to its final rate; writes OUT/<spec>_s<seed>.h5 and prints one JSON line.

    python benchmarks/container_packings.py cylinder:diameter=7 500 1 --out /tmp/prof
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

from spherejam.core.packing_io import write_packing
from spherejam.core.seeding import poisson_packing
from spherejam.engines.closest_jamming import find_closest_jamming
from spherejam.engines.lubachevsky_stillinger import run_ls


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("spec", help="container spec, e.g. cylinder:diameter=7 or periodic")
    ap.add_argument("n", type=int)
    ap.add_argument("seed", type=int)
    ap.add_argument("--sigma", type=float, default=0.0)
    ap.add_argument("--ls-rate", type=float, default=0.1)
    ap.add_argument("--final-rate", type=float, default=1e-3)
    ap.add_argument("--out", type=Path, default=Path("."))
    args = ap.parse_args()
    t = time.time()
    start = poisson_packing(args.n, sigma=args.sigma, seed=args.seed, container=args.spec)
    ls = run_ls(start, args.ls_rate, seed=args.seed, progress_interval=1e9)
    mls = find_closest_jamming(ls.packing, seed=args.seed, progress_interval=1e9, final_rate=args.final_rate)
    tag = args.spec.replace(":", "_").replace("=", "").replace(",", "_")
    args.out.mkdir(parents=True, exist_ok=True)
    write_packing(args.out / f"{tag}_s{args.seed}.h5", mls.packing)
    print(json.dumps({"spec": args.spec, "n": mls.packing.n, "seed": args.seed, "phi_ls": ls.packing.phi,
                      "phi_mls": mls.packing.phi, "stop": mls.stats.stop_reason, "seconds": time.time() - t}))


if __name__ == "__main__":
    main()
