"""The containers' stress matrix (issue 45, acceptance "no overlap, no wall penetration"; docs/containers_acceptance).

Every shape (slab, closed box, periodic cylinder, capped cylinder, sphere, non-cubic periodic box) x size distribution
(monodisperse, log-normal sigma = 0.3, bidisperse 1:4) x N (20, 500, 5000) x protocol (the table PROTOCOLS of
containers_common: LS, MLS, FB). Each output is checked by brute force (containers_common.
brute_force: all pairs, images along periodic axes only, chunked), and must have a worst relative overlap and a
worst relative wall penetration <= 1e-10.

Each container is sized from N (containers_common.SHAPES: about the cube side s of N spheres at phi = 0.62). One JSON
record per run in --out (default: the committed benchmarks/records/containers/stress); a run whose record exists is
skipped, so an interrupted matrix resumes where it stopped.
Prints the table (shape x distribution x N x protocol: worst overlap, worst penetration, phi, stop reason, CPU s).

    python benchmarks/containers_stress.py --n 20 500
    python benchmarks/containers_stress.py --n 5000 --max-wall 3000
    python benchmarks/containers_stress.py --table-only      # print what is there
    python benchmarks/containers_stress.py --narrow          # the NARROW containers (minutes)
"""

from __future__ import annotations

import argparse
import math
import sys
import time
import traceback

from containers_common import DISTRIBUTIONS, LIMIT, PROTOCOLS, RECORDS, SHAPES, Records, brute_force, cube_side, \
    provenance, start_packing

from spherejam.core.errors import InputError


def run_case(shape: str, dist: str, n: int, protocol: str, seed: int, max_wall: float | None) -> dict:
    spec = SHAPES[shape](cube_side(n, dist))
    record = {"shape": shape, "dist": dist, "psd": DISTRIBUTIONS[dist], "n": n, "protocol": protocol,
              "seed": seed, "container": spec, "protocol_text": PROTOCOLS[protocol][0], **provenance()}
    cpu0, t0 = time.process_time(), time.perf_counter()
    try:
        start = start_packing(n, dist, spec, seed)
        result = PROTOCOLS[protocol][1](start, seed, max_wall)
        q = result.packing
        check = brute_force(q.positions, q.diameters, q.container)
        record.update(check)
        record.update(phi=q.phi, stop=result.stats.stop_reason, collisions=result.stats.collisions,
                      achieved=q.container.in_diameters(q.mean_diameter),
                      reduced_pressure=q.metadata.get("reduced_pressure"),
                      outcome="ok" if check["worst_overlap"] <= LIMIT and check["worst_penetration"] <= LIMIT
                      else "FAIL")
    except InputError as exc:
        record.update(outcome="refused", reason=str(exc))
    except Exception as exc:  # noqa: BLE001 - a crash is a finding, recorded with its traceback
        record.update(outcome="error", reason=f"{type(exc).__name__}: {exc}", traceback=traceback.format_exc())
    record.update(cpu=time.process_time() - cpu0, wall=time.perf_counter() - t0)
    return record


#: Narrow containers (``--narrow``): single file, two abreast, few spheres against curved walls, a monolayer-thin slab,
#: wide size ratios against walls; specs whose largest sampled sphere does not fit are refused up front.
NARROW = [("cylinder:diameter=1.2", 20, "lognormal:sigma=0"), ("cylinder:diameter=1.5", 30, "lognormal:sigma=0.3"),
          ("cylinder:diameter=2.2,capped=yes", 30, "lognormal:sigma=0"),
          ("sphere:diameter=2.5", None, "lognormal:sigma=0"),
          ("box:x=1.3,y=1.3", 20, "lognormal:sigma=0"), ("slab:height=1.3", 50, "lognormal:sigma=0.3"),
          ("cylinder:diameter=5", 200, "bidisperse:ratio=4,small=0.5,by=number"),
          ("sphere:diameter=6", None, "bidisperse:ratio=4,small=0.5,by=number"),
          ("cylinder:diameter=2.0", 40, "lognormal:sigma=0"), ("slab:height=2.0", 60, "lognormal:sigma=0")]


def narrow(seeds: int = 3) -> int:
    """LS at gamma = 10 and 1e-2 and MLS in each NARROW container, ``seeds`` seeds; prints one line per run and the
    worst overlap and penetration; returns the number of failed runs."""
    from spherejam.core.seeding import poisson_packing
    from spherejam.engines.closest_jamming import find_closest_jamming
    from spherejam.engines.lubachevsky_stillinger import run_ls

    runs = {"ls10": lambda p, s: run_ls(p, 10.0, seed=s, progress_interval=1e9, max_wall_time=600),
            "ls0.01": lambda p, s: run_ls(p, 0.01, seed=s, progress_interval=1e9, max_wall_time=600),
            "mls": lambda p, s: find_closest_jamming(p, initial_rate=10, final_rate=1e-2, seed=s, progress_interval=1e9,
                                                     max_wall_time=600)}
    worst, failed, done = [-math.inf, -math.inf], 0, 0
    for spec, n, psd in NARROW:
        for seed in range(1, seeds + 1):
            try:
                start = poisson_packing(n, psd=psd, container=spec, seed=seed)
            except InputError as exc:
                print(f"refused {spec} n={n} {psd} seed={seed}: {exc}")
                continue
            for name, run in runs.items():
                try:
                    r = run(start, seed)
                except Exception as exc:  # noqa: BLE001 - a crash is a finding
                    failed += 1
                    print(f"ERROR {spec} n={n} {psd} seed={seed} {name}: {type(exc).__name__}: {exc}", flush=True)
                    continue
                q = r.packing
                c = brute_force(q.positions, q.diameters, q.container)
                worst = [max(worst[0], c["worst_overlap"]), max(worst[1], c["worst_penetration"])]
                bad = max(c["worst_overlap"], c["worst_penetration"]) > LIMIT
                failed += bad
                done += 1
                print(f"{'FAIL' if bad else 'ok'} {spec} n={q.n} {psd} seed={seed} {name}: phi={q.phi:.4f} "
                      f"stop={r.stats.stop_reason} overlap={c['worst_overlap']:.1e} "
                      f"penetration={c['worst_penetration']:.1e}", flush=True)
    print(f"narrow containers: {done} runs, {failed} failed; worst overlap {worst[0]:.2e}, worst penetration "
          f"{worst[1]:.2e} (limit {LIMIT:g})")
    return failed


