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

Issue 35 (any box, any size ratio), each case in a fresh process (so its peak memory is its own):

    python benchmarks/bench_ls.py before-after --baseline-src /work/main/src   # N = 1e3, 1e4, sigma 0, 0.3
    python benchmarks/bench_ls.py wide [--baseline-src ...]   # N = 1e4: mono, 1:1.4, 1:3, 1:10, log-normal 0.5
    python benchmarks/bench_ls.py scale --sizes 100000 1000000 --max-wall 900   # sigma 0.3, gamma = 1

``before-after`` runs each case alternately with the baseline's package and this one (``--repeats`` times) and prints
the ratio of collisions per CPU second (each process's own CPU time: the machine is shared); ``wide`` prints each
distribution's rate against the monodisperse one of the same run, the time to jam and the peak memory. Bidisperse
mixtures have 30 % of the sphere volume in the small spheres; starts are Poisson, compressed by LS at gamma = 1 to
phi = 0.58 (not timed), then LS at gamma = 1e-2 to p = 1e12 (timed).
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import subprocess
import sys
import time

import numpy as np

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


# --- issue 35: before/after, wide size distributions, scale -----------------------------------------------------

#: Wide distributions of the issue: name -> (kind, parameter).
WIDE = {"mono": ("sigma", 0.0), "bi1.4": ("bi", 1.4), "bi3": ("bi", 3.0), "bi10": ("bi", 10.0),
        "lognormal0.5": ("sigma", 0.5)}


def bidisperse_start(n: int, ratio: float, small_volume: float = 0.3, seed: int = 12345):
    """Poisson centres, two sizes 1 : ratio with ``small_volume`` of the sphere volume in the small ones, closest pair
    touching."""
    from spherejam.core.packing import Packing

    per_large = (1.0 - small_volume) / small_volume / ratio**3  # large spheres per small one
    n_large = max(1, round(n * per_large / (1.0 + per_large)))
    d = np.ones(n)
    d[:n_large] = ratio
    rng = np.random.default_rng(seed)
    box = (np.sum(np.pi / 6 * d**3) / 0.3) ** (1.0 / 3.0)
    return Packing(rng.random((n, 3)) * box, d * 1e-3, box).scaled_to_contact()


def case(n: int, dist: str, rate: float, prepare: bool, max_wall: float | None) -> dict:
    """One timed LS run (in this process); returns its figures and this process's peak memory."""
    kind, value = WIDE[dist] if dist in WIDE else ("sigma", float(dist.removeprefix("sigma")))
    start = poisson_packing(n, value, seed=12345) if kind == "sigma" else bidisperse_start(n, value)
    if prepare:
        start = run_ls(start, 1.0, seed=7, target_phi=0.58, progress_interval=1e9).packing
    t0, cpu0 = time.perf_counter(), time.process_time()
    r = run_ls(start, rate, seed=3, progress_interval=1e9, max_wall_time=max_wall)
    wall, cpu = time.perf_counter() - t0, time.process_time() - cpu0
    c = r.stats.as_dict()
    return {"n": n, "dist": dist, "rate": rate, "phi": r.packing.phi, "stop": c["stop_reason"],
            "collisions": c["collisions"], "wall": wall, "cpu": cpu, "per_s": c["collisions"] / cpu,
            "pressure": r.packing.metadata["reduced_pressure"], "d_ratio": float(start.diameters.max() /
                                                                                 start.diameters.min()),
            "peak_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0}


def run_case(src: str | None, n: int, dist: str, rate: float, prepare: bool = True,
             max_wall: float | None = None) -> dict:
    """:func:`case` in a fresh process importing spherejam from ``src`` (None: this environment's)."""
    env = dict(os.environ)
    if src is not None:
        env["PYTHONPATH"] = src
    args = [sys.executable, __file__, "case", "--n", str(n), "--dist", dist, "--rate", repr(rate)]
    if not prepare:
        args.append("--no-prepare")
    if max_wall is not None:
        args += ["--max-wall", repr(max_wall)]
    out = subprocess.run(args, capture_output=True, text=True, env=env, check=True)
    return json.loads(out.stdout.strip().splitlines()[-1])


def _line(label: str, b: dict) -> str:
    return (f"{label:8s} N={b['n']:>7} {b['dist']:>12s} phi={b['phi']:.5f} stop={b['stop']:<13s} "
            f"collisions={b['collisions']:>13,} wall={b['wall']:7.1f}s cpu={b['cpu']:7.1f}s "
            f"{b['per_s'] / 1e6:6.3f} M/cpu-s "
            f"peak={b['peak_mb']:7.0f} MB")


def before_after(baseline: str, sizes, sigmas, repeats: int) -> None:
    here = str(__import__("pathlib").Path(__file__).resolve().parents[1] / "src")
    for n in sizes:
        for sigma in sigmas:
            old, new = [], []
            for _ in range(repeats):  # alternate, so that drifts of the machine's load hit both alike
                old.append(run_case(baseline, n, f"sigma{sigma}", RATE))
                new.append(run_case(here, n, f"sigma{sigma}", RATE))
            print(_line("before", max(old, key=lambda b: b["per_s"])))
            print(_line("after", max(new, key=lambda b: b["per_s"])))
            same = all(a["phi"] == b["phi"] and a["collisions"] == b["collisions"] for a, b in zip(old, new))
            ratio = max(b["per_s"] for b in new) / max(b["per_s"] for b in old)
            print(f"  ratio after/before (best of {repeats}) = {ratio:.3f}; identical phi and collisions: {same}",
                  flush=True)


def wide(baseline: str | None, n: int) -> None:
    sources = [("after", str(__import__("pathlib").Path(__file__).resolve().parents[1] / "src"))]
    if baseline:
        sources.insert(0, ("before", baseline))
    for label, src in sources:
        mono = None
        for dist in WIDE:
            b = run_case(src, n, dist, RATE)
            mono = mono or b["per_s"]
            print(_line(label, b) + f"  d_max/d_min={b['d_ratio']:.1f}  rate/mono={b['per_s'] / mono:.2f}",
                  flush=True)


def scale(sizes, max_wall: float) -> None:
    for n in sizes:
        b = run_case(None, n, "sigma0.3", 1.0, prepare=False, max_wall=max_wall)
        print(_line("scale", b) + f"  p={b['pressure']:.3g} (gamma = 1 from Poisson; budget {max_wall:g} s)",
              flush=True)


def main() -> None:
    if len(sys.argv) > 1 and sys.argv[1] in ("case", "before-after", "wide", "scale"):
        ap = argparse.ArgumentParser(description="issue 35 modes (see the module docstring)")
        ap.add_argument("mode")
        ap.add_argument("--n", type=int, default=10000)
        ap.add_argument("--dist", default="mono")
        ap.add_argument("--rate", type=float, default=RATE)
        ap.add_argument("--no-prepare", action="store_true")
        ap.add_argument("--max-wall", type=float, default=None)
        ap.add_argument("--baseline-src")
        ap.add_argument("--sizes", type=int, nargs="*", default=None)
        ap.add_argument("--sigmas", type=float, nargs="*", default=[0.0, 0.3])
        ap.add_argument("--repeats", type=int, default=2)
        a = ap.parse_args()
        if a.mode == "case":
            print(json.dumps(case(a.n, a.dist, a.rate, not a.no_prepare, a.max_wall)))
        elif a.mode == "before-after":
            before_after(a.baseline_src, a.sizes or [1000, 10000], a.sigmas, a.repeats)
        elif a.mode == "wide":
            wide(a.baseline_src, a.n)
        else:
            scale(a.sizes or [100000, 1000000], a.max_wall or 900.0)
        return
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
