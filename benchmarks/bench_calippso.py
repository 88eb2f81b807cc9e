"""CALiPPSO speed and certification figures: the new LP path and the old one side by side on the same input.

    python benchmarks/bench_calippso.py                 # N = 1024, d = 3 from an LS + MLS packing at p = 1e5
    python benchmarks/bench_calippso.py --n 2048 --start-kind ls --pressure 1e12 --rate 1e-3   # jammed LS start
    python benchmarks/bench_calippso.py --start s.h5 --paths hipo      # one path on a saved start (large N)
    python benchmarks/bench_calippso.py --start s.h5 --paths hipo hipo:2   # HiPO on 1 and on 2 threads
    python benchmarks/bench_calippso.py --dat FILE.dat  # a CALiPPSO.jl example input (d, N, sigma, then centres; L=1)
    python benchmarks/bench_calippso.py --mls           # certify MLS outputs: |delta phi| <= 1e-4 and isostatic
    python benchmarks/bench_calippso.py --save-start s.h5   # keep the start; --start s.h5 reruns on it
    python benchmarks/bench_calippso.py --start s.h5 --fallback   # the uncertified-vertex fallback, old and new
    python benchmarks/bench_calippso.py --start mls1250.h5 --tile 2 --paths hipo ipx+crossover@1
                                        # N = 10^4 from an N = 1250 MLS output; the old path for its first LP only

A path is ``solver[:threads][+crossover][@max_lps]``: ``ipx+crossover`` is the old path (IPX interior point, HiGHS
crossover), ``hipo`` the new path (HiPO interior point, its vertex certified by the active-set solve, crossover only
as the fallback; ``solver="auto"`` takes it from N = 4096 on). The first path listed is the reference: every other path
must give the same contact network, the same rattlers and force balance <= 1e-10 (printed as "agree"). Times are
CPU seconds of this process (the machine is shared: wall time is printed too but is no figure), per LP and in total.
``@max_lps`` stops a path after that many LPs, for an old path too slow to run to the end (its per-LP times are then
compared with the same LPs of the other paths, not its total).

``--tile K`` replicates the start K x K x K times in a box K times as large: a packing jammed at pressure p stays
jammed at p, with K^3 N spheres. Its LPs have the size, sparsity and contact statistics of an N = K^3 N packing's (a
jammed MLS output of N = 10^4 or 16384 costs hours to make); their contact network repeats with period L, which an
independent packing's does not.

The default start is made by spherejam's Lubachevsky-Stillinger engine (d = 3): LS at ``--rate`` to reduced
pressure ``--pressure`` (1e5), then the MLS loop with p_max = ``--pressure`` (rates 1e-2 -> 1e-4), so that the
pressure is the packing's own and not a fast compression's (``--start-kind ls`` skips the MLS part; with
``--pressure 1e12`` that is a packing jammed at p = 1e12, the stand-in for an MLS output). The LS ->
CALiPPSO consistency d phi_J / (p (phi_J - phi0)) printed below is ~1 for an MLS start but ~0.1 for a plain fast-LS
start at p = 1e5, whose true pressure is ~10 times lower and which takes 5-8 times more LPs (measured at N = 1024).
For each run it prints the LS time (not part of the target), the LP counts and CPU times per method (HiGHS interior
point + crossover "ipm", certified interior-point vertex "vertex", simplex from the basis of an uncertified vertex
"predicted", warm-started simplex "warm", active set from the previous LP "active-set"), phi, contacts, rattlers,
isostaticity, force balance, and the small-argument exponents of the gap and force distributions. ``--fallback``
times the fallback of an uncertified vertex on the start's first LP, the new path against the old (docs/calippso.md
§5.2).
"""

from __future__ import annotations

import argparse
import logging
import math
import sys
import time

import numpy as np

from spherejam.analysis.distributions import MEAN_FIELD_GAMMA, MEAN_FIELD_THETA_E, distributions
from spherejam.calippso.run import run_calippso
from spherejam.calippso.solution import METHOD_CODES
from spherejam.core.packing import Packing


