"""spherejam's LS beside spheropack's ``pack()`` in the same containers, in one run (issue 45, acceptance "side by
side with spheropack"; docs/containers_acceptance.md).

Containers (the same geometry for both codes, in units of the nominal diameter, equal spheres):
  * cylinder: D = 7 d, periodic along its axis, N = 725, the length that holds them at phi = 0.54 (18.27 d): the
    tube baseline of spheropack (its tests/baselines: 725 spheres, D/d = 7, periodic axis, 10 seeds);
  * slab: walls 10 d apart, periodic square cross-section, N = 725 at phi = 0.54.
Both codes start from points (ours: Poisson centres inside the walls, closest pair touching) and grow the spheres at a
constant rate until the mean reduced pressure PV/(NkT) exceeds 1e12 (ours: LS with p_max = 1e12; spheropack:
``density="max", stop=[Pressure(1e12)]``). Growth rates: ours gamma = d<d>/dt in units of the final mean diameter
(docs/algorithms.md §2, T = 0.2), spheropack's Gamma = (d<d>/dt) / sqrt(kT/m); the same Gamma is gamma / sqrt(0.2).

For each seed the two codes run one after the other in this process (order alternating by seed), each timed by
its own CPU time (time.process_time: the machine is shared). Both codes' packings get the same exact porosity profile
(containers_common.profile_record: radial in the cylinder, folded axial in the slab), compared bin by bin over seeds
(compare_profiles). Printed per container: phi (mean, 95 % t-interval over
seeds) of each code and their difference, the achieved D/<d> (or H/<d>), collisions per CPU second of each code
(spheropack's own count ``Packing.n_collisions``, which includes sphere-wall collisions; ours: the engine's pair
collisions plus its wall collisions, summed over the windows) and their ratio, the CPU time to jam and its ratio.

Needs spheropack in the running interpreter (a venv under /tmp, never a dependency of spherejam):

    python -m venv --system-site-packages /tmp/contbench_venv && /tmp/contbench_venv/bin/pip install spheropack==0.2.0
    PYTHONPATH=src /tmp/contbench_venv/bin/python benchmarks/containers_spheropack.py --out runs/spheropack
"""

from __future__ import annotations

import argparse
import math
import sys
import time

import numpy as np
from containers_common import RECORDS, Records, brute_force, fmt_ci, mean_ci, mean_profile, profile_features, \
    profile_record, provenance, welch

from spherejam.core.packing import Packing
from spherejam.core.seeding import poisson_packing
from spherejam.engines.lubachevsky_stillinger import run_ls

TEMPERATURE = 0.2
N = 725
PHI_NOMINAL = 0.54  # the tube baseline's length: 725 spheres of diameter d at phi = 0.54 in a D = 7 d tube
CONTAINERS = {"cylinder": "cylinder:diameter=7", "slab": "slab:height=10"}


def ours(spec: str, seed: int, rate: float) -> dict:
    start = poisson_packing(N, seed=seed, container=spec, phi_nominal=PHI_NOMINAL)
    walls = [0]

    def count_walls(_, stats):
        walls[0] += stats.wall_collisions

    cpu0 = time.process_time()
    r = run_ls(start, rate, seed=seed, progress_interval=1e9, callback=count_walls)
    cpu = time.process_time() - cpu0
    q = r.packing
    check = brute_force(q.positions, q.diameters, q.container)
    temps = np.asarray(r.history["temperature"], dtype=float)
    # spheropack's n_collisions counts sphere-wall collisions too (two spheres in a closed box collide thousands of
    # times, in a periodic one tens), so ours are counted alike: the engine's pair collisions plus its wall ones
    return {"phi": q.phi, "collisions": int(r.stats.collisions) + walls[0], "pair_collisions": int(r.stats.collisions),
            "wall_collisions": walls[0], "cpu": cpu, "stop": r.stats.stop_reason,
            "reduced_pressure": q.metadata.get("reduced_pressure"),
            "achieved": q.container.in_diameters(q.mean_diameter),
            "window_temperature_median": float(np.median(temps)), **check, **profile_record(q)}


def container_of(spec: str):
    """Our container's geometry (nominal units), for handing the same box to spheropack."""
    return poisson_packing(N, seed=0, container=spec, phi_nominal=PHI_NOMINAL).container


