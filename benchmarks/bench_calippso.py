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

A path is ``solver[:threads][+crossover][-warm][+cg][+interior|+vertex][/schedule][@max_lps]`` (``auto``:
run_calippso's default; ``-warm``: no warm starts, the path of every N >= 4096; ``+cg``: constraint generation,
docs/calippso.md §5.7, so that ``--paths auto auto+cg`` times today's path and constraint generation side by side;
``+interior``: intermediate steps from the interior point, docs/calippso.md §10, and ``+vertex`` every LP a vertex,
whatever the default at the input's N, §10.11; ``/reference``: the reference's bounds schedule,
docs/calippso.md §10, so that ``--paths auto auto/reference --table`` is the trajectory A/B, each path's certificate
checked on its own by the issue's validity criteria and its LPs and CPU printed as ratios to the first path's):
``ipx+crossover`` is the old path (IPX interior point, HiGHS crossover), ``hipo`` the new path (HiPO interior point,
its vertex certified by the active-set solve, crossover only as the fallback; ``solver="auto"`` takes it from N = 4096
on). The first path listed is the reference: every other path must give the same contact network, the same rattlers
and force balance <= 1e-10 (printed as "agree"; a path that changes the trajectory may end on another valid state).
Times are CPU seconds of this process (the machine is shared: wall time is printed too but is no figure), per LP and
in total; ``--lp-log DIR`` keeps each path's per-LP CSV. ``@max_lps`` stops a path after that many LPs, for an old
path too slow to run to the end (its per-LP times are then compared with the same LPs of the other paths, not its
total).

``--baseline REF`` runs every path twice, side by side in one run: with today's package (this checkout) and with
the package as it was at git revision REF (exported by ``git archive`` into a temporary folder and run in a child
process; default :data:`BASELINE_REF`, the last revision before the active-set solve learnt to pivot on bounds, to
relax violated rows and to promote rattlers, docs/calippso.md §5.4). The new path's certificate must agree with the
baseline's (same contacts and rattlers, force balance <= 1e-10, |delta phi| <= 1e-9). ``--fixture NAME`` starts from
a packing built by ``benchmarks/calippso_fixtures.py``. ``--table`` prints one summary row per path (LPs, CPU per LP,
the solver path of each LP as one letter per LP, contacts, rattlers, isostaticity, force balance).

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
import os
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
#: Today's path of ``--baseline``: the package before the active-set solve pivoted on bounds (issue 30).
BASELINE_REF = "8725c3c"
#: One letter per LP method in the ``--table`` solver path.
METHOD_LETTERS = {"ipm": "I", "simplex": "S", "active-set": "a", "warm": "w", "vertex": "V", "predicted": "P",
                  "interior": "i"}


def parse_path(text: str) -> dict:
    """``solver[:threads][+crossover][-warm][+cg][+interior|+vertex][/schedule][@max_lps]`` -> run_calippso keyword
    arguments (``+interior``: intermediate steps from the interior point; ``+vertex``: every LP a vertex, whatever
    the default of the input's N; neither: run_calippso's default, docs/calippso.md §10.11; ``-warm``:
    no warm starts, as from N = 4096 on; ``+cg``: constraint generation, docs/calippso.md §5.7; ``/schedule``: the
    bounds schedule, ``adaptive``, ``reference`` or ``trust``, docs/calippso.md §10)."""
    text, _, max_lps = text.partition("@")
    text, _, schedule = text.partition("/")
    kw = {"schedule": schedule} if schedule else {}
    if text.endswith("+interior"):
        text, kw["interior_steps"] = text.removesuffix("+interior"), True
    elif text.endswith("+vertex"):
        text, kw["interior_steps"] = text.removesuffix("+vertex"), False
    if text.endswith("+cg"):
        text, kw["constraint_generation"] = text.removesuffix("+cg"), True
    if text.endswith("-warm"):
        text, kw["warm_start"] = text.removesuffix("-warm"), False
    crossover = True if text.endswith("+crossover") else None  # None: run_calippso's pairing for the solver
    solver, _, threads = text.removesuffix("+crossover").partition(":")
    kw.update(solver=solver, threads=int(threads or 1), crossover=crossover)
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


