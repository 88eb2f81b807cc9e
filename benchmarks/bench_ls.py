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
    python benchmarks/bench_ls.py wide [--baseline-src ...] [--out W.jsonl] [--rounds R]   # N = 1e4: issue 47's table
    python benchmarks/bench_ls.py scale --sizes 100000 1000000 --max-wall 900   # sigma 0.3, gamma = 1

Issue 47 (where the time goes at wide size ratios; docs/algorithms.md §7.5), the counts of each distribution:

    python benchmarks/bench_ls.py counts --n 10000 --repeats 0 --jobs 6 --out n10000.jsonl
    python benchmarks/bench_ls.py counts --n 1000 --extra --repeats 3 --jobs 3 --out n1000.jsonl
    python benchmarks/bench_ls.py counts-table n10000.jsonl        # the Markdown table of the docs

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

from numba import njit

from spherejam.core.seeding import poisson_packing
from spherejam.engines.kernels import event_driven as ed
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

#: Wide distributions of the issues: name -> (kind, parameter); kind "psd" takes any size-distribution spec.
WIDE = {"mono": ("sigma", 0.0), "bi1.4": ("bi", 1.4), "bi3": ("bi", 3.0), "bi10": ("bi", 10.0),
        "lognormal0.5": ("sigma", 0.5)}
#: The distributions of ``counts`` (issue 47): the bidisperse ratios, then the continuous wide ones.
COUNTED = {"mono": ("sigma", 0.0), "bi3": ("bi", 3.0), "bi5": ("bi", 5.0), "bi10": ("bi", 10.0),
           "lognormal0.5": ("sigma", 0.5), "powerlaw-3r20": ("psd", "powerlaw:exponent=-3,ratio=20")}
#: Further rows measured by ``counts --extra`` for the cost model's fit (issue 47).
EXTRA = {"lognormal0.3": ("sigma", 0.3), "bi1.4": ("bi", 1.4), "bi2": ("bi", 2.0), "bi4": ("bi", 4.0),
         "gauss0.2": ("psd", "gaussian:delta=0.2"), "uniform2": ("psd", "uniform:ratio=2"),
         "powerlaw-3r5": ("psd", "powerlaw:exponent=-3,ratio=5")}
#: The distributions of the PSD acceptance table (docs/psd.md §8, benchmarks/records/psd_acceptance_cpu.csv), drawn
#: from their own specs, for the cost model's refit (``benchmarks/cost_fit.py measure``; docs/algorithms.md §7.9).
PSD_TABLE = {"psd-bi1.4n": ("psd", "bidisperse:ratio=1.4,small=0.5,by=number"),
             "psd-bi2": ("psd", "bidisperse:ratio=2,small=0.3,by=volume"),
             "psd-bi4": ("psd", "bidisperse:ratio=4,small=0.3,by=volume"),
             "gauss0.1": ("psd", "gaussian:delta=0.1"), "powder": ("psd", "table:examples/powder.csv")}
DISTRIBUTIONS = {**WIDE, **COUNTED, **EXTRA, **PSD_TABLE}


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


def wide_start(n: int, dist: str, prepare: bool = True):
    """The start of a ``case``: Poisson with the distribution's sizes, compressed by LS at gamma = 1 to phi = 0.58
    unless ``prepare`` is false."""
    kind, value = DISTRIBUTIONS[dist] if dist in DISTRIBUTIONS else ("sigma", float(dist.removeprefix("sigma")))
    if kind == "sigma":
        start = poisson_packing(n, value, seed=12345)
    elif kind == "psd":
        start = poisson_packing(n, psd=value, seed=12345)
    else:
        start = bidisperse_start(n, value)
    if prepare:
        start = run_ls(start, 1.0, seed=7, target_phi=0.58, progress_interval=1e9).packing
    return start