def read_dat(path: str) -> Packing:
    """A CALiPPSO.jl example file: d, N, diameter, then N lines of centres in the unit box."""
    with open(path) as f:
        lines = [line for line in f.read().split("\n") if line.strip()]
    dim, n, sigma = int(lines[0]), int(lines[1]), float(lines[2])
    x = np.array([[float(v) for v in line.split()] for line in lines[3:3 + n]])
    assert x.shape == (n, dim)
    return Packing(x, np.full(n, sigma), 1.0, {"algorithm": "calippso.jl-example"})


def ls_start(n: int, pressure: float, rate: float, seed: int, kind: str = "mls") -> tuple[Packing, float]:
    from spherejam.core.seeding import poisson_packing
    from spherejam.engines.closest_jamming import find_closest_jamming
    from spherejam.engines.lubachevsky_stillinger import run_ls

    t = time.perf_counter()
    result = run_ls(poisson_packing(n, 0.0, seed, dim=3), rate, p_max=pressure, seed=seed, progress_interval=60.0)
    if kind == "mls":
        result = find_closest_jamming(result.packing, initial_rate=rate, final_rate=1e-4, p_max=pressure, seed=seed,
                                      progress_interval=60.0)
    return result.packing, time.perf_counter() - t


#: Targets (s on one core) of the whole certification, by N.
TARGETS = {1024: 2.0, 10_000: 300.0, 16384: 1800.0}


def parse_path(text: str) -> dict:
    """``solver[:threads][+crossover][@max_lps]`` -> run_calippso keyword arguments."""
    text, _, max_lps = text.partition("@")
    crossover = True if text.endswith("+crossover") else None  # None: run_calippso's pairing for the solver
    solver, _, threads = text.removesuffix("+crossover").partition(":")
    kw = {"solver": solver, "threads": int(threads or 1), "crossover": crossover}
    if max_lps:
        kw["max_iterations"] = int(max_lps)
    return kw


def tiled(packing: Packing, k: int) -> Packing:
    """``packing`` repeated k x k x k times in a box k times as large (same gaps, same pressure, k^d N spheres)."""
    if k == 1:
        return packing
    shifts = np.stack(np.meshgrid(*[np.arange(k)] * packing.dim, indexing="ij"), -1).reshape(-1, packing.dim)
    x = (packing.positions[None, :, :] + packing.box * shifts[:, None, :]).reshape(-1, packing.dim)
    metadata = {**packing.metadata, "tiled": f"{k}^{packing.dim} copies of N={packing.n}"}
    return Packing(x, np.tile(packing.diameters, len(shifts)), k * packing.box, metadata)


def timed_run(start: Packing, kw: dict):
    """run_calippso and the CPU seconds it took (this process, all its threads)."""
    cpu0 = time.process_time()
    result = run_calippso(start, progress_interval=30.0, **kw)
    return result, time.process_time() - cpu0