def key(shape, dist, n, protocol, seed) -> str:
    return f"{shape}_{dist}_N{n}_{protocol}_s{seed}"


def table(records: list[dict]) -> str:
    lines = ["| shape | distribution | N | protocol | container (asked) | achieved | worst overlap | "
             "worst penetration | phi | stop | CPU s | outcome |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in records:
        ach = ", ".join(f"{k}={v:.3f}" for k, v in (r.get("achieved") or {}).items())
        ov = f"{r['worst_overlap']:.2e}" if "worst_overlap" in r else "-"
        pen = r.get("worst_penetration")
        pen = "-" if pen is None else ("no wall" if pen == float("-inf") else f"{pen:.2e}")
        phi = f"{r['phi']:.4f}" if "phi" in r else "-"
        outcome = r["outcome"] if r["outcome"] in ("ok", "FAIL") else f"{r['outcome']}: {r.get('reason', '')}"
        lines.append(f"| {r['shape']} | {r['dist']} | {r['n']} | {r['protocol']} | `{r['container']}` | {ach} | {ov} |"
                     f" {pen} | {phi} | {r.get('stop', '-')} | {r['cpu']:.2f} | {outcome} |")
    return "\n".join(lines)


def summary(records: list[dict]) -> str:
    """One row per N and protocol: runs, outcomes, the worst overlap and penetration, the largest CPU time."""
    lines = ["| N | protocol | runs (shapes x distributions) | ok | failed, crashed or refused | worst overlap | "
             "worst penetration | stopped by the time budget | largest CPU s |",
             "|---|---|---|---|---|---|---|---|---|"]
    for n in sorted({r["n"] for r in records}):
        for protocol in PROTOCOLS:
            rr = [r for r in records if r["n"] == n and r["protocol"] == protocol]
            if not rr:
                continue
            ov = max((r["worst_overlap"] for r in rr if "worst_overlap" in r), default=float("nan"))
            pen = max((r["worst_penetration"] for r in rr if "worst_penetration" in r), default=float("nan"))
            budget = sum(r.get("stop") == "max_wall_time" for r in rr)
            lines.append(f"| {n} | {protocol} | {len(rr)} | {sum(r['outcome'] == 'ok' for r in rr)} | "
                         f"{sum(r['outcome'] != 'ok' for r in rr)} | {ov:.2e} | {pen:.2e} | {budget} | "
                         f"{max(r['cpu'] for r in rr):.1f} |")
    return "\n".join(lines)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default=str(RECORDS / "stress"), help="folder of the per-run JSON records (resumable)")
    ap.add_argument("--shapes", nargs="+", default=list(SHAPES), choices=list(SHAPES))
    ap.add_argument("--dists", nargs="+", default=list(DISTRIBUTIONS), choices=list(DISTRIBUTIONS))
    ap.add_argument("--n", nargs="+", type=int, default=[20, 500, 5000])
    ap.add_argument("--protocols", nargs="+", default=list(PROTOCOLS), choices=list(PROTOCOLS))
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--max-wall", type=float, default=None, help="wall-time budget of one run (s); its output is "
                    "checked all the same (stop reason max_wall_time)")
    ap.add_argument("--table-only", action="store_true", help="print the table of the records present; run nothing")
    ap.add_argument("--narrow", action="store_true", help="run the NARROW containers instead of the matrix")
    args = ap.parse_args(argv)
    if args.narrow:
        return 1 if narrow() else 0
    store = Records(args.out)
    done = []
    for n in args.n:
        for shape in args.shapes:
            for dist in args.dists:
                for protocol in args.protocols:
                    k = key(shape, dist, n, protocol, args.seed)
                    rec = store.get(k)
                    if rec is None and not args.table_only:
                        rec = run_case(shape, dist, n, protocol, args.seed, args.max_wall)
                        store.put(k, rec)
                        print(f"{k}: {rec['outcome']} overlap={rec.get('worst_overlap', float('nan')):.2e} "
                              f"penetration={rec.get('worst_penetration', float('nan')):.2e} "
                              f"phi={rec.get('phi', float('nan')):.4f} stop={rec.get('stop')} cpu={rec['cpu']:.1f}s "
                              f"{rec.get('reason', '')}", flush=True)
                    if rec is not None:
                        done.append(rec)
    print(table(done))
    print("\n" + summary(done))
    bad = [r for r in done if r["outcome"] in ("FAIL", "error")]
    ok = [r for r in done if r["outcome"] == "ok"]
    worst_ov = max((r["worst_overlap"] for r in done if "worst_overlap" in r), default=float("nan"))
    worst_pen = max((r["worst_penetration"] for r in done if "worst_penetration" in r), default=float("nan"))
    print(f"\n{len(done)} runs: {len(ok)} ok, {len(bad)} failed or crashed, "
          f"{sum(r['outcome'] == 'refused' for r in done)} refused up front; worst overlap {worst_ov:.2e}, "
          f"worst penetration {worst_pen:.2e} (limit {LIMIT:g})")
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