class Certificate:
    """The figures of one certification: from a run in this process (``result`` set) or from a child's dump."""

    SCALARS = ("phi", "phi_initial", "n_contacts", "n_rattlers", "isostatic", "force_balance_residual", "iterations",
               "completed", "cpu", "wall_time")

    def __init__(self, **fields):
        self.result = None
        self.__dict__.update(fields)

    @classmethod
    def of(cls, result, cpu: float) -> Certificate:
        return cls(result=result, history=result.history, pairs=result.pairs, rattlers=result.rattlers,
                   forces=result.forces, phi=result.phi, phi_initial=result.phi_initial,
                   n_contacts=result.n_contacts, n_rattlers=result.n_rattlers, isostatic=result.isostatic,
                   force_balance_residual=result.force_balance_residual, iterations=result.iterations,
                   completed=result.completed, cpu=cpu, wall_time=result.wall_time, counters=result.counters)

    def dump(self, path: str) -> None:
        import json

        arrays = {f"history_{k}": v for k, v in self.history.items()}
        meta = {k: getattr(self, k) for k in self.SCALARS}
        meta["counters"] = {k: v for k, v in self.counters.items() if isinstance(v, (int, float, str, bool, dict))}
        np.savez(path, pairs=self.pairs, rattlers=self.rattlers, forces=self.forces,
                 meta=np.array(json.dumps(meta, default=float)), **arrays)

    @classmethod
    def load(cls, path: str) -> Certificate:
        import json

        with np.load(path) as f:
            meta = json.loads(str(f["meta"]))
            history = {k.removeprefix("history_"): f[k] for k in f.files if k.startswith("history_")}
            return cls(history=history, pairs=f["pairs"], rattlers=f["rattlers"], forces=f["forces"], **meta)

    @property
    def rattler_fraction(self) -> float:
        return self.n_rattlers / self.rattlers.size

    def solver_path(self) -> str:
        """One letter per LP (:data:`METHOD_LETTERS`)."""
        names = {code: name for name, code in METHOD_CODES.items()}
        return "".join(METHOD_LETTERS[names[int(c)]] for c in self.history["method"])


def timed_run(start: Packing, kw: dict, lp_log: str | None = None) -> Certificate:
    """run_calippso and the CPU seconds it took (this process, all its threads); ``lp_log``: its per-LP CSV."""
    cpu0 = time.process_time()
    result = run_calippso(start, progress_interval=30.0, lp_log=lp_log, **kw)
    return Certificate.of(result, time.process_time() - cpu0)


def baseline_run(ref: str, start_file: str, path: str, workdir: str) -> Certificate:
    """The certification of ``start_file`` by the package as it was at git revision ``ref``, in a child process."""
    import subprocess
    from pathlib import Path

    repo = Path(__file__).resolve().parent.parent
    tree = Path(workdir) / f"spherejam-{ref}"
    if not tree.exists():
        tree.mkdir(parents=True)
        archive = subprocess.run(["git", "-C", str(repo), "archive", ref, "src"], check=True, capture_output=True)
        subprocess.run(["tar", "-x", "-C", str(tree)], input=archive.stdout, check=True)
    out = Path(workdir) / f"baseline-{path.replace(':', '_').replace('@', '_')}.npz"
    env = {**os.environ, "PYTHONPATH": str(tree / "src")}
    subprocess.run([sys.executable, __file__, "--start", start_file, "--paths", path, "--dump", str(out)], env=env,
                   check=True)
    return Certificate.load(str(out))


def report(label: str, start: Packing, cert: Certificate) -> None:
    h = cert.history
    names = {code: name for name, code in METHOD_CODES.items()}
    per_method = ", ".join(
        f"{names[c]} {int(np.sum(h['method'] == c))} ({h['cpu_time'][h['method'] == c].sum():.2f} s)"
        for c in sorted(set(h["method"].tolist())))
    c = cert.counters
    print(f"== {label}")
    print(f"   iterations {cert.iterations} (converged {cert.completed}); LPs (CPU s): {per_method}")
    print(f"   CPU {cert.cpu:.2f} s (LPs incl. the force LP {c['lp_cpu_time']:.2f} s), wall "
          f"{cert.wall_time:.2f} s; methods incl. force LP {c['lp_methods']}, HiGHS solvers "
          f"{c['lp_solvers']}, warm-start attempts {c['warm_attempts']}")
    print(f"   phi_J {cert.phi:.10f}  delta_phi {cert.phi - cert.phi_initial:.3e}  contacts {cert.n_contacts}  "
          f"rattlers {cert.n_rattlers} ({100 * cert.rattler_fraction:.2f}%)  isostatic {cert.isostatic}  "
          f"force balance {cert.force_balance_residual:.2e}  worst overlap {c['worst_overlap']:.1e}")
    if start.metadata.get("reduced_pressure"):
        p = float(start.metadata["reduced_pressure"])
        if p < 1e9:
            print(f"   LS->CALiPPSO consistency d phi_J / (p (phi_J - phi0)) = "
                  f"{start.dim * cert.phi / (p * (cert.phi - start.phi)):.3f} (spec: ~1 +- 30%)")
        else:  # the expected shift d phi / p is below the LP's resolution
            print(f"   start at p = {p:.3g}: expected phi_J - phi0 ~ d phi / p = {start.dim * start.phi / p:.1e}")
    print("   per LP: sqrt(G)-1, max|s|, rows (in the cutoff / solved / added by constraint generation), CPU s, "
          "wall s, method")
    solved = h.get("lp_rows", h["n_constraints"])  # a baseline before constraint generation has no such column
    added = h.get("rows_added", np.zeros_like(solved))
    for k in range(cert.iterations):
        print(f"     {k + 1:3d} {h['sqrt_inflation_minus_1'][k]: .3e} {h['max_displacement'][k]:.3e} "
              f"{h['n_constraints'][k]:7d} {solved[k]:7d} {added[k]:4d} {h['cpu_time'][k]:7.2f} "
              f"{h['solve_time'][k]:7.2f} {names[int(h['method'][k])]}")
    if cert.completed and cert.result is not None:
        d = distributions(cert.result)
        print(f"   gaps: gamma = {d['gap_gamma']:.3f} +- {d['gap_gamma_stderr']:.3f} from {int(d['gap_fit_n'])} gaps "
              f"in h in [{d['gap_fit_lo']:g}, {d['gap_fit_hi']:g}] (mean field {MEAN_FIELD_GAMMA})")
        print(f"   forces: theta(all) = {d['force_theta_all']:.3f} +- {d['force_theta_all_stderr']:.3f}, "
              f"theta(extended) = {d['force_theta_extended']:.3f} +- {d['force_theta_extended_stderr']:.3f} "
              f"from f/<f> in [{d['force_fit_lo']:g}, {d['force_fit_hi']:g}] (mean field theta_e "
              f"{MEAN_FIELD_THETA_E})")