def report(label: str, start: Packing, result, cpu: float) -> None:
    h = result.history
    s = result.summary()
    names = {code: name for name, code in METHOD_CODES.items()}
    per_method = ", ".join(
        f"{names[c]} {int(np.sum(h['method'] == c))} ({h['cpu_time'][h['method'] == c].sum():.2f} s)"
        for c in sorted(set(h["method"].tolist())))
    print(f"== {label}")
    print(f"   iterations {result.iterations} (converged {result.completed}); LPs (CPU s): {per_method}")
    print(f"   CPU {cpu:.2f} s (LPs incl. the force LP {result.counters['lp_cpu_time']:.2f} s), wall "
          f"{result.wall_time:.2f} s; methods incl. force LP {result.counters['lp_methods']}, HiGHS solvers "
          f"{result.counters['lp_solvers']}, warm-start attempts {result.counters['warm_attempts']}")
    print(f"   phi_J {result.phi:.10f}  delta_phi {s['delta_phi']:.3e}  contacts {result.n_contacts}  "
          f"rattlers {result.n_rattlers} ({100 * s['rattler_fraction']:.2f}%)  isostatic {result.isostatic}  "
          f"force balance {result.force_balance_residual:.2e}  worst overlap {result.counters['worst_overlap']:.1e}")
    if start.metadata.get("reduced_pressure"):
        p = float(start.metadata["reduced_pressure"])
        if p < 1e9:
            print(f"   LS->CALiPPSO consistency d phi_J / (p (phi_J - phi0)) = "
                  f"{start.dim * result.phi / (p * (result.phi - start.phi)):.3f} (spec: ~1 +- 30%)")
        else:  # the expected shift d phi / p is below the LP's resolution
            print(f"   start at p = {p:.3g}: expected phi_J - phi0 ~ d phi / p = {start.dim * start.phi / p:.1e}")
    print("   per LP: sqrt(G)-1, max|s|, rows, CPU s, wall s, method")
    for k in range(result.iterations):
        print(f"     {k + 1:3d} {h['sqrt_inflation_minus_1'][k]: .3e} {h['max_displacement'][k]:.3e} "
              f"{h['n_constraints'][k]:7d} {h['cpu_time'][k]:7.2f} {h['solve_time'][k]:7.2f} "
              f"{names[int(h['method'][k])]}")
    if result.completed:
        d = distributions(result)
        print(f"   gaps: gamma = {d['gap_gamma']:.3f} +- {d['gap_gamma_stderr']:.3f} from {int(d['gap_fit_n'])} gaps "
              f"in h in [{d['gap_fit_lo']:g}, {d['gap_fit_hi']:g}] (mean field {MEAN_FIELD_GAMMA})")
        print(f"   forces: theta(all) = {d['force_theta_all']:.3f} +- {d['force_theta_all_stderr']:.3f}, "
              f"theta(extended) = {d['force_theta_extended']:.3f} +- {d['force_theta_extended_stderr']:.3f} "
              f"from f/<f> in [{d['force_fit_lo']:g}, {d['force_fit_hi']:g}] (mean field theta_e "
              f"{MEAN_FIELD_THETA_E})")


def _by_pair(result) -> np.ndarray:
    """The contact forces ordered by their pair (i, j), so that two results compare force to force."""
    return result.forces[np.lexsort((result.pairs[:, 1], result.pairs[:, 0]))]


def agreement(ref, other) -> str:
    """Same contact network and rattlers as the reference path, and both force balances <= 1e-10."""
    same_pairs = {tuple(p) for p in ref.pairs.tolist()} == {tuple(p) for p in other.pairs.tolist()}
    same_rattlers = bool(np.array_equal(ref.rattlers, other.rattlers))
    balanced = max(ref.force_balance_residual, other.force_balance_residual) <= 1e-10
    df = float(np.max(np.abs(_by_pair(ref) - _by_pair(other)))) if same_pairs else float("nan")
    ok = same_pairs and same_rattlers and balanced and ref.isostatic == other.isostatic
    return (f"same contacts {same_pairs}, same rattlers {same_rattlers}, force balance <= 1e-10 {balanced}, "
            f"max |f - f_ref| {df:.1e} (units of the mean), delta phi {other.phi - ref.phi:.1e} -> "
            f"{'agree' if ok else 'DISAGREE'}")


def per_lp_ratio(ref, other) -> str:
    """CPU time of the LPs both runs solved (one of them stopped early by ``@max_lps``), first LP and all shared."""
    k = min(ref.iterations, other.iterations)
    a, b = ref.history["cpu_time"][:k], other.history["cpu_time"][:k]
    return (f"first {k} LP(s): CPU {b.sum():.1f} s against {a.sum():.1f} s, ratio {b.sum() / a.sum():.2f}; first LP "
            f"{b[0]:.1f} s against {a[0]:.1f} s (no agreement check: a run stopped before convergence)")


