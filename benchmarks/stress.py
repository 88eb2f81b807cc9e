"""Stress test of the engines (issue 23; not in CI): LS, FB and a short MLS over many sizes, polydispersities, rates
and seeds, every output checked for overlaps by brute force (all pairs, minimum image, and every sphere against its own
images; no cell lists). The closest image of a pair is its minimum image, so this is exact in any box.

The grid: sigma in {0, 0.1, 0.3, 0.5}; N in {100, 1000, 10^4}; LS rates gamma in {10, 1, 1e-2} plus 1e-4 at
N = 100; FB rates in {1e-1, 1e-2} plus 1e-4 at N = 100 (an FB rate must be < 1, so the LS values 10 and 1 are
checked once to be refused); 50 seeds at N = 100, 1 seed above (``--seeds``). The short MLS starts from each LS
output with gamma_0 = 10, f = 2, down to gamma_f = 1e-2.

Each run ends as one of
  ok        the packing came back and has no pair overlapping by more than 1e-10 (relative to the contact distance);
  overlap   it came back with such a pair (a bug);
  refused   the engine refused the input with an InputError;
  self      ok, and LS/MLS stopped because the largest sphere grew as wide as the box (it touches its own images,
            nothing can grow: stop reason "self_contact"; possible at small N and wide size distributions);
  skipped   an MLS whose LS start was not produced;
  error     anything else (a bug).

Other size distributions join the sigma axis as spec strings (``--psd bidisperse:ratio=10,small=0.3,by=volume``,
docs/psd.md); ``--sigmas`` with no value leaves the log-normals out.

The full grid takes days on one core; pick a subset:

    nice python benchmarks/stress.py --n 100 --sigmas 0 0.1 --seeds 3 --ls-rates 10 1 --fb-rates 0.1 0.01
    python benchmarks/stress.py --n 2 10 50 --sigmas --psd bidisperse:ratio=10,small=0.3,by=volume --seeds 5
    python benchmarks/stress.py                     # everything (long)
    python benchmarks/stress.py --json stress.json  # also write the per-run records
"""

from __future__ import annotations

import argparse
import json
import time
import traceback
from collections import Counter

import numpy as np

from spherejam.core.errors import InputError
from spherejam.core.seeding import poisson_packing
from spherejam.engines.closest_jamming import find_closest_jamming
from spherejam.engines.force_biased import run_fb
from spherejam.engines.lubachevsky_stillinger import run_ls

OVERLAP_LIMIT = 1e-10


def brute_force_overlaps(positions: np.ndarray, diameters: np.ndarray, box: float, chunk: int = 256):
    """(number of pairs with 1 - r_ij/D_ij > 1e-10, worst 1 - r_ij/D_ij) over all pairs, minimum image, and each
    sphere with its own image at distance L."""
    n = len(positions)
    own = 1.0 - box / diameters
    count, worst = int(np.count_nonzero(own > OVERLAP_LIMIT)), float(own.max())
    for start in range(0, n - 1, chunk):
        a = positions[start:start + chunk]
        d = a[:, None, :] - positions[None, :, :]
        d -= box * np.round(d / box)
        r = np.sqrt(np.einsum("ijk,ijk->ij", d, d))
        contact = 0.5 * (diameters[start:start + chunk, None] + diameters[None, :])
        overlap = 1.0 - r / contact
        i = np.arange(start, start + len(a))[:, None]
        overlap = np.where(np.arange(n)[None, :] > i, overlap, -np.inf)  # each pair once, no self-pairs
        count += int(np.count_nonzero(overlap > OVERLAP_LIMIT))
        worst = max(worst, float(overlap.max()))
    return count, worst


def start(n: int, psd: str, seed: int):
    """The Poisson start of one case: ``psd`` a size-distribution spec (a log-normal sigma is ``lognormal:sigma=s``)."""
    return poisson_packing(n, seed=seed, psd=psd)


