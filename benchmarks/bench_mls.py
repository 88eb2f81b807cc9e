"""MLS (closest jamming) speed: wall time and collisions from a fixed fast-compressed start, one core.

Start: Poisson (seed 2024) -> LS at gamma = 0.5 (1/gamma = 2, a "fast" packing of the paper) to p = 1e12 (not timed).
Then MLS with the paper's parameters (gamma_0 = 10, f = 2, final rate 1e-4, p_max = 1e12, 20 events per particle).
Reference: the paper's code takes ~7 min for N = 1e3 at sigma = 0.3 and 10-20 h for N = 1e4; target N = 1e4 <= 1 h.

A run cut by ``--max-wall-time`` prints its progress and an extrapolated total, marked as such, from an expected
number of collisions per particle: ``--collisions-per-particle``, else the cost model of
:mod:`spherejam.workflow.cost_model` (2.4e5 at N = 1e3, growing as N^0.66: ~1.1e6 at N = 1e4, the mean of five
measured searches).

    python benchmarks/bench_mls.py                                   # N = 1e3, sigma 0 and 0.3
    python benchmarks/bench_mls.py --sizes 10000 --max-wall-time 1800
    python benchmarks/bench_mls.py --sizes 300 --psd lognormal:sigma=0 gaussian:delta=0.1 --seeds 1 2 --out M.jsonl

``--psd`` takes size-distribution specs in place of ``--sigmas``; ``--seeds`` are the MLS seeds (each with its own
Poisson start, seed 2024 + k); ``--out`` appends each run's figures (collisions, CPU seconds) as a JSON line, which
``benchmarks/cost_fit.py`` reads for the cost model's N-part (docs/algorithms.md §7.9).
"""

from __future__ import annotations

import argparse
import json
import time

from spherejam.core.seeding import poisson_packing
from spherejam.engines.closest_jamming import find_closest_jamming
from spherejam.engines.lubachevsky_stillinger import run_ls
from spherejam.workflow.cost_model import mls_collisions_per_particle


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", type=int, nargs="*", default=[1000])
    ap.add_argument("--sigmas", type=float, nargs="*", default=[0.0, 0.3])
    ap.add_argument("--max-wall-time", type=float, default=None, help="cap per MLS run (seconds)")
    ap.add_argument("--collisions-per-particle", type=float, default=None,
                    help="for the extrapolation of capped runs (default: the cost model at this N)")
    ap.add_argument("--psd", nargs="*", default=None, help="size-distribution specs (in place of --sigmas)")
    ap.add_argument("--seeds", type=int, nargs="*", default=[1])
    ap.add_argument("--out", default=None, help="append each run's figures as a JSON line")
    args = ap.parse_args()
    dists = [("psd", spec) for spec in args.psd] if args.psd else [("sigma", s) for s in args.sigmas]
    for n in args.sizes:
        for kind, value in dists:
            for seed in args.seeds:
                size = {"psd": value} if kind == "psd" else {"sigma": value}
                poisson = poisson_packing(n, seed=2024 + seed - 1, **size)
                start = run_ls(poisson, 0.5, seed=seed, progress_interval=1e9).packing
                t0, c0 = time.perf_counter(), time.process_time()
                r = find_closest_jamming(start, seed=seed, max_wall_time=args.max_wall_time, progress_interval=60.0)
                wall, cpu = time.perf_counter() - t0, time.process_time() - c0
                c = r.stats
                label = f"psd={value}" if kind == "psd" else f"sigma={value:.1f}"
                line = (f"MLS N={n:>6} {label} seed={seed}: phi_start={start.phi:.5f} phi_J={c.phi_final:.5f} "
                        f"stages={c.extras.stages} stop={c.stop_reason} collisions={c.collisions:,} "
                        f"({c.collisions / n:,.0f}/particle) wall={wall:.1f}s cpu={cpu:.1f}s "
                        f"({c.collisions / cpu / 1e6:.3f} M collisions/cpu-s)")
                if c.stop_reason == "max_wall_time":
                    cpp = args.collisions_per_particle or mls_collisions_per_particle(n=n)
                    est = cpp * n / (c.collisions / wall)
                    line += (f"  [CAPPED; EXTRAPOLATED total ~{est / 60:.0f} min at {cpp:,.0f} collisions/particle]")
                print(line, flush=True)
                if args.out:
                    with open(args.out, "a") as fh:
                        fh.write(json.dumps({"n": n, kind: value, "seed": seed, "phi_start": start.phi,
                                             "phi_j": c.phi_final, "stop": c.stop_reason,
                                             "collisions": c.collisions, "cpu": cpu, "wall": wall,
                                             "diameters": poisson.diameters.tolist()}) + "\n")


if __name__ == "__main__":
    main()
