"""Packed cylinders against the packed-bed literature (issue 45, acceptance "cylinders against the literature";
docs/containers_acceptance.md).

Rows: size distribution (monodisperse, log-normal sigma = 0.3) x D/d (5, 7, 10, 20) x protocol (the table
containers_common.PROTOCOLS: LS at gamma = 1, the fast rate; MLS; FB at gamma = 1e-3), each with --seeds packings (>= 10
for the issue) in a cylinder periodic along its axis, N fixed per D/d (CYLINDER_N; the length follows, 22 d at D/d = 5
down to 8.3 d at D/d = 20, so that N stays affordable). Beside each row the bulk phi of the same protocol and
distribution (periodic cube, --bulk-n spheres, the same seeds).

Table 1 per row: the achieved D/<d> (the container is sized from an estimate of the final phi, so it differs from the
asked one; <d> the final number-mean diameter), the mean phi with its 95 % t-interval, the excess porosity over bulk
(eps - eps_bulk = phi_bulk - phi, Welch 95 % interval) and its product with D/<d> (constant if the excess is a wall
layer of fixed thickness, whose share of the volume goes as 4 / (D/d)), and the verified mean-porosity correlations of
analysis.packed_bed (Benyahia & O'Neill 2005) at the achieved D/<d>, with their excess over their own bulk limit.
Frictionless jammed packings are denser than poured or slurry-packed beds, so only the excess compares.

Table 2 per row: the exact radial porosity profile of each packing (analysis.profiles, bins of 0.025 d, stored in its
record) against the issue's criteria (containers_common.profile_features): porosity 1 at the wall, first minimum at
0.5 +- 0.1 d, period about 1 d, |eps - eps_core| < 0.03 beyond 5 d (D/d = 20 only: no narrower cylinder has a core
holding 5 % of its volume).
``--figure PNG`` draws the mean profiles and the excess porosity against D/d.

One JSON record per packing in --out (default: the committed benchmarks/records/containers/cylinders); runs present
are skipped, so the matrix resumes; ``--table-only`` rebuilds the tables from the records.

    python benchmarks/containers_cylinders.py --protocols ls fb          # the cheap rows first
    python benchmarks/containers_cylinders.py                            # all rows, 10 seeds (resumes)
    python benchmarks/containers_cylinders.py --table-only --figure benchmarks/records/containers/cylinders.png
"""

from __future__ import annotations

import argparse
import sys
import time

import numpy as np
from containers_common import CORE_DISTANCE, DISTRIBUTIONS, PROTOCOLS, RECORDS, Records, brute_force, fmt_ci, \
    mean_ci, mean_profile, profile_features, profile_record, provenance, start_packing, welch

from spherejam.analysis import packed_bed

#: N per asked D/d: enough for a column at least ~8 d long, periodic along its axis.
CYLINDER_N = {5: 500, 7: 725, 10: 1000, 20: 3000}

#: The verified mean-porosity correlations (analysis.packed_bed; unverified ones are excluded there)
CORRELATIONS = [c for c in packed_bed.CORRELATIONS.values() if c.kind == "mean" and c.verified]


def run(spec: str, n: int, dist: str, protocol: str, seed: int) -> dict:
    cpu0 = time.process_time()
    start = start_packing(n, dist, spec, seed)
    result = PROTOCOLS[protocol][1](start, seed, None)
    q = result.packing
    return {"container": spec, "n": n, "dist": dist, "protocol": protocol, "seed": seed, "phi": q.phi,
            "stop": result.stats.stop_reason, "cpu": time.process_time() - cpu0,
            "achieved": q.container.in_diameters(q.mean_diameter),
            **(profile_record(q) if q.container.has_walls else {}),
            **brute_force(q.positions, q.diameters, q.container), **provenance()}


def _pm(values, digits=3) -> str:
    m, h = mean_ci(values)
    return f"{m:.{digits}f} ± {h:.{digits}f}" if h is not None else f"{m:.{digits}f} (CI n/e, n = {len(values)})"