def run_one(protocol: str, n: int, psd: str, rate: float, seed: int, cache: dict) -> dict:
    record = {"protocol": protocol, "n": n, "psd": psd, "rate": rate, "seed": seed}
    t0 = time.perf_counter()
    try:
        if protocol == "ls":
            result = run_ls(start(n, psd, seed), rate, seed=seed, progress_interval=1e9)
            packing = result.packing
            cache[(n, psd, rate, seed)] = packing
        elif protocol == "fb":
            result = run_fb(start(n, psd, seed), rate, progress_interval=1e9)
            packing = result.packing
        else:  # a short MLS from the LS output of the same case
            ls_output = cache.get((n, psd, rate, seed))
            if ls_output is None:
                record.update(outcome="skipped", reason="no LS output to start from")
                return record
            result = find_closest_jamming(ls_output, initial_rate=10.0, decrease_factor=2.0, final_rate=1e-2,
                                          seed=seed, progress_interval=1e9)
            packing = result.packing
        count, worst = brute_force_overlaps(packing.positions, packing.diameters, packing.box)
        fine = "self" if result.stats.stop_reason == "self_contact" else "ok"
        record.update(outcome="overlap" if count else fine, overlaps=count, worst_overlap=worst, phi=packing.phi)
    except InputError as exc:
        record.update(outcome="refused", reason=str(exc))
    except Exception as exc:  # noqa: BLE001 - the point is to count every failure
        record.update(outcome="error", reason=f"{type(exc).__name__}: {exc}", traceback=traceback.format_exc())
    record["wall_time"] = time.perf_counter() - t0
    return record


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--protocols", nargs="+", default=["ls", "fb", "mls"], choices=["ls", "fb", "mls"])
    ap.add_argument("--n", nargs="+", type=int, default=[100, 1000, 10000])
    ap.add_argument("--sigmas", nargs="*", type=float, default=[0.0, 0.1, 0.3, 0.5],
                    help="log-normal sigmas (none: only the --psd distributions)")
    ap.add_argument("--psd", nargs="+", default=[], help="more size distributions, as spec strings (docs/psd.md)")
    ap.add_argument("--ls-rates", nargs="+", type=float, default=[10.0, 1.0, 1e-2, 1e-4],
                    help="LS (and MLS start) rates; 1e-4 and below only at N <= --small-n")
    ap.add_argument("--fb-rates", nargs="+", type=float, default=[1e-1, 1e-2, 1e-4],
                    help="FB rates; 1e-4 and below only at N <= --small-n")
    ap.add_argument("--small-n", type=int, default=100, help="largest N that also runs the slowest rates")
    ap.add_argument("--seeds", type=int, default=50, help="seeds at N <= --small-n (1 seed above)")
    ap.add_argument("--json", help="write every run's record to this file")
    args = ap.parse_args(argv)

    # the issue's gamma = 10 and 1 are not FB rates: they must be refused, not run
    refused_fb = [r for r in (10.0, 1.0) if _refused(lambda r=r: run_fb(poisson_packing(20, 0.0, 0), r))]
    print(f"FB rates 10 and 1 refused as bad input: {len(refused_fb)} of 2")

    records, cache = [], {}
    distributions = [f"lognormal:sigma={s:g}" for s in args.sigmas] + list(args.psd)
    for n in args.n:
        seeds = range(args.seeds if n <= args.small_n else 1)
        for psd in distributions:
            for protocol in args.protocols:
                rates = args.fb_rates if protocol == "fb" else args.ls_rates
                for rate in rates:
                    if rate <= 1e-4 and n > args.small_n:
                        continue
                    for seed in seeds:
                        rec = run_one(protocol, n, psd, rate, seed, cache)
                        records.append(rec)
                        if rec["outcome"] in ("overlap", "error"):
                            print(f"  {rec['outcome'].upper()}: {protocol} N={n} {psd} gamma={rate:g} "
                                  f"seed={seed}: {rec.get('reason', rec.get('overlaps'))}", flush=True)
                done = [r for r in records if (r["n"], r["psd"], r["protocol"]) == (n, psd, protocol)]
                c = Counter(r["outcome"] for r in done)
                worst = max((r.get("worst_overlap", -np.inf) for r in done), default=-np.inf)
                print(f"{protocol:3s} N={n:<6d} {psd:<40s} runs={len(done):4d} ok={c['ok']:4d} "
                      f"overlaps>1e-10={c['overlap']:3d} refused={c['refused']:3d} self_contact={c['self']:3d} "
                      f"errors={c['error']:3d} skipped={c['skipped']:3d} worst 1-r/D={worst:.2e} "
                      f"wall={sum(r['wall_time'] for r in done if 'wall_time' in r):.0f}s", flush=True)
    total = Counter(r["outcome"] for r in records)
    print(f"TOTAL runs={len(records)} ok={total['ok']} overlaps>1e-10={total['overlap']} refused={total['refused']} "
          f"self_contact={total['self']} errors={total['error']} skipped={total['skipped']}")
    if args.json:
        with open(args.json, "w") as fh:
            json.dump(records, fh, indent=1, default=float)
    return 1 if total["overlap"] or total["error"] else 0


def _refused(call) -> bool:
    try:
        call()
    except InputError:
        return True
    return False


if __name__ == "__main__":
    raise SystemExit(main())