def first_lp(start: Packing) -> tuple[tuple, dict]:
    """The arguments of the first LP that run_calippso solves on ``start`` (the LP is built, not solved)."""
    import spherejam.calippso.run as run_module

    class Captured(Exception):
        pass

    def capture(*args, **kwargs):
        raise Captured(args, kwargs)

    solve = run_module.solve_lp
    run_module.solve_lp = capture
    try:
        run_calippso(start, solver="hipo")
    except Captured as exc:
        return exc.args
    finally:
        run_module.solve_lp = solve
    raise RuntimeError("run_calippso solved no LP")


def time_fallback(start: Packing, reps: int = 2) -> None:
    """The first LP of ``start`` by HiPO to the vertex tolerance; if its vertex is not certified, the fallback
    timed both ways at any N, alternately in this process: "predicted" (primal simplex from the predicted vertex's
    basis, the path below lp.PREDICTED_MAX_N) against "ipm" (the old fallback, a second HiPO solve with crossover,
    the path from that N on). CPU s; the ratio is old / new of the fastest repetition."""
    import highspy

    from spherejam.calippso import lp

    args, kw = first_lp(start)
    kw = {**kw, "solver": "hipo", "crossover": False, "warm": None}
    run, max_n = highspy.Highs.run, lp.PREDICTED_MAX_N
    solves: list[str] = []

    def timed(self):
        cpu0 = time.process_time()
        status = run(self)
        info = self.getInfo()
        solves.append(f"{self.getOptionValue('solver')[1]} {time.process_time() - cpu0:.2f} s "
                      f"({info.ipm_iteration_count} IPM, {info.simplex_iteration_count} simplex, "
                      f"{info.crossover_iteration_count} crossover iterations)")
        return status

    best: dict[str, float] = {}
    sols = {}
    highspy.Highs.run = timed
    try:
        for _ in range(reps):
            for fallback in ("ipm", "predicted"):
                lp.PREDICTED_MAX_N, solves[:] = (0 if fallback == "ipm" else math.inf), []
                cpu0 = time.process_time()
                sol = lp.solve_lp(*args, **kw)
                cpu = time.process_time() - cpu0
                if sol.method_name == "vertex":
                    print(f"first LP ({args[0].shape[0]} rows): vertex certified, no fallback to time ({cpu:.2f} s)")
                    return
                best[fallback] = min(best.get(fallback, math.inf), cpu)
                sols[fallback] = sol
                print(f"   fallback {fallback}: {cpu:.2f} s CPU, method {sol.method}; solves: {'; '.join(solves)}")
    finally:
        highspy.Highs.run, lp.PREDICTED_MAX_N = run, max_n
    old, new = sols["ipm"], sols["predicted"]
    same = bool(np.array_equal(old.duals > 0, new.duals > 0))
    print(f"first LP ({args[0].shape[0]} rows, N={start.n}): vertex not certified; fallback CPU s: old (ipm) "
          f"{best['ipm']:.2f}, new (predicted) {best['predicted']:.2f}, ratio old/new "
          f"{best['ipm'] / best['predicted']:.2f}; same active rows {same}, "
          f"|Gamma - Gamma_old| {abs(new.inflation - old.inflation):.1e}")