def theirs(spec: str, seed: int, big_gamma: float) -> dict:
    import spheropack
    from spheropack import stop

    c = container_of(spec)
    if c.curved == "cylinder":
        box = spheropack.Cylinder(diameter=2.0 * c.radius, length=c.lengths[2], capped=False)
    else:
        box = spheropack.Box(list(c.lengths), periodic=list(c.periodic))
    cpu0 = time.process_time()
    p = spheropack.pack(N, radii=0.5, container=box, density="max", growth_rate=big_gamma,
                        stop=[stop.Pressure(1e12)], seed=seed)
    cpu = time.process_time() - cpu0
    d = 2.0 * np.asarray(p.radii, dtype=float)
    check = brute_force(np.asarray(p.positions, dtype=float), d, c)
    mean_d = float(d.mean())
    achieved = ({"diameter": 2.0 * c.radius / mean_d} if c.curved else {"height": c.lengths[2] / mean_d})
    # its centres in our frame (the same container, the same origin): the same exact profile as ours
    q = Packing(np.asarray(p.positions, dtype=float), d, math.nan, container=c)
    return {"phi": float(p.density), "collisions": int(p.n_collisions), "events": int(p.n_events), "cpu": cpu,
            "stop": str(p.status), "reduced_pressure": float(p.reduced_pressure), "achieved": achieved,
            "shrink_factor": float(p.shrink_factor), "min_gap": float(p.min_gap), **check, **profile_record(q)}