def case(n: int, dist: str, rate: float, prepare: bool, max_wall: float | None) -> dict:
    """One timed LS run (in this process); returns its figures and this process's peak memory."""
    start = wide_start(n, dist, prepare)
    t0, cpu0 = time.perf_counter(), time.process_time()
    r = run_ls(start, rate, seed=3, progress_interval=1e9, max_wall_time=max_wall)
    wall, cpu = time.perf_counter() - t0, time.process_time() - cpu0
    c = r.stats.as_dict()
    return {"n": n, "dist": dist, "rate": rate, "phi": r.packing.phi, "stop": c["stop_reason"],
            "collisions": c["collisions"], "wall": wall, "cpu": cpu, "per_s": c["collisions"] / cpu,
            "pressure": r.packing.metadata["reduced_pressure"], "d_ratio": float(start.diameters.max() /
                                                                                 start.diameters.min()),
            "peak_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0}


def _own_session() -> None:
    """In a child before exec: a session (scheduler autogroup) of its own, at the lowest priority, so that parallel
    cases share the machine as separate low-priority jobs."""
    os.setsid()
    try:
        with open("/proc/self/autogroup", "w") as fh:
            fh.write("19")
    except OSError:
        os.nice(19)


def run_case(src: str | None, n: int, dist: str, rate: float, prepare: bool = True,
             max_wall: float | None = None, isolated: bool = False) -> dict:
    """:func:`case` in a fresh process importing spherejam from ``src`` (None: this environment's); ``isolated``:
    in a low-priority session of its own (:func:`_own_session`)."""
    env = dict(os.environ)
    if src is not None:
        env["PYTHONPATH"] = src
    args = [sys.executable, __file__, "case", "--n", str(n), "--dist", dist, "--rate", repr(rate)]
    if not prepare:
        args.append("--no-prepare")
    if max_wall is not None:
        args += ["--max-wall", repr(max_wall)]
    out = subprocess.run(args, capture_output=True, text=True, env=env, check=True,
                         preexec_fn=_own_session if isolated else None)
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


#: The rows of issue 47's table (``wide``): monodisperse first (the baseline of every ratio).
WIDE_TABLE = ("mono", "sigma0.3", "bi3", "bi5", "bi10", "lognormal0.5", "powerlaw-3r20")


def wide(baseline: str | None, n: int, out: str | None = None, before=WIDE_TABLE, rows=WIDE_TABLE,
         rounds: int = 1) -> None:
    """Issue 47's table (the distributions ``rows``, monodisperse first): each with the baseline's package
    (``before``, if given; only the distributions ``before``) and this one (``after``), alternately, each run in a
    fresh process; every rate against the monodisperse rate of the same tree and round. ``rounds`` > 1 repeats the
    whole table, so that a drift of the machine's load hits every row alike, and ends with each row's median ratio.
    ``out``: each run as a JSON line (``benchmarks/cost_fit.py`` reads the ``after`` ones)."""
    sources = [("after", str(__import__("pathlib").Path(__file__).resolve().parents[1] / "src"))]
    if baseline:
        sources.insert(0, ("before", baseline))
    ratios: dict[tuple[str, str], list[float]] = {}
    print(f"load average at start: {os.getloadavg()}", flush=True)
    for _ in range(rounds):
        mono: dict[str, dict] = {}
        for dist in dict.fromkeys(("mono",) + tuple(rows)):
            for label, src in sources:
                if label == "before" and dist not in before and dist != "mono":
                    continue
                b = run_case(src, n, dist, RATE)
                mono.setdefault(label, b)
                m = mono[label]
                ratios.setdefault((label, dist), []).append(b["per_s"] / m["per_s"])
                print(_line(label, b) + f"  d_max/d_min={b['d_ratio']:.1f}  rate/mono={b['per_s'] / m['per_s']:.3f}",
                      flush=True)
                if out:
                    with open(out, "a") as fh:
                        fh.write(json.dumps({"tree": label, "src": src, "timed": b, "mono_per_s": m["per_s"],
                                             "mono_collisions": m["collisions"]}) + "\n")
    print(f"load average at end: {os.getloadavg()}", flush=True)
    if rounds > 1:
        print("| tree | distribution | rate/mono, each round | median |\n|---|---|---|---|")
        for (label, dist), r in ratios.items():
            print(f"| {label} | {dist} | {', '.join(f'{x:.3f}' for x in r)} | {float(np.median(r)):.3f} |")


# --- issue 47: where the time goes at wide ratios (counts) ----------------------------------------------------
# The kernel counts events by kind only; the per-collision pair tests and scans are estimated from the engine state
# sampled at every kernel call (count_figures). A per-event counting copy of the event loop (f7b5aa5) measured the
# exact figures of docs/algorithms.md §7.5 once; it was removed when it had drifted from the kernel.

#: Columns of the per-class counter array (rows: size classes, octaves of D / D_min).
K_COLL, K_NULL, K_PRED_COLL, K_TESTS_COLL, K_PRED_MOVE, K_TESTS_MOVE, K_PRED_SKIN, K_TESTS_SKIN, K_SCAN_SKIN, \
    K_EDIT_SKIN, K_PRED_INIT, K_TESTS_INIT, K_LIST_SUM, K_LIST_SAMPLES = range(14)
N_K = 14
N_CLASSES = 8


@njit(cache=True, inline="always")
def _size_class(d, dmin):
    return min(int(np.floor(np.log2(d / dmin * (1.0 + 1e-9)))), N_CLASSES - 1)


@njit(cache=True)
def _class_of_rows(st, dmin):
    out = np.empty(st.shape[0], dtype=np.int64)
    for i in range(st.shape[0]):
        out[i] = _size_class(st[i, 7], dmin)
    return out


def _cells_per_side(s) -> int:
    """Cells per side of a single-level cubic grid, else -1 (levels or a non-cubic frame: no 3x3x3 stencil
    estimate)."""
    ms = s.lvl_ms
    return int(ms[0, 0]) if len(ms) == 1 and (ms[0] == ms[0, 0]).all() else -1


def _stencil_occupancy(cellof: np.ndarray, m: int) -> np.ndarray:
    """Spheres in the 3x3x3 cell stencil of each sphere's cell (all N when m < 3: one cell; NaN when m < 0: a
    levelled or non-cubic grid): what a skin event of that sphere scans."""
    n = len(cellof)
    if m < 0:
        return np.full(n, np.nan)
    if m < 3:
        return np.full(n, n)
    grid = np.bincount(cellof, minlength=m**3).reshape(m, m, m)  # index x + m y + m^2 z -> [z, y, x]
    total = np.zeros_like(grid)
    for dz in (-1, 0, 1):
        for dy in (-1, 0, 1):
            for dx in (-1, 0, 1):
                total += np.roll(grid, (dz, dy, dx), axis=(0, 1, 2))
    return total.reshape(-1)[cellof]


def count_case(n: int, dist: str, rate: float = RATE) -> dict:
    """The LS run of :func:`case` (same start, seed and rate) with its engine state sampled at every kernel call:
    list lengths by size class (octaves of D / D_min), cells per side, stencil occupancy, and the kernel's event
    counters of each call; pair tests and scans are estimated from the samples (see :func:`count_figures`)."""
    start = wide_start(n, dist)
    nominal = start.diameters / start.diameters.mean()
    dmin, dmax = float(nominal.min()), float(nominal.max())
    big = float(np.sqrt(dmin * dmax)) * (1.0 - 1e-9)  # "large": above the geometric middle of the size range
    k = np.zeros((N_CLASSES, N_K), dtype=np.int64)
    grid: dict[int, int] = {}  # cells per side -> kernel calls
    # per kernel call: (collisions, moves, skin events, mean list per class weighted by the estimated collision
    # share, mean list of all spheres, mean stencil occupancy)
    calls: list[tuple[int, int, int, float, float, float]] = []
    d = nominal
    share = len(d) * d**2 + 2.0 * d * d.sum() + np.sum(d**2)  # kinetic estimate: rate_i ~ sum_j (D_i + D_j)^2
    share /= share.sum()
    original_init, original_run = ed.init_events, ed.run_events

    def init_counted(s, t):
        cls = _class_of_rows(s.st, dmin)
        k[:, K_PRED_INIT] += np.bincount(cls, minlength=N_CLASSES)
        k[:, K_TESTS_INIT] += np.bincount(cls, weights=s.nnb, minlength=N_CLASSES).astype(np.int64)
        original_init(s, t)

    def run_events_counted(s, t, target, count_collisions, t_horizon, counters, acc, copies):
        cls = _class_of_rows(s.st, dmin)
        nnb = s.nnb.astype(float)
        k[:, K_LIST_SUM] += np.bincount(cls, weights=nnb, minlength=N_CLASSES).astype(np.int64)
        k[:, K_LIST_SAMPLES] += np.bincount(cls, minlength=N_CLASSES)
        side = _cells_per_side(s)
        grid[side] = grid.get(side, 0) + 1
        before = counters.copy()
        out = original_run(s, t, target, count_collisions, t_horizon, counters, acc, copies)
        delta = counters - before
        sh = share[s.perm]  # rows are renumbered in cell order: row r is input sphere perm[r]
        calls.append((int(delta[ed.C_COLLISIONS]), int(delta[ed.C_MOVES]), int(delta[ed.C_SKIN]),
                      float(np.sum(sh * nnb)), float(nnb.mean()), float(_stencil_occupancy(s.cellof, side).mean())))
        return out

    ed.init_events, ed.run_events = init_counted, run_events_counted
    try:
        cpu0 = time.process_time()
        r = run_ls(start, rate, seed=3, progress_interval=1e9)
        cpu = time.process_time() - cpu0
    finally:
        ed.init_events, ed.run_events = original_init, original_run
    c = r.stats.as_dict()
    counts = np.bincount(_class_of_rows(np.c_[np.zeros((n, 7)), nominal], dmin), minlength=N_CLASSES)
    share_by_class = np.bincount(_class_of_rows(np.c_[np.zeros((n, 7)), nominal], dmin), weights=share,
                                 minlength=N_CLASSES)
    small = nominal[nominal < big]
    pair_sum = 2.0 * len(d) * np.sum(d**2) + 2.0 * d.sum() ** 2  # sum over ordered pairs of (D_i + D_j)^2
    small_sum = 2.0 * len(small) * np.sum(small**2) + 2.0 * small.sum() ** 2
    return {"n": n, "dist": dist, "phi": r.packing.phi, "collisions": c["collisions"],
            "peak_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0,
            "events": c["events"], "stats": {key: v for key, v in c.items() if isinstance(v, (int, float))},
            "cpu_counting": cpu, "d_ratio": dmax / dmin, "large_from": big / dmin,
            "spheres_per_class": counts.tolist(), "share_estimate": share_by_class.tolist(),
            "large_share_estimate": 1.0 - small_sum / pair_sum, "k": k.tolist(),
            "cells_per_side": grid, "calls": calls}


def _per(a: float, b: float) -> str:
    return f"{a / b:.3g}" if b else "not estimable (n = 0)"


def count_figures(c: dict) -> dict:
    """Per collision: pair tests by cause, re-predictions by cause, spheres scanned by skin events, and the share of
    collisions with a large sphere. The re-predictions are the kernel's counters (exact); the pair tests and scans
    are estimated from the state sampled at each kernel call: a collision re-predicts both partners, weighted by
    the kinetic estimate of each sphere's collision share (rate_i ~ sum_j (D_i + D_j)^2, equal masses), a lost
    partner likewise, a skin exit any sphere alike."""
    k = np.array(c["k"], dtype=float)
    tot = k.sum(axis=0)
    coll = c["collisions"]
    calls = np.array(c["calls"], dtype=float).reshape(-1, 6)
    ccoll, cmove, cskin, wlist, mlist, occ = calls.T
    f = {"collisions": coll, "moves": cmove.sum() / coll, "skin": cskin.sum() / coll,
         "tests_init": tot[K_TESTS_INIT] / coll}
    f.update(tests_coll=2 * np.sum(ccoll * wlist) / coll, tests_move=np.sum(cmove * wlist) / coll,
             tests_skin=np.sum(cskin * mlist) / coll, scan_per_skin=np.sum(cskin * occ) / max(cskin.sum(), 1),
             edits_per_skin=float("nan"), large=c["large_share_estimate"], coll_share=c["share_estimate"])
    if c["d_ratio"] < 1.0 + 1e-9:
        f["large"] = float("nan")  # equal spheres: no large ones
    f["tests"] = f["tests_coll"] + f["tests_move"] + f["tests_skin"] + f["tests_init"]
    f["scan_per_coll"] = f["scan_per_skin"] * f["skin"]
    f["lists"] = [row[K_LIST_SUM] / row[K_LIST_SAMPLES] if row[K_LIST_SAMPLES] else float("nan") for row in k]
    return f


def print_counts(t: dict, c: dict, mono_rate: float, mono_cpp: float) -> None:
    """The figures of one distribution: speed against mono, then the counts per collision."""
    f = count_figures(c)
    how = "estimated"
    cpp = t["collisions"] / t["n"]
    print(f"{c['dist']}: d_max/d_min={c['d_ratio']:.1f} phi={t['phi']:.5f} collisions={t['collisions']:,} "
          f"({cpp:.0f} per sphere, {cpp / mono_cpp:.2f} of mono) cpu={t['cpu']:.1f}s "
          f"{t['per_s'] / 1e6:.3f} M/cpu-s rate/mono={t['per_s'] / mono_rate:.3f} "
          f"time/mono={mono_rate / t['per_s'] * cpp / mono_cpp:.2f} peak={t['peak_mb']:.0f} MB; "
          f"same events in the sampled run: {t['phi'] == c['phi'] and t['collisions'] == c['collisions']}")
    print(f"  re-predictions per collision (counted): own collision 2, lost partner {f['moves']:.3f}, skin exit "
          f"{f['skin']:.4f}; cells per side (kernel calls): {c['cells_per_side']}")
    print(f"  pair tests per collision ({how}): {f['tests']:.1f} = own collision {f['tests_coll']:.1f} + lost "
          f"partner {f['tests_move']:.1f} + skin {f['tests_skin']:.2f} + window starts {f['tests_init']:.2f} "
          f"(counted); skin events scan {f['scan_per_skin']:.0f} spheres each ({f['scan_per_coll']:.1f} per "
          f"collision); collisions with a large sphere (D >= {c['large_from']:.2f} D_min): {f['large']:.3f}")
    for q in range(N_CLASSES):
        nq = c["spheres_per_class"][q]
        if nq:
            print(f"  class D/D_min in [{2**q}, {2**(q + 1)}){'+' if q == N_CLASSES - 1 else ''}: {nq} spheres, "
                  f"mean list {f['lists'][q]:.1f} (counted), share of collision partners {f['coll_share'][q]:.3f} "
                  f"({how})", flush=True)


def counts_table(path: str) -> None:
    """The Markdown table of docs/algorithms.md §7.5 from the JSON lines of ``counts --out``."""
    print("| distribution | d_max/d_min | cells per side | rate / mono | collisions per sphere / mono | time / mono | "
          "peak MB | lost-partner re-predictions per collision | skin exits per collision | spheres scanned per "
          "skin exit | pair tests per collision: own, lost partner, skin, window starts, total (est.) | mean list "
          "small / large | collisions with a large sphere (est.) |")
    print("|" + "---|" * 13)
    for line in open(path).read().splitlines():
        r = json.loads(line)
        t, c = r["timed"], r["counted"]
        f = count_figures(c)
        n = t["n"]
        cpp = t["collisions"] / n / (r["mono_collisions"] / n)
        rate = t["per_s"] / r["mono_per_s"]
        lists = [x for x, q in zip(f["lists"], c["spheres_per_class"]) if q]
        grid = "/".join(sorted(c["cells_per_side"], key=int, reverse=True))
        large = "–" if f["large"] != f["large"] else f"{f['large']:.2f}"
        print(f"| {c['dist']} | {c['d_ratio']:.1f} | {grid} | {rate:.3f} | {cpp:.2f} | {cpp / rate:.2f} | "
              f"{t['peak_mb']:.0f} | {f['moves']:.3f} | {f['skin']:.4f} | {f['scan_per_skin']:.0f} | "
              f"{f['tests_coll']:.1f}, {f['tests_move']:.1f}, {f['tests_skin']:.2f}, {f['tests_init']:.2f}, "
              f"{f['tests']:.1f} | {lists[0]:.1f} / {lists[-1]:.1f} | {large} |")


def run_count_case(n: int, dist: str) -> dict:
    out = subprocess.run([sys.executable, __file__, "count-case", "--n", str(n), "--dist", dist],
                         capture_output=True, text=True, check=True, preexec_fn=_own_session)
    return json.loads(out.stdout.strip().splitlines()[-1])


def counts(n: int, dists, repeats: int, out: str | None, jobs: int) -> None:
    """Issue 47: per distribution, the timed run (``repeats`` times, each in a fresh process) and the counting run,
    ``jobs`` processes at a time (each in a low-priority session of its own); the rate is the best of the timed runs
    and the sampled one, against the first distribution's of this invocation; all figures as
    JSON lines to ``out``."""
    from concurrent.futures import ThreadPoolExecutor

    print(f"load average at start: {os.getloadavg()}", flush=True)
    with ThreadPoolExecutor(jobs) as pool:
        # repeats interleaved over the distributions, so that drifts of the machine's load hit them alike
        timed = [(dist, pool.submit(run_case, None, n, dist, RATE, isolated=True))
                 for _ in range(repeats) for dist in dists]
        counted = {dist: pool.submit(run_count_case, n, dist) for dist in dists}
        best: dict[str, dict] = {}
        for dist, f in timed:
            b = f.result()
            print(_line("run", b), flush=True)
            if dist not in best or b["per_s"] > best[dist]["per_s"]:
                best[dist] = b
        counted = {dist: f.result() for dist, f in counted.items()}
        for dist, c in counted.items():
            # the sampled run is the same LS run (a few numpy reductions per kernel call): a further repeat
            if dist not in best or c["collisions"] / c["cpu_counting"] > best[dist]["per_s"]:
                best[dist] = {"n": n, "dist": dist, "rate": RATE, "phi": c["phi"], "stop": c["stats"]["stop_reason"]
                              if "stop_reason" in c["stats"] else "", "collisions": c["collisions"],
                              "wall": float("nan"), "cpu": c["cpu_counting"],
                              "per_s": c["collisions"] / c["cpu_counting"], "d_ratio": c["d_ratio"],
                              "peak_mb": c["peak_mb"], "from_sampled_run": True}
        mono = best[dists[0]]
        for dist in dists:
            c = counted[dist]
            print_counts(best[dist], c, mono["per_s"], mono["collisions"] / mono["n"])
            if out:
                with open(out, "a") as fh:
                    fh.write(json.dumps({"timed": best[dist], "counted": c, "mono_per_s": mono["per_s"],
                                         "mono_collisions": mono["collisions"], "repeats": repeats,
                                         "jobs": jobs}) + "\n")
    print(f"load average at end: {os.getloadavg()}", flush=True)


def scale(sizes, max_wall: float) -> None:
    for n in sizes:
        b = run_case(None, n, "sigma0.3", 1.0, prepare=False, max_wall=max_wall)
        print(_line("scale", b) + f"  p={b['pressure']:.3g} (gamma = 1 from Poisson; budget {max_wall:g} s)",
              flush=True)


def main() -> None:
    if len(sys.argv) == 3 and sys.argv[1] == "counts-table":
        counts_table(sys.argv[2])
        return
    if len(sys.argv) > 1 and sys.argv[1] in ("case", "count-case", "counts", "before-after", "wide", "scale"):
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
        ap.add_argument("--dists", nargs="*", default=None, help="counts: distributions (first = the baseline)")
        ap.add_argument("--extra", action="store_true", help="counts: also the cost model's further rows")
        ap.add_argument("--out", default=None, help="counts: append each distribution's figures as JSON here")
        ap.add_argument("--jobs", type=int, default=1, help="counts: cases run at once")
        ap.add_argument("--rounds", type=int, default=1, help="wide: the whole table this many times, interleaved")
        a = ap.parse_args()
        if a.mode == "case":
            print(json.dumps(case(a.n, a.dist, a.rate, not a.no_prepare, a.max_wall)))
        elif a.mode == "count-case":
            print(json.dumps(count_case(a.n, a.dist, a.rate)))
        elif a.mode == "counts":
            dists = a.dists or list(COUNTED) + (list(EXTRA) if a.extra else [])
            counts(a.n, dists, a.repeats, a.out, a.jobs)
        elif a.mode == "before-after":
            before_after(a.baseline_src, a.sizes or [1000, 10000], a.sigmas, a.repeats)
        elif a.mode == "wide":
            wide(a.baseline_src, a.n, a.out, a.dists or WIDE_TABLE, a.dists or WIDE_TABLE, a.rounds)
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