TABLE_HEAD = ("| input | N | code | LPs | CPU s | CPU s / LP | LPs, CPU / first path's | solver path per LP | "
              "contacts | rattlers | phi_J - first path's | isostatic | force balance | valid |\n"
              "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|")


def validity(cert) -> tuple[bool, str]:
    """The issue's validity of a certificate, on its own: converged under the unchanged criteria (sqrt(Gamma) - 1 <=
    1e-12 and max |s| <= 1e-9 over stable particles at the last LP), isostatic, force balance <= 1e-10, no overlap
    (worst relative overlap <= 1e-10). Returns (valid, the failed criteria)."""
    h = cert.history
    failed = [name for name, ok in (
        ("converged", bool(cert.completed) and h["sqrt_inflation_minus_1"][-1] <= 1e-12
         and h["max_displacement"][-1] <= 1e-9),
        ("isostatic", bool(cert.isostatic)),
        ("force balance", cert.force_balance_residual <= 1e-10),
        ("overlap", cert.counters.get("worst_overlap", math.inf) <= 1e-10)) if not ok]
    return not failed, ", ".join(failed)


def table_row(label: str, n: int, code: str, cert: Certificate, first: Certificate | None = None) -> str:
    lps = cert.iterations + (1 if cert.counters.get("fine_tuned") else 0)
    ok, failed = validity(cert)
    ratios = dphi = "(first)"
    if first is not None:
        ratios = f"{cert.iterations / first.iterations:.2f}, {cert.cpu / first.cpu:.2f}"
        dphi = f"{cert.phi - first.phi:.1e}"
    return (f"| {label} | {n} | {code} | {cert.iterations} + 1 | {cert.cpu:.1f} | {cert.cpu / max(lps, 1):.2f} | "
            f"{ratios} | {cert.solver_path()} | {cert.n_contacts} | {cert.n_rattlers} | {dphi} | {cert.isostatic} | "
            f"{cert.force_balance_residual:.1e} | {'yes' if ok else 'NO: ' + failed} |")


def _by_pair(cert) -> np.ndarray:
    """The contact forces ordered by their pair (i, j), so that two results compare force to force."""
    return cert.forces[np.lexsort((cert.pairs[:, 1], cert.pairs[:, 0]))]