def compare_profiles(a: list[dict], b: list[dict]) -> None:
    """Our exact porosity profiles against spheropack's (the same function on both codes' centres): each code's
    criteria on its mean profile, and per bin the Welch difference over seeds; if the two agree, about 5 % of the
    bins have a 95 % interval that excludes 0."""
    xa, ea, sa = mean_profile(a)
    xb, eb, sb = mean_profile(b)
    m = min(len(xa), len(xb))
    kind = a[0]["profile"]["kind"]
    print(f"  porosity profile ({kind}, distance from the wall in <d>, bins of {a[0]['profile']['bin_width']:g} d):")
    for code, rr, (x, e, s) in (("ours", a, (xa, ea, sa)), ("spheropack", b, (xb, eb, sb))):
        f = profile_features(x, e, s, None)
        per = [profile_features(*mean_profile([r]), None) for r in rr]
        first = [g["minima"][0][0] for g in per if g["minima"]]
        mins = ", ".join(f"({p:.3f}, {q:.3f})" for p, q in f["minima"])
        period = "not estimable" if f["period"] is None else f"{f['period']:.3f} d"
        print(f"    {code:10s} wall bin eps = {f['wall_bin']:.3f}, extrapolated to the wall "
              f"{f['wall_extrapolated']:.3f}; first minimum {fmt_ci(first, 3)} d; minima of the mean profile {mins}; "
              f"period {period}")
    diffs, outside = [], 0
    for k in range(m):
        d, h = welch([r["profile"]["porosity"][k] for r in a], [r["profile"]["porosity"][k] for r in b])
        diffs.append(d)
        outside += h is not None and abs(d) > h
    diffs = np.asarray(diffs)
    k = int(np.argmax(np.abs(diffs)))
    print(f"    ours - spheropack per bin: largest |difference| {abs(diffs[k]):.4f} at {xa[k]:.3f} d; "
          f"{outside} of {m} bins ({100 * outside / m:.0f} %) with a Welch 95 % interval excluding 0; "
          f"mean difference over the first 1 d {diffs[xa[:m] < 1.0].mean():+.4f}, beyond 1 d "
          f"{diffs[xa[:m] >= 1.0].mean():+.4f}")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default=str(RECORDS / "spheropack"), help="folder of the per-run JSON records "
                    "(resumable; default: the committed benchmarks/records/containers/spheropack)")
    ap.add_argument("--seeds", type=int, default=10)
    ap.add_argument("--rate", type=float, default=0.1, help="our LS gamma (spheropack: gamma / sqrt(0.2))")
    ap.add_argument("--table-only", action="store_true", help="summarise the records present; run nothing")
    ap.add_argument("--containers", nargs="+", default=list(CONTAINERS), choices=list(CONTAINERS))
    args = ap.parse_args(argv)
    try:
        import spheropack
    except ImportError:
        print("spheropack is not installed in this interpreter (see the docstring for the venv)", file=sys.stderr)
        return 2
    big_gamma = args.rate / math.sqrt(TEMPERATURE)
    store = Records(args.out)
    # warm-up (numba's cached code, spheropack's module): not timed, not recorded
    run_ls(poisson_packing(50, seed=1, container="cylinder:diameter=4"), 1.0, progress_interval=1e9)
    print(f"spheropack {spheropack.__version__}; N = {N}; our gamma = {args.rate:g}, spheropack Gamma = "
          f"{big_gamma:.4g}; stop at reduced pressure 1e12; {args.seeds} seeds", flush=True)
    status = 0
    for name in args.containers:
        spec = CONTAINERS[name]
        rows = {"ours": [], "spheropack": []}
        for seed in range(1, args.seeds + 1):
            order = ("ours", "spheropack") if seed % 2 else ("spheropack", "ours")
            for code in order:
                k = f"{name}_{code}_g{args.rate:g}_s{seed}"
                rec = store.get(k)
                if rec is not None and "profile" not in rec and not args.table_only:
                    rec = None  # from before the profiles were recorded: both codes are run again in this run
                if rec is None and args.table_only:
                    continue
                if rec is None:
                    rec = (ours(spec, seed, args.rate) if code == "ours" else theirs(spec, seed, big_gamma))
                    rec.update(code=code, container=spec, seed=seed, rate=args.rate, big_gamma=big_gamma,
                               **provenance())
                    store.put(k, rec)
                    print(f"  {k}: phi={rec['phi']:.5f} collisions={rec['collisions']:,} cpu={rec['cpu']:.2f}s "
                          f"overlap={rec['worst_overlap']:.2e} penetration={rec['worst_penetration']:.2e} "
                          f"stop={rec['stop']} load={rec['load']:.1f}", flush=True)
                rows[code].append(rec)
        both = {r["seed"] for r in rows["ours"]} & {r["seed"] for r in rows["spheropack"]}
        rows = {code: sorted((r for r in rr if r["seed"] in both), key=lambda r: r["seed"])
                for code, rr in rows.items()}
        if not both:
            print(f"\n{name}: no seed with both codes yet")
            continue
        print(f"\n{name} (`{spec}`, N = {N}, nominal phi {PHI_NOMINAL}):")
        for code, rr in rows.items():
            ach = {k: np.mean([r["achieved"][k] for r in rr]) for k in rr[0]["achieved"]}
            cps = sum(r["collisions"] for r in rr) / sum(r["cpu"] for r in rr)
            print(f"  {code:10s} phi = {fmt_ci([r['phi'] for r in rr], 4)}; achieved "
                  f"{', '.join(f'{k}/<d> = {v:.3f}' for k, v in ach.items())}; collisions per CPU s = {cps:,.0f}; "
                  f"CPU s to jam = {fmt_ci([r['cpu'] for r in rr], 2)}; collisions to jam = "
                  f"{np.mean([r['collisions'] for r in rr]):,.0f}; worst overlap "
                  f"{max(r['worst_overlap'] for r in rr):.2e}, worst penetration "
                  f"{max(r['worst_penetration'] for r in rr):.2e}")
            if max(max(r["worst_overlap"], r["worst_penetration"]) for r in rr) > 1e-10:
                status = 1 if code == "ours" else status
        a, b = rows["ours"], rows["spheropack"]
        m, h = mean_ci([x["phi"] - y["phi"] for x, y in zip(a, b)])
        print(f"  phi(ours) - phi(spheropack), paired by seed: {m:+.4f}"
              + (f" ± {h:.4f}" if h is not None else f" (CI not estimable, n = {len(a)})"))
        ratio = (sum(r["collisions"] for r in a) / sum(r["cpu"] for r in a)) / \
                (sum(r["collisions"] for r in b) / sum(r["cpu"] for r in b))
        per_seed = [(x["collisions"] / x["cpu"]) / (y["collisions"] / y["cpu"]) for x, y in zip(a, b)]
        print(f"  collisions per CPU second, ours / spheropack = {ratio:.2f} (pooled; per seed "
              f"{fmt_ci(per_seed, 2)}); target >= 3")
        t_ratio = sum(r["cpu"] for r in a) / sum(r["cpu"] for r in b)
        print(f"  CPU time to jam, ours / spheropack = {t_ratio:.2f}; collisions to jam, ours / spheropack = "
              f"{sum(r['collisions'] for r in a) / sum(r['collisions'] for r in b):.2f}", flush=True)
        if all("profile" in r for r in a + b):
            compare_profiles(a, b)
    return status


if __name__ == "__main__":
    sys.exit(main())