def profile_rows(rows) -> list[str]:
    """Table 2: the profile criteria of each row, per packing (mean, 95 % t) and on the row's mean profile."""
    out = ["| D/d | distribution | protocol | packings | wall bin eps [0, 0.025 d] | eps extrapolated to the wall "
           "(target 1) | first minimum, d (target 0.5 ± 0.1) | its eps | period, d (target ≈ 1) | minima of the "
           "mean profile (d, eps) | core eps | max abs(eps - eps_core) beyond 5 d, 0.5 d shells (target < 0.03) |",
           "|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for ratio, dist, protocol, cyl, _ in rows:
        cyl = [r for r in cyl if "profile" in r]
        if not cyl:
            continue
        # a core that is a thin thread along the axis (D/d = 10: 0.15 d in radius) is not a bulk region
        cores = [1.0 - r["core_phi"] for r in cyl if r.get("core_phi") is not None and r["core_fraction"] >= 0.05]
        per = [profile_features(*mean_profile([r]), None) for r in cyl]
        first = [f["minima"][0][0] for f in per if f["minima"]]
        first_eps = [f["minima"][0][1] for f in per if f["minima"]]
        periods = [f["period"] for f in per if f["period"] is not None]
        eps_core = float(np.mean(cores)) if cores else None
        mean = profile_features(*mean_profile(cyl), eps_core)
        mins = ", ".join(f"({x:.3f}, {e:.3f})" for x, e in mean["minima"])
        dev = "no core" if mean["core_deviation"] is None else f"{mean['core_deviation']:.4f}"
        out.append(f"| {ratio} | {DISTRIBUTIONS[dist]} | {protocol} | {len(cyl)} | {_pm([f['wall_bin'] for f in per])}"
                   f" | {_pm([f['wall_extrapolated'] for f in per])} | {_pm(first)} | {_pm(first_eps)} |"
                   f" {_pm(periods)} | {mins} | {_pm(cores, 4) if cores else 'no core (< 5 % of the volume)'} |"
                   f" {dev} |")
    return out


def figure(rows, path: str) -> None:
    """Left: the mean radial porosity profile of each monodisperse row; right: the excess porosity over bulk against
    the achieved D/<d>, beside each verified correlation's excess."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, (a, b) = plt.subplots(1, 2, figsize=(12, 4.5))
    styles = {"ls": "-", "mls": "--", "fb": ":"}
    colours = dict(zip(CYLINDER_N, ["C0", "C1", "C2", "C3"]))
    for ratio, dist, protocol, cyl, bulk in rows:
        cyl = [r for r in cyl if "profile" in r]
        if dist == "mono" and cyl:
            x, eps, _ = mean_profile(cyl)
            a.plot(x, eps, styles[protocol], color=colours[ratio], lw=1,
                   label=f"D/d = {ratio}, {protocol.upper()} (n = {len(cyl)})")
        if cyl and bulk:
            ach = float(np.mean([r["achieved"]["diameter"] for r in cyl]))
            m, h = welch([r["phi"] for r in bulk], [r["phi"] for r in cyl])
            shift = {"ls": -0.15, "mls": 0.0, "fb": 0.15}[protocol]  # side by side, not on top of each other
            b.errorbar(ach + shift, m, yerr=h or 0, fmt={"ls": "o", "mls": "s", "fb": "^"}[protocol],
                       color="C0" if dist == "mono" else "C3", ms=5, capsize=3)
    a.axhline(1.0, color="grey", lw=0.5)
    a.set_xlim(0, 6)
    a.set_xlabel("distance from the wall / <d>")
    a.set_ylabel("porosity eps (exact, bins of 0.025 d)")
    a.set_title("mean radial profile, monodisperse")
    a.legend(fontsize=7, ncol=2)
    r = np.linspace(4.5, 22, 200)
    for c in CORRELATIONS:
        b.plot(r, packed_bed.correlation_excess(c.name, r), "k-", lw=1, label=f"{c.name}: excess over {c.bulk}")
    for proto, mark in (("ls", "o"), ("mls", "s"), ("fb", "^")):
        for dist, col in (("mono", "C0"), ("sigma0.3", "C3")):
            b.plot([], [], mark, color=col, label=f"{proto.upper()}, {DISTRIBUTIONS[dist]}")
    b.set_xlabel("achieved D/<d> (LS, MLS, FB drawn 0.15 apart)")
    b.set_ylabel("excess porosity eps - eps_bulk (Welch 95 %)")
    b.set_title("excess porosity over bulk of the same protocol")
    b.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    print(f"figure: {path}")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default=str(RECORDS / "cylinders"), help="folder of the per-packing JSON records")
    ap.add_argument("--seeds", type=int, default=10)
    ap.add_argument("--diameters", nargs="+", type=int, default=list(CYLINDER_N), choices=list(CYLINDER_N))
    ap.add_argument("--dists", nargs="+", default=["mono", "sigma0.3"], choices=list(DISTRIBUTIONS))
    ap.add_argument("--protocols", nargs="+", default=list(PROTOCOLS), choices=list(PROTOCOLS))
    ap.add_argument("--bulk-n", type=int, default=2000)
    ap.add_argument("--table-only", action="store_true", help="print what the records hold; run nothing")
    ap.add_argument("--figure", help="draw the mean profiles and the excess porosity into this PNG")
    args = ap.parse_args(argv)
    store = Records(args.out)

    def get(kind, spec, n, dist, protocol, seed):
        k = f"{kind}_{dist}_{protocol}_N{n}_s{seed}"
        rec = store.get(k)
        # a cylinder's record from before the profiles were recorded is run again (the seed gives the same packing)
        stale = rec is not None and kind != "bulk" and "profile" not in rec
        if (rec is None or stale) and not args.table_only:
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
    names = " | ".join(f"{c.name} eps | its excess over {c.bulk}" for c in CORRELATIONS)
    print(f"\n| D/d asked | D/<d> achieved | distribution | protocol | N | packings | phi (95 % CI) | bulk phi "
          f"(95 % CI) | excess porosity eps - eps_bulk (Welch 95 %) | excess x D/<d> | {names} | CPU s / packing |")
    print("|---|---|---|---|---|---|---|---|---|---|" + "---|---|" * len(CORRELATIONS) + "---|")
    for ratio, dist, protocol, cyl, bulk in rows:
        achieved = float(np.mean([r["achieved"]["diameter"] for r in cyl]))
        phis, bphis = [r["phi"] for r in cyl], [r["phi"] for r in bulk]
        m, h = welch(bphis, phis) if bulk else (float("nan"), None)
        excess = f"{m:+.4f} ± {h:.4f}" if h is not None else (f"{m:+.4f} (CI not estimable)" if bulk else "no bulk")
        corr = " | ".join(f"{packed_bed.mean_porosity(c.name, achieved):.4f} | "
                          f"{packed_bed.correlation_excess(c.name, achieved):+.4f}" for c in CORRELATIONS)
        print(f"| {ratio} | {achieved:.3f} | {DISTRIBUTIONS[dist]} | {protocol} | {CYLINDER_N[ratio]} | {len(cyl)} |"
              f" {fmt_ci(phis, 4)} | {fmt_ci(bphis, 4) if bulk else '-'} | {excess} | {m * achieved:.3f} | {corr} |"
              f" {mean_ci([r['cpu'] for r in cyl])[0]:.1f} |")
    worst = max((max(r["worst_overlap"], r["worst_penetration"]) for *_, c, b in rows for r in c + b),
                default=float("nan"))
    print(f"\nworst overlap or wall penetration over every packing above: {worst:.2e} (limit 1e-10)")
    print(f"\nradial profiles (distance from the wall in <d>; core: at least {CORE_DISTANCE:g} d from the wall; "
          "per-packing figures as mean ± 95 % t over packings):\n")
    print("\n".join(profile_rows(rows)))
    if args.figure:
        figure(rows, args.figure)
    return int(status)


if __name__ == "__main__":
    sys.exit(main())