def certify_mls(n: int, seeds: list[int]) -> None:
    try:
        from spherejam.engines.closest_jamming import find_closest_jamming
    except ImportError:
        print("spherejam.engines.closest_jamming.find_closest_jamming is not available; MLS certification skipped")
        return
    from spherejam.core.seeding import poisson_packing

    for seed in seeds:
        t = time.perf_counter()
        mls = find_closest_jamming(poisson_packing(n, 0.0, seed, dim=3))
        mls_packing = getattr(mls, "packing", mls)
        t_mls = time.perf_counter() - t
        result = run_calippso(mls_packing)
        dphi = result.phi - mls_packing.phi
        ok = abs(dphi) <= 1e-4 and result.isostatic
        print(f"MLS seed {seed}: N={n} phi_MLS {mls_packing.phi:.8f} -> CALiPPSO {result.phi:.8f} "
              f"(delta {dphi:.2e}), iterations {result.iterations}, isostatic {result.isostatic}, "
              f"MLS {t_mls:.1f} s, CALiPPSO {result.wall_time:.1f} s -> {'PASS' if ok else 'FAIL'}")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=1024)
    ap.add_argument("--pressure", type=float, default=1e5)
    ap.add_argument("--rate", type=float, default=1e-2, help="LS compression rate of the start (1e-2)")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--start-kind", choices=("mls", "ls"), default="mls",
                    help="mls: LS then MLS with p_max = --pressure (default); ls: LS only")
    ap.add_argument("--dat", help="CALiPPSO.jl example input instead of an LS start")
    ap.add_argument("--start", help="packing file (spherejam HDF5) to start from instead of a new LS run")
    ap.add_argument("--save-start", help="write the LS start to this packing file")
    ap.add_argument("--mls", action="store_true", help="certify MLS outputs instead")
    ap.add_argument("--paths", nargs="+", default=["ipx+crossover", "hipo"],
                    help="LP paths solver[:threads][+crossover], the first is the reference (ipx+crossover hipo)")
    ap.add_argument("--fallback", action="store_true",
                    help="time the fallback of an uncertified vertex on the first LP, new path against the old")
    ap.add_argument("--tile", type=int, default=1, help="replicate the start K x K x K times (default 1)")
    ap.add_argument("-v", "--verbose", action="store_true")
    args = ap.parse_args(argv)
    if args.tile < 1:
        ap.error(f"--tile must be >= 1, got {args.tile}")
    logging.basicConfig(level=logging.INFO if args.verbose else logging.WARNING, format="%(message)s")
    if args.mls:
        certify_mls(min(args.n, 512), [args.seed, args.seed + 1])
        return 0
    if args.dat:
        start = read_dat(args.dat)
        label = args.dat
    elif args.start:
        from spherejam.core.packing_io import read_packing

        start = read_packing(args.start)
        label = args.start
    else:
        start, t_ls = ls_start(args.n, args.pressure, args.rate, args.seed, args.start_kind)
        label = f"{args.start_kind.upper()} start, seed {args.seed} (made in {t_ls:.1f} s, not timed below)"
        if args.save_start:
            from spherejam.core.packing_io import write_packing

            write_packing(args.save_start, start)
    start = tiled(start, args.tile)
    if args.tile > 1:
        label += f", tiled {args.tile}^{start.dim}"
    print(f"start: {label}: N={start.n} d={start.dim} phi0={start.phi:.10f} "
          f"p={start.metadata.get('reduced_pressure')}")
    if args.fallback:
        time_fallback(start)
        return 0
    results = []
    for path in args.paths:
        kw = parse_path(path)
        if kw["threads"] == 1:
            result, cpu = timed_run(start, kw)
        else:  # HiGHS fixes its thread count at a process's first solve: run this path in a fresh process
            import multiprocessing
            from concurrent.futures import ProcessPoolExecutor

            with ProcessPoolExecutor(1, mp_context=multiprocessing.get_context("spawn")) as pool:
                result, cpu = pool.submit(timed_run, start, kw).result()
        report(path, start, result, cpu)
        target = TARGETS.get(start.n)
        if target is not None and "max_iterations" not in kw:
            print(f"   issue target <= {target:g} s on one core: {'met' if cpu <= target else 'NOT met'} (CPU s)")
        if results and results[0].completed and result.completed:
            print(f"   vs {args.paths[0]}: {agreement(results[0], result)}")
        elif results:
            print(f"   vs {args.paths[0]}: {per_lp_ratio(results[0], result)}")
        results.append(result)
    return 0


if __name__ == "__main__":
    sys.exit(main())