def agreement(ref, other) -> str:
    """Same contact network and rattlers as the reference path, both force balances <= 1e-10 and |delta phi| <=
    1e-9; failing that, whether both are isostatic and balanced (another vertex of a degenerate optimum)."""
    same_pairs = {tuple(p) for p in ref.pairs.tolist()} == {tuple(p) for p in other.pairs.tolist()}
    same_rattlers = bool(np.array_equal(ref.rattlers, other.rattlers))
    balanced = max(ref.force_balance_residual, other.force_balance_residual) <= 1e-10
    dphi = other.phi - ref.phi
    df = float(np.max(np.abs(_by_pair(ref) - _by_pair(other)))) if same_pairs else float("nan")
    ok = same_pairs and same_rattlers and balanced and ref.isostatic == other.isostatic and abs(dphi) <= 1e-9
    verdict = "agree" if ok else ("DISAGREE (both isostatic and balanced)" if balanced and ref.isostatic
                                  and other.isostatic else "DISAGREE")
    return (f"same contacts {same_pairs}, same rattlers {same_rattlers}, force balance <= 1e-10 {balanced}, "
            f"max |f - f_ref| {df:.1e} (units of the mean), delta phi {dphi:.1e} -> {verdict}")


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
    ap.add_argument("--fixture", help="start from this benchmarks/calippso_fixtures.py fixture (built if missing)")
    ap.add_argument("--baseline", nargs="?", const=BASELINE_REF, default=None, metavar="REF",
                    help=f"also run every path with the package at git revision REF ({BASELINE_REF}), side by side")
    ap.add_argument("--table", action="store_true", help="print one markdown table row per path at the end")
    ap.add_argument("--label", help="the input's name in the table (default: the fixture or start file)")
    ap.add_argument("--dump", help=argparse.SUPPRESS)  # a child of --baseline: write the certificate here
    ap.add_argument("--lp-log", metavar="DIR",
                    help="write each path's per-LP record (docs/calippso.md §10.1) to DIR/LABEL.PATH.lps.csv")
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
    elif args.start or args.fixture:
        from spherejam.core.packing_io import read_packing

        if args.fixture:
            from calippso_fixtures import build

            args.start = str(build(args.fixture))
        start = read_packing(args.start)
        label = args.fixture or args.start
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
    if args.dump:  # a child of --baseline: one path, its certificate to a file
        timed_run(start, parse_path(args.paths[0])).dump(args.dump)
        return 0
    import tempfile

    workdir = tempfile.mkdtemp(prefix="bench_calippso-")
    start_file = args.start
    if args.baseline and (start_file is None or args.tile > 1):
        from spherejam.core.packing_io import write_packing

        start_file = f"{workdir}/start.h5"
        write_packing(start_file, start)
    rows = []
    results = []
    for path in args.paths:
        kw = parse_path(path)
        lp_log = None
        if args.lp_log:  # one CSV per path, written LP by LP: a path stopped by hand keeps its LPs
            os.makedirs(args.lp_log, exist_ok=True)
            stem = os.path.basename(args.label or label).removesuffix(".h5")
            lp_log = os.path.join(args.lp_log, f"{stem}.{path.replace('/', '_').replace(':', '_')}.lps.csv")
        if kw["threads"] == 1:
            cert = timed_run(start, kw, lp_log)
        else:  # HiGHS fixes its thread count at a process's first solve: run this path in a fresh process
            import multiprocessing
            from concurrent.futures import ProcessPoolExecutor

            with ProcessPoolExecutor(1, mp_context=multiprocessing.get_context("spawn")) as pool:
                cert = pool.submit(timed_run, start, kw, lp_log).result()
        report(path, start, cert)
        target = TARGETS.get(start.n)
        pressure = float(start.metadata.get("reduced_pressure") or math.nan)
        if start.n == 1024 and not pressure < 1e9:  # N = 1024's target is for a start at p = 1e5
            target = None
        if target is not None and "max_iterations" not in kw:
            print(f"   issue target <= {target:g} s on one core: {'met' if cert.cpu <= target else 'NOT met'} (CPU s)")
        ok, failed = validity(cert)
        print(f"   valid certificate (converged, isostatic, force balance <= 1e-10, no overlap): "
              f"{'yes' if ok else 'NO (' + failed + ')'}")
        if results:
            print(f"   against {args.paths[0]}: LPs {cert.iterations} vs {results[0].iterations} (ratio "
                  f"{cert.iterations / results[0].iterations:.2f}), CPU {cert.cpu:.1f} s vs {results[0].cpu:.1f} s "
                  f"(ratio {cert.cpu / results[0].cpu:.2f})")
        if results and results[0].completed and cert.completed:
            print(f"   vs {args.paths[0]}: {agreement(results[0], cert)}")
        elif results:
            print(f"   vs {args.paths[0]}: {per_lp_ratio(results[0], cert)}")
        results.append(cert)
        name = args.label or label
        if args.baseline:
            base = baseline_run(args.baseline, start_file, path, workdir)
            report(f"{path} at {args.baseline} (today's path)", start, base)
            print(f"   new against today's: LPs {cert.iterations} vs {base.iterations}, CPU {cert.cpu:.1f} s vs "
                  f"{base.cpu:.1f} s (ratio {base.cpu / cert.cpu:.2f})")
            if base.completed and cert.completed:
                print(f"   new against today's certificate: {agreement(base, cert)}")
            rows.append(table_row(name, start.n, f"{path} at {args.baseline}", base))
        rows.append(table_row(name, start.n, path, cert, results[0] if len(results) > 1 else None))
    if args.table:
        print(TABLE_HEAD)
        print("\n".join(rows))
    return 0


if __name__ == "__main__":
    sys.exit(main())
