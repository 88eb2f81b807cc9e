"""Packed cylinders against the packed-bed literature (issue 45, acceptance "cylinders against the literature";
docs/containers_acceptance.md).

Rows: size distribution (monodisperse, log-normal sigma = 0.3) x D/d (5, 7, 10, 20) x protocol (the table
containers_common.PROTOCOLS: LS at gamma = 1, the fast rate, and MLS), each with --seeds packings (>= 10 for the
issue) in a cylinder periodic along its axis, N fixed per D/d (CYLINDER_N; the length follows). Beside each row the
bulk phi of the same protocol and distribution (periodic cube, --bulk-n spheres, the same seeds).

Printed per row: the achieved D/<d> (the container is sized from an estimate of the final phi, so it differs from
the asked one; <d> the final number-mean diameter), the mean phi with its 95 % t-interval, the excess porosity over
bulk (eps - eps_bulk = phi_bulk - phi, Welch 95 % interval), and the Benyahia & O'Neill (2005) correlation
eps = 0.390 + 1.740 / (D/d + 1.140)^2 at the achieved D/<d>, with its excess over its own bulk limit (0.390).
Frictionless jammed packings are denser than poured or slurry-packed beds, so only the excess compares.

One JSON record per packing in --out; runs present are skipped, so the matrix resumes. Rows are run in order of
D/d, so a short sitting gives the small columns first.

    python benchmarks/containers_cylinders.py --out runs/cylinders --diameters 5 7 --seeds 3
    python benchmarks/containers_cylinders.py --out runs/cylinders              # all rows, 10 seeds (long)
"""

from __future__ import annotations

import argparse
import sys
import time

import numpy as np
from containers_common import DISTRIBUTIONS, PROTOCOLS, Records, brute_force, fmt_ci, mean_ci, provenance, \
    start_packing, welch

#: N per asked D/d: enough for a column at least ~8 d long, periodic along its axis.
CYLINDER_N = {5: 500, 7: 725, 10: 1000, 20: 3000}


def benyahia_oneill(ratio: float) -> float:
    """Mean porosity of a packed cylinder of D/d = ratio, Benyahia & O'Neill (2005), 1.5 < D/d < 50."""
    return 0.390 + 1.740 / (ratio + 1.140) ** 2


def run(spec: str, n: int, dist: str, protocol: str, seed: int) -> dict:
    cpu0 = time.process_time()
    start = start_packing(n, dist, spec, seed)
    result = PROTOCOLS[protocol][1](start, seed, None)
    q = result.packing
    return {"container": spec, "n": n, "dist": dist, "protocol": protocol, "seed": seed, "phi": q.phi,
            "stop": result.stats.stop_reason, "cpu": time.process_time() - cpu0,
            "achieved": q.container.in_diameters(q.mean_diameter),
            **brute_force(q.positions, q.diameters, q.container), **provenance()}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", required=True)
    ap.add_argument("--seeds", type=int, default=10)
    ap.add_argument("--diameters", nargs="+", type=int, default=list(CYLINDER_N), choices=list(CYLINDER_N))
    ap.add_argument("--dists", nargs="+", default=["mono", "sigma0.3"], choices=list(DISTRIBUTIONS))
    ap.add_argument("--protocols", nargs="+", default=list(PROTOCOLS), choices=list(PROTOCOLS))
    ap.add_argument("--bulk-n", type=int, default=2000)
    ap.add_argument("--table-only", action="store_true", help="print what the records hold; run nothing")
    args = ap.parse_args(argv)
    store = Records(args.out)

    def get(kind, spec, n, dist, protocol, seed):
        k = f"{kind}_{dist}_{protocol}_N{n}_s{seed}"
        rec = store.get(k)
        if rec is None and not args.table_only:
            rec = run(spec, n, dist, protocol, seed)
            store.put(k, rec)
            print(f"  {k}: phi={rec['phi']:.5f} stop={rec['stop']} cpu={rec['cpu']:.1f}s "
                  f"overlap={rec['worst_overlap']:.1e} penetration={rec['worst_penetration']:.1e} "
                  f"load={rec['load']:.1f}", flush=True)
        return rec

    rows, status = [], 0
    for ratio in args.diameters:
        for dist in args.dists:
            for protocol in args.protocols:
                bulk = [get("bulk", "periodic", args.bulk_n, dist, protocol, s) for s in range(1, args.seeds + 1)]
                cyl = [get(f"cyl{ratio}", f"cylinder:diameter={ratio}", CYLINDER_N[ratio], dist, protocol, s)
                       for s in range(1, args.seeds + 1)]
                bulk, cyl = [r for r in bulk if r], [r for r in cyl if r]
                if not cyl:
                    continue
                status |= any(max(r["worst_overlap"], r["worst_penetration"]) > 1e-10 for r in cyl + bulk)
                rows.append((ratio, dist, protocol, cyl, bulk))
    print("\n| D/d asked | D/<d> achieved | distribution | protocol | N | packings | phi (95 % CI) | bulk phi "
          "(95 % CI) | excess porosity eps - eps_bulk (Welch 95 %) | Benyahia-O'Neill eps | its excess over 0.390 |"
          " CPU s / packing |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|")
    for ratio, dist, protocol, cyl, bulk in rows:
        achieved = float(np.mean([r["achieved"]["diameter"] for r in cyl]))
        phis, bphis = [r["phi"] for r in cyl], [r["phi"] for r in bulk]
        m, h = welch(bphis, phis) if bulk else (float("nan"), None)
        excess = f"{m:+.4f} ± {h:.4f}" if h is not None else (f"{m:+.4f} (CI not estimable)" if bulk else "no bulk")
        bo = benyahia_oneill(achieved)
        print(f"| {ratio} | {achieved:.3f} | {DISTRIBUTIONS[dist]} | {protocol} | {CYLINDER_N[ratio]} | {len(cyl)} |"
              f" {fmt_ci(phis, 4)} | {fmt_ci(bphis, 4) if bulk else '-'} | {excess} | {bo:.4f} | {bo - 0.390:+.4f} |"
              f" {mean_ci([r['cpu'] for r in cyl])[0]:.1f} |")
    worst = max((max(r["worst_overlap"], r["worst_penetration"]) for *_, c, b in rows for r in c + b),
                default=float("nan"))
    print(f"\nworst overlap or wall penetration over every packing above: {worst:.2e} (limit 1e-10)")
    return int(status)


if __name__ == "__main__":
    sys.exit(main())
