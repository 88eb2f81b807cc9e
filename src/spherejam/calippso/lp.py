"""Solving one CALiPPSO linear program with HiGHS: the solver choice, warm starts from the previous LP's basis, and
the certified vertex that replaces HiGHS's crossover (docs/calippso.md §5).

Every solution HiGHS calls optimal is checked here once more (rows, bounds, force balance) before it is used
(docs/calippso.md §5.5), and every failure is reported with the LP's iteration and size (docs/calippso.md §6).
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from ..core.errors import InputError, SimulationError, require
from ..core.validation import LP_SOLVERS
from .active_set import MAX_PIVOTS, interior_point_prediction, solve_active_set
from .constraints import Pins, as_pins, constraint_rows, pair_keys, particle_force_sums, row_excess
from .highs import highs_model
from .solution import LPBasis, LPSolution

#: The HiGHS solvers an LP can be sent to: HiPO (sparse-direct interior point, needs highspy-extras), IPX
#: (interior point), dual simplex.
SOLVERS = LP_SOLVERS
#: Smallest N that ``solver="auto"`` sends to HiPO with a certified vertex; below it IPX + crossover is faster
#: (docs/calippso.md §5.1).
AUTO_HIPO_MIN_N = 4096
#: Smallest N whose LPs are never warm-started: there a warm start needs so many pivots that a cold HiPO solve is
#: cheaper (docs/calippso.md §5.3).
WARM_START_MAX_N = 4096
#: IPM optimality tolerance of an interior-point solve whose vertex is certified instead of crossed over: tight
#: enough that the near-active rows separate clearly from the others (docs/calippso.md §5.2).
VERTEX_IPM_TOLERANCE = 1e-12
#: Smallest N whose uncertified vertices fall back to a second interior point with HiGHS's crossover; below it
#: they fall back to primal simplex from the predicted vertex's basis. From N = 4096 on that basis needed more pivots
#: than the second solve costs, as warm starts did (docs/calippso.md §5.2); benchmarks/bench_calippso.py --fallback
#: sets it to time both paths on one LP.
PREDICTED_MAX_N = 4096
#: Primal simplex pivots allowed from a predicted basis before the second interior point takes over: about the
#: break-even with that solve at N = 1024-2048 (docs/calippso.md §5.2).
PREDICTED_PIVOT_LIMIT = 1500
#: The unit kappa of a near-converged LP as HiGHS gets it (``solve_lp(scale=...)``): its unknowns are s / kappa (s in
#: largest diameters) and (Gamma - 1) / kappa, so that HiGHS's absolute tolerances (1e-9) act at 1e-14 in the LP's own
#: units, below the contacts' gaps there and above the round-off of |r|^2 - sigma^2 (docs/calippso.md §5.8).
NEAR_CONVERGED_SCALE = 1e-5


def resolve_solver(solver: str, n: int) -> str:
    """The HiGHS solver of a cold solve for ``solver`` (one of :data:`SOLVERS` or "auto") at N = ``n``: "auto" is
    HiPO from :data:`AUTO_HIPO_MIN_N` on when highspy-extras provides it, else IPX."""
    require(solver in (*SOLVERS, "auto"), "solver", solver, f"must be one of auto, {', '.join(SOLVERS)}")
    if solver == "auto":  # without highspy-extras HiGHS has no HiPO
        solver = "hipo" if n >= AUTO_HIPO_MIN_N and _highspy_extras() is not None else "ipx"
    return solver


_BLAS_THREADS: list[int] = []


def _highspy_extras():
    """The import spec of highspy-extras (HiPO's libraries), or None if it is not installed."""
    import importlib.util

    return importlib.util.find_spec("highspy_extras")


def _limit_blas_threads(threads: int) -> None:
    """Give HiPO's BLAS (OpenBLAS linked into highspy-extras) ``threads`` threads.

    HiGHS's ``threads`` option does not reach it, and OpenBLAS otherwise starts one thread per core: a one-core
    workflow job would then use every core of the node for its dense kernels.
    """
    if _BLAS_THREADS == [threads]:
        return
    import ctypes

    spec = _highspy_extras()
    if spec is None or not spec.submodule_search_locations:
        return
    for lib in sorted(Path(next(iter(spec.submodule_search_locations))).glob("libhighs_extras*.so*")):
        try:
            ctypes.CDLL(str(lib)).openblas_set_num_threads(int(threads))
        except (OSError, AttributeError):
            continue
    _BLAS_THREADS[:] = [threads]


def highs_version() -> str:
    """The HiGHS version (recorded in a run's parameters)."""
    import highspy

    return highspy.Highs().version()


def _highs_options(tolerance: float, extra: dict[str, Any] | None, solver: str = "hipo",
                   threads: int = 1) -> dict[str, Any]:
    opts: dict[str, Any] = {
        "output_flag": False,
        # named explicitly: with highspy-extras installed "ipm" silently means HiPO, without it IPX
        "solver": solver,
        "run_crossover": "on",  # a vertex solution: duals exact and zero off the active set
        "primal_feasibility_tolerance": tolerance,
        "dual_feasibility_tolerance": tolerance,
        "ipm_optimality_tolerance": tolerance,
        # r_ij components are O(1) in our units, but keep tiny ones rather than treating them as zero
        "small_matrix_value": 1e-12,
        # one thread by default: workflow jobs get one core each, and idle scheduler workers would spin on it
        "threads": int(threads),
    }
    if solver == "hipo":
        # Gamma's column has an entry in every row, so the normal equations are dense: HiPO's analysis tries them,
        # fails, and takes the augmented system after all (13 of 73 CPU-s at N = 1e4, docs/calippso.md §5.1)
        opts["hipo_system"] = "augmented"
    opts.update(extra or {})
    return opts


_BASIC = 1  # HighsBasisStatus.kBasic


def _warm_basis(warm: LPBasis, keys: np.ndarray, highspy):
    """The previous LP's basis carried over to the rows ``keys``: rows new to the LP start basic (slack).

    Flagged alien when the count of basic variables is wrong (an active row left the cutoff), so HiGHS repairs it
    instead of rejecting it.
    """
    pos = np.minimum(np.searchsorted(warm.keys, keys), warm.keys.size - 1)
    found = warm.keys[pos] == keys
    rows = np.where(found, warm.rows[pos], _BASIC)
    basis = highspy.HighsBasis()
    members = _status_members(highspy)
    basis.col_status = members[warm.cols].tolist()
    basis.row_status = members[rows].tolist()
    basis.valid = True
    # alien only when needed: HiGHS's alien-basis repair factorises once more (docs/calippso.md §5.3); a square
    # basis that is singular is still caught, as rank deficiency, when simplex factorises it
    basis.alien = bool(np.count_nonzero(rows == _BASIC) + np.count_nonzero(warm.cols == _BASIC) != keys.size)
    return basis


def _vertex_basis(vertex: LPSolution, rattler: np.ndarray, fixed: np.ndarray, pinned: int,
                  keys: np.ndarray) -> LPBasis:
    """The HiGHS basis of a certified vertex (for the next LP's warm start): active rows at their upper bound, the
    displacements of stable particles and Gamma basic, held components, the pinned particle and rattlers at a
    bound (rattlers at the one they moved towards, as HiGHS's crossover leaves them)."""
    n, dim = vertex.s.shape
    cols = np.where(vertex.s.ravel() > 0, 2, 0).astype(np.int8)  # kUpper / kLower
    free = np.repeat(~rattler, dim) & (fixed.ravel() == 0)
    free[as_pins(pinned, n, dim).columns] = False
    cols[free] = _BASIC
    cols = np.append(cols, np.int8(_BASIC))  # Gamma
    rows = np.where(vertex.duals > 0, 2, _BASIC).astype(np.int8)
    order = np.argsort(keys)
    return LPBasis(keys[order], rows[order], cols)


def _status_members(highspy):
    s = highspy.HighsBasisStatus
    members = np.array([s.kLower, s.kBasic, s.kUpper, s.kZero, s.kNonbasic], dtype=object)
    assert all(int(m) == k for k, m in enumerate(members))
    return members


def _status_codes(statuses) -> np.ndarray:
    return np.fromiter((int(v) for v in statuses), dtype=np.int8, count=len(statuses))


def _vertex_problem(rij, sigma2, pi, pj, s, inflation, duals, lower, upper, tolerance) -> str | None:
    """Check a solution HiGHS calls optimal ourselves; a description of what is wrong, or None.

    Primal: every row holds to 10 ``tolerance`` relative to its pair's sigma_ij^2, every bound to 10 ``tolerance``.
    Dual: the pair forces balance (to 1e-6 of the mean force) on every displacement component strictly inside its
    bounds (why: docs/calippso.md §5.5).
    """
    excess = float(row_excess(rij, sigma2, pi, pj, s, inflation))
    if excess > 10.0 * tolerance:
        return f"a pair row is violated by {excess:.1e}"
    slack = max(float(np.max(lower - s)), float(np.max(s - upper)))
    if slack > 10.0 * tolerance:
        return f"a bound is violated by {slack:.1e}"
    active = duals > 0
    if np.any(active):
        mean_force = float(np.mean(duals[active] * np.sqrt(np.einsum("ij,ij->i", rij[active], rij[active]))))
        net = particle_force_sums(rij, duals, pi, pj, s.shape[0])
        inside = (s > lower + tolerance) & (s < upper - tolerance)
        worst = float(np.max(np.abs(net[inside]), initial=0.0)) / mean_force
        if worst > 1e-6:
            return f"forces do not balance (residual {worst:.1e} of the mean force)"
    return None


#: HiGHS options of a simplex solve from a given basis (a warm start, or the basis a vertex predicts): primal
#: simplex, since that basis is nearly primal feasible (its rows barely moved), and no scaling, since the rows are
#: O(1) already and scaling made warm solves slower (docs/calippso.md §5.3).
SIMPLEX_FROM_BASIS = {"solver": "simplex", "simplex_strategy": 4, "simplex_scale_strategy": 0}
#: HiGHS options of a re-solve after constraint generation added rows (docs/calippso.md §5.7): dual simplex, since the
#: optimal basis of the LP without them stays dual feasible when they join it as basic rows, and only they are
#: violated.
SIMPLEX_AFTER_CUTS = {"solver": "simplex", "simplex_strategy": 1, "simplex_scale_strategy": 0}


def _simplex_overrides(options: dict[str, Any] | None) -> dict[str, Any]:
    """The user's simplex options that override :data:`SIMPLEX_FROM_BASIS`."""
    return {k: v for k, v in (options or {}).items() if k in ("simplex_strategy", "simplex_scale_strategy")}


def warm_pivot_limit(n: int) -> int:
    """Primal simplex pivots allowed to a warm start before interior point takes over (N particles).

    1000 up to N = 1000, falling as 1/N to 200: about the break-even with one interior-point + crossover solve
    (docs/calippso.md §5.3); beyond it the cap only bounds the loss.
    """
    return max(200, min(1000, 1_000_000 // max(int(n), 1)))


def solve_lp(rij, sigma2, pi, pj, n, *, s_bound, pinned, inflation_bounds, tolerance=1e-9, options=None,
             iteration=-1, warm: LPBasis | None = None, solver: str = "hipo", threads: int = 1,
             crossover: bool = True, cuts: bool = False, interior: bool = False,
             interior_fallback: float | None = None, scale: float = 1.0) -> LPSolution:
    """Solve one CALiPPSO LP (minimise -Gamma) with HiGHS; raise :class:`SimulationError` unless optimal.

    ``s_bound`` is the per-component bound, ``pinned`` the particle whose displacement is fixed to 0 (or the
    :class:`~.constraints.Pins` of a container's LP: gauge pins and wall nodes, docs/containers.md §5),
    ``inflation_bounds`` the (lower, upper) bounds of the inflation factor Gamma. With ``warm`` (the basis of the
    previous LP) primal simplex starts from it: consecutive LPs share most of their active rows, so it re-optimises
    in a few pivots where interior point starts from scratch (docs/calippso.md §5.3). Failing that, or without
    ``warm``, a cold solve by ``solver`` (one of :data:`SOLVERS`, with ``threads`` HiGHS threads). An interior
    point is followed by HiGHS's crossover when ``crossover``; otherwise its near-active rows predict the vertex,
    which :func:`solve_active_set` certifies (method "vertex", docs/calippso.md §5.2); the fallback is primal
    simplex from the predicted vertex's basis (method "predicted", below N = :data:`PREDICTED_MAX_N`), then a second
    interior point with crossover. With ``cuts``, ``warm`` is the optimal basis of this LP without some of its rows
    (constraint generation, docs/calippso.md §5.7), re-optimised by dual simplex instead. On a non-optimal result
    the LP is solved once more with dual simplex (IPX after a simplex cold solve) before giving up
    (docs/calippso.md §6). With ``interior`` the interior point itself is returned (method "interior", no vertex,
    no basis: an intermediate step, docs/calippso.md §10) once its rows and bounds are checked; its duals are not a
    vertex's and certify nothing. Should it fail, the attempts above follow. With ``interior_fallback`` an
    uncertified vertex whose fallback would be a crossover (N >= :data:`PREDICTED_MAX_N`) returns its interior point as
    such a step instead, if that point's sqrt(Gamma) - 1 exceeds ``interior_fallback``: at N = 16384 a crossover ran
    for over 40 CPU-min, and at N = 1e4 they cost 400-1200 CPU-s each (docs/calippso.md §5.2). With ``scale`` < 1
    HiGHS gets the LP in Gamma - 1 (each row's right-hand side |r|^2 - sigma^2 computed here, not by HiGHS's
    cancellation) and in units of ``scale`` (:data:`NEAR_CONVERGED_SCALE`): the same LP, its solution mapped back, for
    LPs whose gains are below HiGHS's absolute tolerances (docs/calippso.md §5.8).
    """
    require(solver in SOLVERS, "solver", solver, f"must be one of {', '.join(SOLVERS)}")
    import highspy

    model = _Model.build(rij, sigma2, pi, pj, n, s_bound, pinned, inflation_bounds, scale)
    opts = _highs_options(tolerance, options, solver, threads)
    _limit_blas_threads(threads)
    failures = []
    predicted = None  # the basis an uncertified vertex predicts
    t0 = time.perf_counter()
    attempts = _attempts(opts, options, solver, crossover, n, model.ncol, warm, cuts)
    if interior:
        attempts.insert(0, ("interior", {**opts, "solver": "ipx" if solver == "simplex" else solver,
                                         "run_crossover": "off", "ipm_optimality_tolerance": VERTEX_IPM_TOLERANCE,
                                         **(options or {})}))
    for method, o in attempts:
        start = {"warm": warm, "predicted": predicted}.get(method)
        if method == "predicted" and start is None:
            continue  # no vertex was predicted
        h, failure = _run_highs(highspy, model, method, o, start, threads)
        if failure is not None:
            failures.append(failure)
            continue
        status = h.getModelStatus()
        if method == "interior":
            step = _interior_step(h, model, tolerance, t0, o["solver"], failures)
            if step is not None:
                return step
            continue
        if method == "vertex" and status not in (highspy.HighsModelStatus.kInfeasible,
                                                 highspy.HighsModelStatus.kUnbounded):
            # any interior point will do (even one HiGHS calls imprecise): the vertex is certified on its own
            vertex, predicted, problem = _certified_vertex(h, model, tolerance)
            if problem is None:
                vertex.solve_time, vertex.solver = time.perf_counter() - t0, o["solver"]
                return vertex
            failures.append(f"vertex ({h.modelStatusToString(status)}): {problem}")
            if interior_fallback is not None and "predicted" not in (m for m, _ in attempts):  # else a crossover
                step = _interior_step(h, model, tolerance, t0, o["solver"], failures)
                gain = None if step is None else math.sqrt(step.inflation) - 1.0
                if gain is not None and gain > interior_fallback:
                    return step
                if gain is not None:  # this LP may be the run's last, whose convergence test needs a vertex
                    failures.append(f"interior: sqrt(Gamma) - 1 = {gain:.1e}, not above {interior_fallback:.1e}")
            continue
        if status == highspy.HighsModelStatus.kOptimal:
            optimum, problem = _checked_optimum(h, model, tolerance)
            if problem is None:
                s, inflation, duals, basis = optimum
                return LPSolution(s, inflation, duals, time.perf_counter() - t0, method, basis, o["solver"],
                                  "; ".join(failures))
            failures.append(f"{method}: optimal status but {problem}")
            continue
        failures.append(f"{method}: {h.modelStatusToString(status)}")
        if method != "warm" and status in (highspy.HighsModelStatus.kInfeasible,
                                           highspy.HighsModelStatus.kUnbounded):
            break  # a property of the LP, not of the method
    raise SimulationError(
        f"CALiPPSO LP failed at iteration {iteration} ({len(rij)} pair rows, {model.ncol} columns): "
        + "; ".join(failures)
    )


@dataclass
class _Model:
    """One CALiPPSO LP as HiGHS gets it (``lp``), with what checking its solutions needs: the pair rows' right-hand
    side, the column bounds (N d displacement components, then Gamma) and the rows' keys. With ``scale`` < 1 HiGHS's
    unknowns are (s, Gamma - 1) / scale and its rows (A x - sigma^2) / scale <= (|r|^2 - sigma^2) / scale; the
    duals are the same (the cost of Gamma - 1 is that of Gamma), and :meth:`point` maps a solution back."""

    rij: np.ndarray
    sigma2: np.ndarray
    pi: np.ndarray
    pj: np.ndarray
    n: int
    s_bound: float
    pinned: int | Pins  # a sphere whose components are pinned, or the LP's fixed columns (constraints.Pins)
    inflation_bounds: tuple[float, float]
    lp: Any  # highspy.HighsLp
    rhs: np.ndarray
    lower: np.ndarray
    upper: np.ndarray
    keys: np.ndarray
    scale: float = 1.0

    @classmethod
    def build(cls, rij, sigma2, pi, pj, n, s_bound, pinned, inflation_bounds, scale: float = 1.0) -> _Model:
        dim = rij.shape[1]
        m = rij.shape[0]
        ncol = n * dim + 1
        start, index, value, rhs = constraint_rows(rij, sigma2, pi, pj, n)
        cost = np.zeros(ncol)
        cost[-1] = -1.0
        lower = np.full(ncol, -s_bound)
        upper = np.full(ncol, s_bound)
        fixed = as_pins(pinned, n, dim).columns
        lower[fixed] = 0.0
        upper[fixed] = 0.0
        lower[-1], upper[-1] = inflation_bounds
        model = cls(rij, sigma2, pi, pj, n, s_bound, pinned, inflation_bounds, None, rhs, lower, upper,
                    pair_keys(pi, pj, n), scale)
        shift = np.zeros(ncol)
        shift[-1] = model.gamma_offset
        model.lp = highs_model(cost, (lower - shift) / scale, (upper - shift) / scale, np.full(m, -np.inf),
                               model.highs_rhs() / scale, start, index, value)
        return model

    @property
    def dim(self) -> int:
        return self.rij.shape[1]

    @property
    def ncol(self) -> int:
        return self.lower.size

    @property
    def gamma_offset(self) -> float:
        """What HiGHS's last unknown lacks of Gamma: 1 in a scaled LP (Gamma - 1), else 0 (the LP as it is, bit for
        bit)."""
        return 0.0 if self.scale == 1.0 else 1.0

    def highs_rhs(self) -> np.ndarray:
        """The pair rows' right-hand side in HiGHS's unknowns, before the division by ``scale``: |r|^2 -
        sigma^2 in a scaled LP (a gap computed here, not a difference HiGHS forms), else |r|^2."""
        return self.rhs - self.gamma_offset * self.sigma2

    def point(self, sol) -> tuple[np.ndarray, float, np.ndarray]:
        """A HiGHS solution's (s (N, d), Gamma, every row's slack |r|^2 - A x) in the LP's own units."""
        x = np.asarray(sol.col_value) * self.scale
        x[-1] += self.gamma_offset
        slack = self.highs_rhs() - np.asarray(sol.row_value) * self.scale
        return x[:-1].reshape(self.n, self.dim).copy(), float(x[-1]), slack

    def problem(self, s, inflation, duals, tolerance) -> str | None:
        """What is wrong with a solution (:func:`_vertex_problem`), or None."""
        shape = (self.n, self.dim)
        return _vertex_problem(self.rij, self.sigma2, self.pi, self.pj, s, inflation, duals,
                               self.lower[:-1].reshape(shape), self.upper[:-1].reshape(shape), tolerance)


def _attempts(opts, options, solver: str, crossover: bool, n: int, ncol: int, warm: LPBasis | None,
              cuts: bool) -> list[tuple[str, dict[str, Any]]]:
    """The solves :func:`solve_lp` tries in turn, each ``(method, HiGHS options)``: a warm start if there is a basis
    to start from, the cold solve by ``solver`` (an uncertified vertex falling back to primal simplex from its
    predicted basis), then the other kind of solver."""
    if solver == "simplex":
        attempts = [("simplex", opts), ("ipm", {**opts, "solver": "ipx"})]
    else:
        attempts = [("ipm", opts), ("simplex", {**opts, "solver": "simplex"})]
        if not crossover:
            # below PREDICTED_MAX_N an uncertified vertex falls back to primal simplex from the basis it
            # predicts, not to a second interior point
            attempts[:0] = [("vertex", {**opts, "run_crossover": "off",
                                        "ipm_optimality_tolerance": VERTEX_IPM_TOLERANCE, **(options or {})}),
                            ("predicted", {**opts, **SIMPLEX_FROM_BASIS, **_simplex_overrides(options),
                                           "simplex_iteration_limit": PREDICTED_PIVOT_LIMIT})]
            if n >= PREDICTED_MAX_N:
                del attempts[1]
    if warm is not None and warm.cols.size == ncol and warm.keys.size:
        # beyond warm_pivot_limit(N) pivots interior point is cheaper: give up and fall back to it
        limit = min(warm_pivot_limit(n), opts.get("simplex_iteration_limit", 2**31 - 1))
        attempts.insert(0, ("warm", {**opts, **(SIMPLEX_AFTER_CUTS if cuts else SIMPLEX_FROM_BASIS),
                                     "simplex_iteration_limit": limit, **_simplex_overrides(options)}))
    return attempts


def _run_highs(highspy, model: _Model, method: str, options: dict[str, Any], start: LPBasis | None, threads: int):
    """Run HiGHS on the LP with ``options``, from the basis ``start`` if given: ``(the Highs object, None)``, or
    ``(it, why it did not solve)``."""
    h = highspy.Highs()
    for key, val in options.items():
        if h.setOptionValue(key, val) != highspy.HighsStatus.kOk:
            raise InputError(f"solver_options: HiGHS rejected option {key}={val!r}")
    h.passModel(model.lp)
    if start is not None and h.setBasis(_warm_basis(start, model.keys, highspy)) == highspy.HighsStatus.kError:
        return h, f"{method}: basis rejected"
    if h.run() == highspy.HighsStatus.kError and h.getModelStatus() == highspy.HighsModelStatus.kNotset:
        # e.g. a thread count other than the process's first solve's: HiGHS's scheduler keeps that one
        return h, f"{method}: HiGHS returned an error before solving (threads={threads})"
    return h, None


def _certified_vertex(h, model: _Model, tolerance: float):
    """The vertex an interior point (without crossover) heads for, certified by :func:`solve_active_set`:
    ``(the vertex, the predicted vertex's basis, None)``, or ``(None or the vertex, the predicted basis or None, what
    is wrong)``; the predicted basis is the fallback's start."""
    n, dim, pinned, keys = model.n, model.dim, model.pinned, model.keys
    sol = h.getSolution()
    vertex = guess = predicted = None
    why: list[str] = []
    if sol.value_valid and sol.dual_valid:
        s_ipm, _, slack = model.point(sol)
        duals = np.maximum(-np.asarray(sol.row_dual), 0.0)
        guess = interior_point_prediction(model.pi, model.pj, n, dim, model.sigma2, duals, slack, s_ipm,
                                          np.asarray(sol.col_dual)[:-1].reshape(n, dim), model.s_bound, pinned)
        if guess is not None:
            guess[2].ravel()[as_pins(pinned, n, dim).columns] = 0
            vertex = solve_active_set(model.rij, model.sigma2, model.pi, model.pj, n, guess[0], guess[1],
                                      s_bound=model.s_bound, pinned=pinned, inflation_bounds=model.inflation_bounds,
                                      rattler_s=s_ipm, fixed=guess[2], max_pivots=MAX_PIVOTS, why=why)
        else:
            why.append("no isostatic prediction")
    if guess is not None:  # the fallback's start: the predicted vertex as a HiGHS basis
        predicted = _vertex_basis(LPSolution(s_ipm, 1.0, np.isin(keys, guess[0]).astype(float), 0.0, ""),
                                  guess[1], guess[2], pinned, keys)
    if vertex is None:
        why_not = "; ".join(why) or "no valid solution"
        return None, predicted, f"its near-active rows are not a certified vertex ({why_not})"
    problem = model.problem(vertex.s, vertex.inflation, vertex.duals, tolerance)
    if problem is None:
        vertex.basis = _vertex_basis(vertex, guess[1], vertex.held, pinned, keys)  # its bounds after the pivots
        vertex.method = "vertex+" + vertex.method.partition("+")[2]  # + its pivots and how
    return vertex, predicted, problem


def _interior_step(h, model: _Model, tolerance: float, t0: float, solver: str, failures: list[str]):
    """The interior point of a solve without crossover as an intermediate step (:func:`_interior_point`), timed
    from ``t0`` and carrying the ``failures`` before it; None, with what is wrong appended to ``failures``, if it is
    not one."""
    step, problem = _interior_point(h, model, tolerance)
    if problem is not None:
        failures.append(f"interior ({h.modelStatusToString(h.getModelStatus())}): {problem}")
        return None
    step.solve_time, step.solver, step.failed = time.perf_counter() - t0, solver, "; ".join(failures)
    return step


def _interior_point(h, model: _Model, tolerance: float):
    """The interior point of a solve without crossover as an intermediate step: ``(the solution, None)``, or ``(None,
    what is wrong)``. Only its primal part is checked (every row and bound to 10 ``tolerance``, as a vertex's): the
    step must keep every row, and its duals are never used as forces."""
    import highspy

    if h.getModelStatus() != highspy.HighsModelStatus.kOptimal:
        return None, "not optimal"
    sol = h.getSolution()
    if not sol.value_valid:
        return None, "no valid solution"
    s, inflation, _ = model.point(sol)
    problem = model.problem(s, inflation, np.zeros(model.rhs.size), tolerance)  # zero duals: primal only
    if problem is not None:
        return None, problem
    duals = np.maximum(-np.asarray(sol.row_dual), 0.0) if sol.dual_valid else np.zeros(model.rhs.size)
    return LPSolution(s, inflation, duals, 0.0, "interior"), None


def _checked_optimum(h, model: _Model, tolerance: float):
    """The solution of a solve HiGHS calls optimal, checked once more: ``((s, Gamma, duals, basis or None), None)``,
    or ``(None, what is wrong)``."""
    sol = h.getSolution()
    s, inflation, _ = model.point(sol)
    # minimisation with <= rows: HiGHS row duals are <= 0; lambda = -dual >= 0
    duals = np.maximum(-np.asarray(sol.row_dual), 0.0)
    problem = model.problem(s, inflation, duals, tolerance)
    if problem is not None:
        return None, problem
    basis = None
    hb = h.getBasis()
    if hb.valid:
        order = np.argsort(model.keys)
        basis = LPBasis(model.keys[order], _status_codes(hb.row_status)[order], _status_codes(hb.col_status))
    return (s, inflation, duals, basis), None
