"""The porosity profile of packings in a container, averaged over files of one container, and its features: the
porosity at the wall, the first minimum, the next minima (the period), the core phi and the largest deviation from
the core porosity beyond 5 d; with a periodic reference, the excess porosity over bulk beside Benyahia-O'Neill
(docs/containers_structure.md §7).

    python benchmarks/container_profiles.py --bulk 'per/*.h5' 'cyl7/*.h5'

Each positional argument is a glob of packing files of one container; ``--bulk`` a glob of periodic packings of the
same protocol (their mean porosity is eps_bulk).
"""

from __future__ import annotations

import argparse
import glob
import math

import numpy as np

from spherejam.analysis import packed_bed, profiles
from spherejam.core.packing_io import read_packing


def _mean_ci(x):
    """Mean and the half-width of its 95 % Student-t interval (NaN: not estimable, fewer than 3 values)."""
    from scipy.stats import t

    x = np.asarray(x, dtype=float)
    if len(x) < 3:
        return float(x.mean()), math.nan
    return float(x.mean()), float(t.ppf(0.975, len(x) - 1) * x.std(ddof=1) / math.sqrt(len(x)))


def _pm(ci, n):
    return f"+- {ci:.4f}" if math.isfinite(ci) else f"(interval not estimable, n = {n})"


def _minima(centres, eps, start=0.2):
    """Positions and values of the local minima of a profile beyond ``start`` diameters."""
    out = []
    for k in range(1, len(eps) - 1):
        if centres[k] > start and eps[k] < eps[k - 1] and eps[k] <= eps[k + 1]:
            out.append((float(centres[k]), float(eps[k])))
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("groups", nargs="+", help="globs of packing files, one container each")
    ap.add_argument("--bulk", help="glob of periodic packings of the same protocol (eps_bulk)")
    ap.add_argument("--bin-width", type=float, default=0.05)
    ap.add_argument("--core", type=float, default=5.0, help="core distance from every wall, mean diameters")
    args = ap.parse_args()
    eps_bulk = bulk_ci = None
    n_bulk = 0
    if args.bulk:
        phis = [read_packing(f).phi for f in sorted(glob.glob(args.bulk))]
        m, ci = _mean_ci(1.0 - np.array(phis))
        eps_bulk, bulk_ci, n_bulk = m, ci, len(phis)
        print(f"bulk: {len(phis)} periodic packings, eps_bulk = {m:.4f} {_pm(ci, len(phis))} (phi = {1 - m:.4f})")
    for pattern in args.groups:
        files = sorted(glob.glob(pattern))
        if not files:
            print(f"{pattern}: no files")
            continue
        packs = [read_packing(f) for f in files]
        profs = [profiles.profile(p, args.bin_width) for p in packs]
        c = packs[0].container
        ratio = [2 * p.container.radius / p.mean_diameter if c.curved else p.container.lengths[2] / p.mean_diameter
                 for p in packs]
        m = min(len(pr.porosity) for pr in profs)
        eps = np.mean([pr.porosity[:m] for pr in profs], axis=0)
        centres = profs[0].centres[:m]
        phi, phi_ci = _mean_ci([p.phi for p in packs])
        cores = [profiles.core(p, args.core) for p in packs]
        print(f"\n{c.spec}: {len(packs)} packings, N = {packs[0].n}, D/<d> (or H/<d>) = {np.mean(ratio):.3f}")
        print(f"  phi = {phi:.4f} {_pm(phi_ci, len(packs))}; eps = {1 - phi:.4f}")
        if cores[0].volume > 0:
            pc, pc_ci = _mean_ci([x.phi for x in cores])
            print(f"  core phi ({args.core:g} d from every wall, {cores[0].fraction_of_container:.3f} of the volume)"
                  f" = {pc:.4f} {_pm(pc_ci, len(packs))}")
            far = centres > args.core
            if far.any():
                print(f"  max |eps - eps_core| beyond {args.core:g} d (mean profile, bins of {args.bin_width:g} d):"
                      f" {np.max(np.abs(eps[far] - (1 - pc))):.4f}")
        else:
            print(f"  core phi: not estimable (no region {args.core:g} d from every wall)")
        print(f"  porosity of the wall bin [0, {args.bin_width:g}] d: {eps[0]:.4f}")
        mins = _minima(centres, eps)
        if mins:
            print("  local minima (distance from the wall in d, porosity): "
                  + ", ".join(f"({x:.3f}, {e:.3f})" for x, e in mins[:5]))
            if len(mins) >= 2:
                print(f"  spacing of the first minima: {np.diff([x for x, _ in mins[:4]]).round(3).tolist()} d")
        if eps_bulk is not None and c.curved == "cylinder":
            r = float(np.mean(ratio))
            row = packed_bed.comparison([r], [1 - phi], eps_bulk)[0]
            bo = row["excess_benyahia_oneill"]
            ci = math.hypot(phi_ci, bulk_ci)
            ci_text = (f"+- {ci:.4f}" if math.isfinite(ci)
                       else f"(CI not estimable: n = {len(packs)}, bulk n = {n_bulk})")
            print(f"  excess porosity over bulk: {row['excess']:.4f} {ci_text}; Benyahia-O'Neill at D/d = "
                  f"{r:.2f}: {'n/a' if bo is None else f'{bo:.4f}'}")


if __name__ == "__main__":
    main()
