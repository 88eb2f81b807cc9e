"""The core of a tall slab against the periodic box (issue 45, acceptance "physics": a slab with a height >= 30 d
recovers the periodic phi_J of the same protocol in its core, within the CI; docs/containers_acceptance.md).

For each protocol of the table (containers_common.PROTOCOLS: LS, MLS) and each seed: N spheres in a slab of height
H (default 30 mean diameters; the square cross-section follows from N), and the same N, size distribution, protocol
and seed in the periodic cube. The slab's **core** is the layer 5 <d> <= z <= H - 5 <d> (<d> the final mean
diameter, H the achieved height). Its phi is estimated two ways:

  * slice (primary): the volume of every sphere inside the core layer, exactly (the spherical caps cut by the
    layer's planes: the volume of a sphere of radius r whose centre is at height z0 between the planes z = a and
    z = b is the integral of pi (r^2 - (z - z0)^2) over [max(a, z0 - r), min(b, z0 + r)]), divided by the layer's
    volume;
  * centres: the full volume of the spheres whose centres lie in the core layer, divided by its volume (also
    unbiased in a homogeneous layer, noisier).

Printed per protocol: the slab's core phi, the whole slab's phi and the periodic phi_J (mean, 95 % t-interval over
seeds), and the difference core - periodic with its Welch 95 % interval. One JSON record per run in --out (default:
the committed benchmarks/records/containers/slab_core).

    python benchmarks/containers_slab_core.py --seeds 5 --protocols ls mls
    python benchmarks/containers_slab_core.py --table-only
"""

from __future__ import annotations

import argparse
import math
import sys
import time

import numpy as np
from containers_common import DISTRIBUTIONS, PROTOCOLS, RECORDS, Records, brute_force, fmt_ci, provenance, \
    start_packing, welch

MARGIN = 5.0  # core: centres this many mean diameters from both walls


def layer_volume(z0: np.ndarray, r: np.ndarray, a: float, b: float) -> np.ndarray:
    """Volume of each sphere (centre height z0, radius r) between the planes z = a and z = b (a < b), exactly."""
    lo = np.clip(a - z0, -r, r)
    hi = np.clip(b - z0, -r, r)
    # integral of pi (r^2 - u^2) du from lo to hi
    return math.pi * (r * r * (hi - lo) - (hi**3 - lo**3) / 3.0)


def core_phi(packing, margin: float = MARGIN) -> dict:
    c = packing.container
    d = packing.diameters
    mean_d = packing.mean_diameter
    h = c.lengths[2]
    a, b = margin * mean_d, h - margin * mean_d
    area = c.lengths[0] * c.lengths[1]
    z = packing.positions[:, 2]
    slice_phi = float(layer_volume(z, 0.5 * d, a, b).sum() / (area * (b - a)))
    inside = (z >= a) & (z <= b)
    centre_phi = float(np.sum(math.pi / 6.0 * d[inside] ** 3) / (area * (b - a)))
    return {"core_phi_slice": slice_phi, "core_phi_centres": centre_phi, "core_spheres": int(inside.sum()),
            "core_thickness": (b - a) / mean_d, "height": h / mean_d}


def run(kind: str, protocol: str, dist: str, n: int, height: float, seed: int) -> dict:
    spec = f"slab:height={height:g}" if kind == "slab" else "periodic"
    cpu0 = time.process_time()
    start = start_packing(n, dist, spec, seed)
    result = PROTOCOLS[protocol][1](start, seed, None)
    q = result.packing
    rec = {"kind": kind, "protocol": protocol, "dist": dist, "n": n, "seed": seed, "container": spec,
           "phi": q.phi, "stop": result.stats.stop_reason, "cpu": time.process_time() - cpu0,
           "achieved": q.container.in_diameters(q.mean_diameter), **brute_force(q.positions, q.diameters, q.container),
           **provenance()}
    if kind == "slab":
        rec.update(core_phi(q))
    return rec


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default=str(RECORDS / "slab_core"), help="folder of the per-run JSON records "
                    "(resumable; default: the committed benchmarks/records/containers/slab_core)")
    ap.add_argument("--seeds", type=int, default=5)
    ap.add_argument("--n", type=int, default=2200, help="N of both the slab and the periodic cube")
    ap.add_argument("--height", type=float, default=30.0, help="slab height in mean diameters (>= 30 for the issue)")
    ap.add_argument("--psd", default="mono", choices=list(DISTRIBUTIONS))
    ap.add_argument("--table-only", action="store_true", help="summarise the records present; run nothing")
    ap.add_argument("--protocols", nargs="+", default=list(PROTOCOLS), choices=list(PROTOCOLS))
    args = ap.parse_args(argv)
    store = Records(args.out)
    status = 0
    for protocol in args.protocols:
        recs = {"slab": [], "periodic": []}
        for seed in range(1, args.seeds + 1):
            for kind in ("slab", "periodic"):
                k = f"{kind}_{protocol}_{args.psd}_N{args.n}_H{args.height:g}_s{seed}"
                rec = store.get(k)
                if rec is None and args.table_only:
                    continue
                if rec is None:
                    rec = run(kind, protocol, args.psd, args.n, args.height, seed)
                    store.put(k, rec)
                    print(f"  {k}: phi={rec['phi']:.5f} core={rec.get('core_phi_slice', float('nan')):.5f} "
                          f"stop={rec['stop']} cpu={rec['cpu']:.1f}s overlap={rec['worst_overlap']:.1e} "
                          f"penetration={rec['worst_penetration']:.1e}", flush=True)
                if max(rec["worst_overlap"], rec["worst_penetration"]) > 1e-10:
                    status = 1
                recs[kind].append(rec)
        slab, per = recs["slab"], recs["periodic"]
        if not slab or not per:
            print(f"\n{protocol}: no records")
            continue
        print(f"\n{protocol} ({PROTOCOLS[protocol][0]}), {DISTRIBUTIONS[args.psd]}, N = {args.n}, slab height "
              f"{np.mean([r['height'] for r in slab]):.2f} <d> (achieved), core {MARGIN:g} <d> from each wall "
              f"({np.mean([r['core_thickness'] for r in slab]):.2f} <d> thick, "
              f"{np.mean([r['core_spheres'] for r in slab]):.0f} centres):")
        print(f"  slab core phi (exact slice)   {fmt_ci([r['core_phi_slice'] for r in slab], 4)}")
        print(f"  slab core phi (centres)       {fmt_ci([r['core_phi_centres'] for r in slab], 4)}")
        print(f"  slab whole phi                {fmt_ci([r['phi'] for r in slab], 4)}")
        print(f"  periodic phi_J                {fmt_ci([r['phi'] for r in per], 4)}")
        m, h = welch([r["core_phi_slice"] for r in slab], [r["phi"] for r in per])
        verdict = "not estimable" if h is None else ("within the CI" if abs(m) <= h else "OUTSIDE the CI")
        print(f"  core - periodic = {m:+.4f}" + (f" ± {h:.4f} (Welch 95 %): {verdict}" if h is not None
                                                  else f" (CI not estimable, n = {len(slab)})"))
        print(f"  CPU s per packing: slab {np.mean([r['cpu'] for r in slab]):.1f}, periodic "
              f"{np.mean([r['cpu'] for r in per]):.1f}", flush=True)
    return status


if __name__ == "__main__":
    sys.exit(main())
