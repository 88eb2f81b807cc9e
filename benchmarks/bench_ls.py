"""LS engine speed: collisions per second on one core, and the spheropack peer on a comparable case.

Cases (issue 3): LS at gamma = 1e-2 to p = 1e12 from a fixed start (Poisson, seed 12345, compressed by LS at
gamma = 1 to phi = 0.58; not timed), N = 1e3, 1e4 (and 1e5 with ``--sizes 1000 10000 100000``), sigma = 0 and 0.3.
Reference points on this machine class: the paper's C++ code 0.20-0.28 M collisions/s; target >= 1.0 M/s at N = 1e4.

Peer: ``spheropack.pack`` (pip install spheropack) from a Poisson start to reduced pressure 1e12 at the same growth
rate (its Gamma = d<d>/dt / sqrt(kT/m) = gamma / sqrt(0.2)), against our LS from a Poisson start with the same
gamma; both print collisions per second and the ratio (target >= 2.5).

Also the cold-start time of a new process (import + cached numba code + a tiny run; target <= 2 s).

    python benchmarks/bench_ls.py                    # N = 1e3, 1e4; peer at N = 1e4
    python benchmarks/bench_ls.py --sizes 100000 --no-peer
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import time

from spherejam.core.seeding import poisson_packing
from spherejam.engines.lubachevsky_stillinger import run_ls

RATE = 1e-2


def start_packing(n: int, sigma: float):
    return run_ls(poisson_packing(n, sigma, seed=12345), 1.0, seed=7, target_phi=0.58, progress_interval=1e9).packing


def bench_case(n: int, sigma: float, rate: float = RATE) -> dict:
    start = start_packing(n, sigma)
    t0 = time.perf_counter()
    cpu0 = time.process_time()
    r = run_ls(start, rate, seed=3, progress_interval=1e9)
    wall = time.perf_counter() - t0
    cpu = time.process_time() - cpu0
    c = r.stats.as_dict()
    return {"n": n, "sigma": sigma, "phi": r.packing.phi, "collisions": c["collisions"], "events": c["events"],
            "wall": wall, "cpu": cpu, "rate": c["collisions"] / wall}


def cold_start() -> float:
    code = ("import time; t=time.perf_counter(); from spherejam.core.seeding import poisson_packing; "
            "from spherejam.engines.lubachevsky_stillinger import run_ls; "
            "run_ls(poisson_packing(200, 0.0, seed=1), 0.1, max_collisions=1, progress_interval=1e9); "
            "print(time.perf_counter()-t)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    return float(out.stdout.strip().splitlines()[-1])


def peer(n: int, rate: float) -> None:
    try:
        import spheropack
        from spheropack import stop
    except ImportError:
        print("peer: spheropack not installed (pip install spheropack); skipped")
        return
    gamma_dimless = rate / 0.2**0.5
    spheropack.pack(200, density="max", growth_rate=gamma_dimless, stop=[stop.Pressure(1e12)], seed=1)  # warm-up
    t0, c0 = time.perf_counter(), time.process_time()
    sp = spheropack.pack(n, density="max", growth_rate=gamma_dimless, stop=[stop.Pressure(1e12)], seed=1)
    sp_wall, sp_cpu = time.perf_counter() - t0, time.process_time() - c0
    sp_coll = float(sp.history["n_collisions"][-1])
    sp_phi = float(sp.history["density"][-1])
    t0, c0 = time.perf_counter(), time.process_time()
    ours = run_ls(poisson_packing(n, 0.0, seed=1), rate, seed=1, progress_interval=1e9)
    wall, cpu = time.perf_counter() - t0, time.process_time() - c0
    coll = ours.stats.collisions
    print(f"peer  N={n} Poisson -> p=1e12, gamma={rate:g} (spheropack Gamma={gamma_dimless:.4g}):")
    print(f"  spheropack: phi={sp_phi:.5f} collisions={sp_coll:,.0f} wall={sp_wall:.1f}s cpu={sp_cpu:.1f}s "
          f"-> {sp_coll / sp_wall:,.0f}/s wall, {sp_coll / sp_cpu:,.0f}/s cpu")
    print(f"  spherejam:  phi={ours.packing.phi:.5f} collisions={coll:,} wall={wall:.1f}s cpu={cpu:.1f}s "
          f"-> {coll / wall:,.0f}/s wall, {coll / cpu:,.0f}/s cpu")
    mine, theirs = coll / cpu, sp_coll / sp_cpu
    print(f"  ratio spherejam/spheropack (collisions per cpu second) = {mine / theirs:.2f} (target >= 2.5); "
          f"wall-clock ratio {coll / wall / (sp_coll / sp_wall):.2f}")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", type=int, nargs="*", default=[1000, 10000])
    ap.add_argument("--sigmas", type=float, nargs="*", default=[0.0, 0.3])
    ap.add_argument("--no-peer", action="store_true")
    ap.add_argument("--peer-n", type=int, default=10000)
    args = ap.parse_args()
    print(f"cold start (new process, cached numba, tiny run): {cold_start():.2f} s (target <= 2 s)", flush=True)
    for n in args.sizes:
        for sigma in args.sigmas:
            b = bench_case(n, sigma)
            print(f"LS  N={b['n']:>6} sigma={b['sigma']:.1f} gamma={RATE:g}: phi={b['phi']:.5f} "
                  f"collisions={b['collisions']:>12,} wall={b['wall']:7.1f}s cpu={b['cpu']:7.1f}s "
                  f"-> {b['rate'] / 1e6:.3f} M collisions/s wall, {b['collisions'] / b['cpu'] / 1e6:.3f} M/s cpu",
                  flush=True)
    if not args.no_peer:
        peer(args.peer_n, RATE)


if __name__ == "__main__":
    main()
