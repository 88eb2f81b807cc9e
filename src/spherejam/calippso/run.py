"""CALiPPSO: jam a hard-sphere packing by iterative linear programming, with contact forces from the LP duals.

Artiaco, Díaz Hernández Rojas, Parisi, Ricci-Tersenghi, Phys. Rev. E 106, 055310 (2022); the rules below follow the
reference code CALiPPSO.jl v0.2.2 as described in ``docs/calippso.md`` (cited as "docs §x").

**One iteration** solves, with HiGHS (a vertex solution, so the duals are exact: see "Solver" below),

    maximise Gamma  subject to  |r_ij|^2 + 2 r_ij . (s_i - s_j) >= Gamma sigma_ij^2   for pairs with r_ij < l,
                                -s_bound <= s_{i,mu} <= s_bound,   s_pinned = 0,   1 <= Gamma <= Gamma_max,

then moves r_i <- r_i + s_i and inflates every diameter by sqrt(Gamma). Lengths inside are in units of the
*initial* largest diameter; ``R`` below is the current largest radius. It stops when sqrt(Gamma) - 1 <=
``gamma_tolerance`` and max |s_{i,mu}| over non-rattlers <= ``displacement_tolerance`` * (current largest diameter).

**Cutoff l and bound s_bound** (docs §1.3), chosen from sqrt(Gamma) - 1 of the previous LP:
regime 1 (> 5e-4): l = l0, s_bound = (l/2 - max(1.5, sqrt(Gamma_prev)) R)/sqrt(d); regime 2 (> 1e-5): s_bound =
0.1R; regime 3: l = min(2.7R, l0), s_bound = 0.01R. Deviations, all for safety or speed:

* ``Gamma_max`` = ((l - 2 sqrt(d) s_bound) / 2R)^2 bounds Gamma. A pair outside l (or a non-minimum image, as
  l <= L/2) can approach by at most 2 sqrt(d) s_bound, so with this bound *no* pair can overlap after the step --
  a proof where the reference has a heuristic. The bound is never active near convergence.
* When a non-rattler ends an LP at its s bound (the bound, not the contacts, stopped it -- the reference's
  "non-isostatic before convergence" symptom), the next bound is doubled, up to 0.1R; once no bound stops a
  stable particle it is halved back towards the regime's value. With the fixed regime-3 bound of 0.01R a
  fast-compressed LS start otherwise crawls for hundreds of iterations.
* Regime 2 uses l = min(2.7R, l0) like regime 3, not the reference's 4R: with Gamma_max the cutoff no longer
  carries the safety argument, and 4R made the LP 3.5 times larger for nothing (same trajectory, measured).
* l is enlarged (never s_bound driven <= 0) when regime 1 would give s_bound < 0.1 R / sqrt(d), and in regimes 2-3
  when l0 has fallen below the needed margin; l is capped at L/2 (an error if the box is then too small).
* The first iteration's sqrt(Gamma_prev) (the reference's fixed 1.01, always regime 1) is by default estimated as
  1 + the median over particles of the nearest-neighbour gap h = r/sigma - 1, so a compressed start (e.g. LS at
  p >= 1e5) begins in regime 2 or 3 with a small LP instead of a 4R cutoff.
* The pinned particle (removing the d translations) is moved off a particle that the LP finds to be a rattler;
  otherwise a free rigid translation of the stable network would stall the displacement test.
* After each step the closest pair at the new positions is checked; if round-off in the solver left it overlapping,
  sqrt(Gamma) is reduced so that it just touches (recorded as ``overlap_correction``; more than 1e-8 is an error).

**Forces.** With lambda_ij >= 0 the dual of pair row ij, KKT gives sum_ij lambda_ij sigma_ij^2 = 1 and, for a
particle whose bounds are not active, sum_j lambda_ij r_ij = 0: the contact force on i from j is
f_ij ∝ lambda_ij r_ij. A pair is a contact iff lambda_ij sigma_ij^2 > ``zero_force`` / N (scale free: the shares
sum to 1 over ~dN/2 contacts). Rattlers: particles outside the (d+1)-core of the contact graph (iterated).
After convergence one more LP with s unbounded (|s| <= R only, so it stays bounded) and Gamma free is solved at the
final positions without moving anything (docs §2.3), so no bound carries force; contacts and forces come from it.

**Solver.** The first LP, and every LP in regime 1 (large steps, many rows change), is solved from scratch by the
chosen HiGHS solver (``solver``): by default HiPO from N = :data:`AUTO_HIPO_MIN_N` on and IPX with crossover
below it (``solver="auto"``; HiPO is HiGHS's interior point with a sparse direct factorisation; it
scales about as N^1.5 where IPX grows as N^2.5-N^3.9), IPX, or dual simplex, named explicitly because with
highspy-extras installed HiGHS's "ipm" silently means HiPO. An interior point is not a vertex, and HiGHS's
crossover to one costs as much as the interior point itself at N = 4096. Instead the interior point's near-active
rows (:func:`interior_point_prediction`) are taken as the predicted vertex and certified by
:func:`solve_active_set` (method "vertex": exact duals, primal and dual feasibility checked); only when that
fails (a wrong prediction beyond a few pivots, a degenerate vertex) does HiGHS cross over (``crossover=True``
always does). Components held at their s bound are part of the prediction (their multipliers are checked too).
The interior point is run to an optimality tolerance of :data:`VERTEX_IPM_TOLERANCE` so that the active rows
separate clearly. From regime 2 on, consecutive LPs share almost all rows and most of the active set, so primal
simplex (unscaled) starts from the previous LP's basis (rows matched by pair, new rows basic): tens to a
few hundred pivots instead of a full interior-point solve, 3-10 times faster at N = 1024 (``warm_start=False``
turns it off). Beyond :func:`warm_pivot_limit` pivots (~1000 at N = 1024, falling as 1/N to 200: a pivot costs
~3 ms at N = 1024 but ~50 ms at N = 4096) it gives up for interior point, and after k failed warm starts in a row
the next 2^k - 1 LPs skip it (a deterministic back-off, so runs stay reproducible). From N =
:data:`WARM_START_MAX_N` on it is not tried at all: there the warm starts needed 1600-2000+ pivots, more than a
cold solve costs, and the active-set shortcut (below) takes its place.
The certified vertex carries its basis, so warm starts follow it as they follow a crossover. HiGHS (and HiPO's
BLAS) use one thread unless ``threads`` says otherwise (HiGHS fixes its thread count at the first solve of a
process). All give an optimal vertex within the same tolerances; where the optimum is degenerate they may pick
different vertices, so trajectories can differ (the jammed state from the reference's LS input
does not). Every solution HiGHS calls optimal is checked here too (rows, bounds, force balance): simplex was seen
to return "optimal" with a row violated by 3e-5, which would have become an overlap; such a solve counts as failed.

**Active-set shortcut.** When the previous LP was isostatic, its contact network predicts the next optimal vertex;
:func:`solve_active_set` solves that square system by sparse LU, pivots (primal simplex) while a dual is negative,
and returns the vertex only if it is certified optimal (primal and dual feasible). Otherwise HiGHS solves the LP.
It is tried for the final force LP (certified duals: force balance to ~1e-14) and, in the main loop, only where no
warm start is available (regime 1, ``warm_start=False``, N >= :data:`WARM_START_MAX_N`): at smaller N a
warm-started HiGHS solve is faster on average, because the shortcut's failed attempts (an active-set change
beyond a few pivots) cost more than its successes save.
``active_set=False`` turns it off (tests check both agree).

**Which starts converge quickly** (measured, d = 3). Packings at their own high pressure: an MLS output at
p = 1e12 takes 7 LPs at N = 2048 (phi moves by ~1e-9), and an LS + MLS packing at p = 1e5 takes 11 LPs at N = 1024.
From p = 1e5 starts at N >= 2048 the loop creeps instead: each LP gains sqrt(Gamma) - 1 ~ 3e-7 and moves stable
particles by ~3e-3 diameters although its vertex is isostatic with no bound active, while the contact network keeps
changing and phi keeps rising (at N = 2048 by more than d phi / p after 36 LPs). That is the LP densifying the
packing along nearly floppy paths, not a solver artefact: the reference's first large step, interior-point
solutions without crossover and a shrinking trust region (halved after a step that did not contract) crept alike.
Certify high-pressure packings; the workflow certifies MLS outputs at p = 1e12.

**Failures.** Every LP status is checked. A non-optimal warm-started solve falls back to interior point; a
non-optimal interior-point solve is retried once with dual simplex; a failure of that too raises
:class:`SimulationError` (status, iteration, LP size). An infeasible LP cannot happen from an overlap-free start
(s = 0, Gamma = 1 is feasible), so it is reported as an error too. Overlapping inputs are rejected up front with
:class:`OverlapError`.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ..core.errors import InputError, OverlapError, SimulationError, require
from ..core.neighbours import pairs_within
from ..core.packing import DEFAULT_OVERLAP_TOLERANCE, Packing
from ..core.validation import LP_SOLVERS
from ..engines.driver import History, Progress
from .constraints import constraint_rows, pair_vectors, pairs_in_cutoff, particle_force_sums, row_excess

#: Default regime thresholds on sqrt(Gamma_prev) - 1 (docs §1.3).
REGIME_THRESHOLDS = (5e-4, 1e-5)
#: s_bound of regimes 2 and 3 in units of the largest radius R (docs §1.3).
REGIME_S_BOUNDS = (0.1, 0.01)
#: Cutoff of regimes 2 and 3 in units of R (docs §1.3).
REGIME_CUTOFFS = (2.7, 2.7)
#: Smallest regime-1 bound sqrt(d) s_bound / R accepted before the cutoff is enlarged instead.
MIN_FAR_BOUND = 0.1
#: Cap (units of R) of the doubled s_bound after a stable particle hit its bound.
MAX_ESCALATED_BOUND = 0.1
#: Largest correction of sqrt(Gamma) tolerated for solver round-off before the step is declared broken.
MAX_OVERLAP_CORRECTION = 1e-8
CHECKPOINT_KIND = "calippso"
#: History codes of how an LP was solved ("vertex": interior point without crossover, its vertex certified by
#: :func:`solve_active_set`; "ipm": interior point + HiGHS crossover).
METHOD_CODES = {"ipm": 0, "simplex": 1, "active-set": 2, "warm": 3, "vertex": 4}
#: The HiGHS solvers an LP can be sent to: HiPO (sparse-direct interior point, needs highspy-extras), IPX
#: (interior point), dual simplex.
SOLVERS = LP_SOLVERS
#: Smallest N that ``solver="auto"`` sends to HiPO with a certified vertex; below it IPX + crossover was faster
#: (N = 1024: 2.6 s against 5.0 s per run; N = 2048: 116 s against 137 s; docs/cluster.md).
AUTO_HIPO_MIN_N = 4096
#: History codes of which HiGHS solver produced an LP's solution ("none": the active-set solve alone, no HiGHS).
SOLVER_CODES = {"none": 0, "hipo": 1, "ipx": 2, "simplex": 3}
#: Smallest N whose LPs are never warm-started: from N = 4096 on warm starts needed 1600-2000+ primal simplex
#: pivots (50 ms each at 4096, 0.5 s at 10^4), more than a cold HiPO solve costs (docs/cluster.md).
WARM_START_MAX_N = 4096
#: IPM optimality tolerance of an interior-point solve whose vertex is certified instead of crossed over: at 1e-9
#: the near-active rows of HiPO's point were ambiguous (one contact swapped at N = 1024), at 1e-12 they separate
#: by two decades for +3 iterations (measured, docs/cluster.md).
VERTEX_IPM_TOLERANCE = 1e-12


# --- result -----------------------------------------------------------------------------------------------------


@dataclass
class CalippsoResult:
    """A CALiPPSO run.

    Attributes
    ----------
    packing : Packing
        The jammed packing with ACTUAL diameters (same box and length unit as the input); metadata
        ``algorithm="calippso"``, ``parameters``, ``counters``.
    converged : bool
        Both tolerances met before ``max_iterations``.
    iterations : int
        LPs solved in the main loop (the final force LP not included).
    history : dict of arrays, one row per iteration
        ``sqrt_gamma_minus_1``, ``max_displacement`` (non-rattlers, units of the largest diameter),
        ``max_displacement_all``, ``phi``, ``n_constraints``, ``solve_time`` (s), ``cpu_time`` (CPU s of this
        process for the LP, incl. a failed active-set attempt: the figure to compare on a busy machine), ``cutoff``
        and ``s_bound`` (units of the largest diameter), ``regime``, ``method`` (:data:`METHOD_CODES`), ``solver``
        (:data:`SOLVER_CODES`), ``n_contacts``,
        ``n_rattlers``, ``isostatic``,
        ``overlap_correction``.
    pairs : (K, 2) int array
        Contacts i < j among non-rattlers (a contact = pair with a positive dual, see module docstring).
    forces : (K,) float array
        Contact force magnitudes f_ij = lambda_ij r_ij, divided by their mean (so mean 1).
    contact_vectors : (K, d) float array
        Unit vectors (r_i - r_j)/|r_i - r_j| (minimum image): the force on i from j is ``forces * contact_vectors``.
    rattlers : (N,) bool array
        Particles outside the (d+1)-core of the contact graph.
    n_contacts : int
        Contacts among non-rattlers, N_c.
    isostatic : bool
        N_c == d (N_s - 1) + 1 with N_s non-rattlers (one state of self-stress).
    force_balance_residual : float
        max over non-rattlers of |sum_j f_ij n_ij|, in units of the mean contact force (dimensionless).
    gaps : (G,) float array
        Normalised gaps h = r_ij / sigma_ij - 1 of the non-contact pairs among non-rattlers with h < ``gap_range``.
    gap_pairs : (G, 2) int array
        The pairs of ``gaps``.
    phi_initial : float
        Packing fraction of the input.
    wall_time : float
        Seconds for the whole call.
    fine_tuned : bool
        Forces come from the final unbounded LP (False: it failed and the last main-loop LP's duals are used).
    """

    packing: Packing
    converged: bool
    iterations: int
    history: dict[str, np.ndarray]
    pairs: np.ndarray
    forces: np.ndarray
    contact_vectors: np.ndarray
    rattlers: np.ndarray
    n_contacts: int
    isostatic: bool
    force_balance_residual: float
    gaps: np.ndarray
    gap_pairs: np.ndarray
    phi_initial: float
    wall_time: float
    fine_tuned: bool
    counters: dict[str, Any] = field(default_factory=dict)

    @property
    def n_rattlers(self) -> int:
        return int(np.count_nonzero(self.rattlers))

    @property
    def n_stable(self) -> int:
        return int(self.rattlers.size - self.n_rattlers)

    @property
    def phi(self) -> float:
        return self.packing.phi

    def summary(self) -> dict[str, float]:
        """Flat scalars for a results table (flags as 0/1)."""
        return {
            "phi": self.packing.phi,
            "delta_phi": self.packing.phi - self.phi_initial,
            "iterations": float(self.iterations),
            "converged": float(self.converged),
            "is_isostatic": float(self.isostatic),
            "rattler_fraction": self.n_rattlers / self.rattlers.size,
            "force_balance_residual": self.force_balance_residual,
            "n_contacts": float(self.n_contacts),
            "n_stable": float(self.n_stable),
            "isostatic_excess": float(self.n_contacts - (self.packing.dim * (self.n_stable - 1) + 1)),
            "wall_time": self.wall_time,
        }


# --- the LP ---------------------------------------------------------------------------------------------------------


@dataclass
class LPBasis:
    """A HiGHS basis keyed by pair, so that the next LP (slightly different rows) can start from it.

    ``keys`` are the sorted i*N + j of the rows, ``rows`` their HiGHS basis status codes in that order, ``cols``
    the status codes of the d N + 1 columns.
    """

    keys: np.ndarray
    rows: np.ndarray
    cols: np.ndarray


@dataclass
class LPSolution:
    """Solution of one LP: displacements s (N, d), Gamma, pair duals lambda >= 0, solve time, method used, the
    final basis (None if HiGHS did not provide one) and the HiGHS solver used."""

    s: np.ndarray
    gamma: float
    duals: np.ndarray
    solve_time: float
    method: str
    basis: LPBasis | None = None
    solver: str = "none"  # the HiGHS solver behind it (SOLVER_CODES)
    failed: str = ""  # the attempts that failed before this one (e.g. an uncertified vertex before crossover)


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
    # alien only when needed: HiGHS's alien-basis repair factorises once more (~70 ms per LP at N = 1024, 15 % of
    # a warm solve); a square basis that is singular is still caught, as rank deficiency, when simplex factorises it
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
    free[pinned * dim:(pinned + 1) * dim] = False
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


def _vertex_problem(rij, sigma2, pi, pj, s, gamma, duals, lower, upper, tolerance) -> str | None:
    """Check a solution HiGHS calls optimal ourselves; a description of what is wrong, or None.

    Primal: every row and bound holds to 10 ``tolerance`` (sigma^2 units). Dual: the pair forces balance (to 1e-6
    of the mean force) on every displacement component strictly inside its bounds. A simplex run on an
    ill-conditioned basis was seen to report "optimal" with a row violated by 3e-5 (its row activities disagreed
    with A x), which would have become an overlap.
    """
    excess = float(row_excess(rij, sigma2, pi, pj, s, gamma))
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


def warm_pivot_limit(n: int) -> int:
    """Primal simplex pivots allowed to a warm start before interior point takes over (N particles).

    Break-even with one interior-point + crossover solve, measured (one core): ~600-800 pivots at N = 1024
    (3 ms each vs 1.7 s) and at N = 4096 (50-65 ms each vs 45-60 s); beyond that the cap only bounds the loss.
    """
    return max(200, min(1000, 1_000_000 // max(int(n), 1)))


def solve_lp(rij, sigma2, pi, pj, n, *, s_bound, pinned, gamma_bounds, tolerance=1e-9, options=None,
             iteration=-1, warm: LPBasis | None = None, solver: str = "hipo", threads: int = 1,
             crossover: bool = True) -> LPSolution:
    """Solve one CALiPPSO LP (minimise -Gamma) with HiGHS; raise :class:`SimulationError` unless optimal.

    ``s_bound`` is the per-component bound, ``pinned`` the particle whose displacement is fixed to 0,
    ``gamma_bounds`` the (lower, upper) bounds of Gamma. With ``warm`` (the basis of the previous LP) primal simplex
    starts from it: consecutive LPs share most of their active rows, so it re-optimises in a few pivots where
    interior point starts from scratch. Failing that, or without ``warm``, a cold solve by ``solver`` (one of
    :data:`SOLVERS`, with ``threads`` HiGHS threads). An interior point is followed by HiGHS's crossover when
    ``crossover``; otherwise its near-active rows predict the vertex, which :func:`solve_active_set` certifies
    (method "vertex"), and crossover is the fallback. On a non-optimal result the LP is solved once more with dual
    simplex (IPX after a simplex cold solve) before giving up.
    """
    require(solver in SOLVERS, "solver", solver, f"must be one of {', '.join(SOLVERS)}")
    import highspy

    dim = rij.shape[1]
    m = rij.shape[0]
    ncol = n * dim + 1
    start, index, value, rhs = constraint_rows(rij, sigma2, pi, pj, n)
    lp = highspy.HighsLp()
    lp.num_col_ = ncol
    lp.num_row_ = m
    cost = np.zeros(ncol)
    cost[-1] = -1.0
    lower = np.full(ncol, -s_bound)
    upper = np.full(ncol, s_bound)
    lower[pinned * dim:(pinned + 1) * dim] = 0.0
    upper[pinned * dim:(pinned + 1) * dim] = 0.0
    lower[-1], upper[-1] = gamma_bounds
    inf = highspy.kHighsInf
    lower[~np.isfinite(lower)] = -inf
    upper[~np.isfinite(upper)] = inf
    lp.col_cost_ = cost
    lp.col_lower_ = lower
    lp.col_upper_ = upper
    lp.row_lower_ = np.full(m, -inf)
    lp.row_upper_ = rhs
    lp.a_matrix_.format_ = highspy.MatrixFormat.kRowwise
    lp.a_matrix_.num_col_ = ncol
    lp.a_matrix_.num_row_ = m
    lp.a_matrix_.start_ = start
    lp.a_matrix_.index_ = index
    lp.a_matrix_.value_ = value
    keys = pi.astype(np.int64) * n + pj

    opts = _highs_options(tolerance, options, solver, threads)
    _limit_blas_threads(threads)
    if solver == "simplex":
        attempts = [("simplex", opts), ("ipm", {**opts, "solver": "ipx"})]
    else:
        attempts = [("ipm", opts), ("simplex", {**opts, "solver": "simplex"})]
        if not crossover:
            attempts.insert(0, ("vertex", {**opts, "run_crossover": "off",
                                           "ipm_optimality_tolerance": VERTEX_IPM_TOLERANCE, **(options or {})}))
    if warm is not None and warm.cols.size == ncol and warm.keys.size:
        # primal simplex: the carried-over vertex is nearly primal feasible (the rows barely moved)
        # no scaling: the rows are O(1) already, and scaling made warm solves 3-5 times longer (measured). Beyond
        # warm_pivot_limit(N) pivots interior point is cheaper: give up and fall back to it
        limit = min(warm_pivot_limit(n), opts.get("simplex_iteration_limit", 2**31 - 1))
        warm_opts = {"solver": "simplex", "simplex_strategy": 4, "simplex_scale_strategy": 0,
                     "simplex_iteration_limit": limit}
        attempts.insert(0, ("warm", {**opts, **warm_opts, **{k: v for k, v in (options or {}).items()
                                                             if k in ("simplex_strategy", "simplex_scale_strategy")}}))
    failures = []
    t0 = time.perf_counter()
    for method, o in attempts:
        h = highspy.Highs()
        for key, val in o.items():
            if h.setOptionValue(key, val) != highspy.HighsStatus.kOk:
                raise InputError(f"solver_options: HiGHS rejected option {key}={val!r}")
        h.passModel(lp)
        if method == "warm" and h.setBasis(_warm_basis(warm, keys, highspy)) == highspy.HighsStatus.kError:
            failures.append("warm: basis rejected")
            continue
        if h.run() == highspy.HighsStatus.kError and h.getModelStatus() == highspy.HighsModelStatus.kNotset:
            # e.g. a thread count other than the process's first solve's: HiGHS's scheduler keeps that one
            failures.append(f"{method}: HiGHS returned an error before solving (threads={threads})")
            continue
        status = h.getModelStatus()
        if method == "vertex" and status not in (highspy.HighsModelStatus.kInfeasible,
                                                 highspy.HighsModelStatus.kUnbounded):
            # any interior point will do (even one HiGHS calls imprecise): the vertex is certified on its own
            sol = h.getSolution()
            vertex = None
            if sol.value_valid and sol.dual_valid:
                slack = rhs - np.asarray(sol.row_value)
                duals = np.maximum(-np.asarray(sol.row_dual), 0.0)
                s_ipm = np.asarray(sol.col_value)[:-1].reshape(n, dim)
                guess = interior_point_prediction(pi, pj, n, dim, sigma2, duals, slack, s_ipm,
                                                  np.asarray(sol.col_dual)[:-1].reshape(n, dim), s_bound)
                if guess is not None:
                    guess[2][pinned] = 0
                    vertex = solve_active_set(rij, sigma2, pi, pj, n, guess[0], guess[1], s_bound=s_bound,
                                              pinned=pinned, gamma_bounds=gamma_bounds, rattler_s=s_ipm,
                                              fixed=guess[2])
            problem = "its near-active rows are not a certified vertex" if vertex is None else _vertex_problem(
                rij, sigma2, pi, pj, vertex.s, vertex.gamma, vertex.duals, lower[:-1].reshape(n, dim),
                upper[:-1].reshape(n, dim), tolerance)
            if problem is None:
                vertex.basis = _vertex_basis(vertex, guess[1], guess[2], pinned, keys)
                vertex.solve_time, vertex.solver = time.perf_counter() - t0, o["solver"]
                vertex.method = "vertex+" + vertex.method.split("+")[1]  # + its pivots
                return vertex
            failures.append(f"vertex ({h.modelStatusToString(status)}): {problem}")
            continue
        if status == highspy.HighsModelStatus.kOptimal:
            sol = h.getSolution()
            x = np.asarray(sol.col_value)
            # minimisation with <= rows: HiGHS row duals are <= 0; lambda = -dual >= 0
            duals = np.maximum(-np.asarray(sol.row_dual), 0.0)
            s = x[:-1].reshape(n, dim)
            problem = _vertex_problem(rij, sigma2, pi, pj, s, float(x[-1]), duals, lower[:-1].reshape(n, dim),
                                      upper[:-1].reshape(n, dim), tolerance)
            if problem is not None:
                failures.append(f"{method}: optimal status but {problem}")
                continue
            basis = None
            hb = h.getBasis()
            if hb.valid:
                order = np.argsort(keys)
                basis = LPBasis(keys[order], _status_codes(hb.row_status)[order], _status_codes(hb.col_status))
            return LPSolution(s.copy(), float(x[-1]), duals, time.perf_counter() - t0, method, basis, o["solver"],
                              "; ".join(failures))
        failures.append(f"{method}: {h.modelStatusToString(status)}")
        if method != "warm" and status in (highspy.HighsModelStatus.kInfeasible,
                                           highspy.HighsModelStatus.kUnbounded):
            break  # a property of the LP, not of the method
    raise SimulationError(
        f"CALiPPSO LP failed at iteration {iteration} ({m} pair rows, {ncol} columns): " + "; ".join(failures)
    )


def interior_point_prediction(pi, pj, n, dim, sigma2, duals, slack, s=None, col_dual=None, s_bound=None):
    """The vertex an interior point of the LP is heading for: ``(contact keys, rattler mask, fixed)``, or None.

    On the central path lambda_k * slack_k is the same small number for every row, so the score
    (lambda_k sigma_k^2 M) / (slack_k / sigma_k^2) (M rows; both factors dimensionless, the first ~1 on an active
    row) grows without bound on the optimal active set and vanishes off it. An s component gets the same kind of
    score from its bound multiplier |col_dual| and its distance to the bound (with ``s``, ``col_dual`` and
    ``s_bound``): those scoring > 1 are predicted held at the bound (``fixed``: -1 / +1, else 0). Rows scoring > 1
    and the held components (as contacts with a wall) give the contact graph and its rattlers (outside the
    (d+1)-core); of the rows among stable particles the d (N_s - 1) + 1 - (held components) with the highest score
    are the predicted vertex, for :func:`solve_active_set` to certify.
    """
    from ..analysis.contacts import rattler_mask

    m = len(pi)
    score = duals * sigma2 * m / np.maximum(slack / sigma2, 1e-300)
    near = score > 1.0
    fixed = np.zeros((n, dim), dtype=np.int8)
    if s is not None and s_bound is not None and math.isfinite(s_bound):
        # scales of a bound multiplier (~ 2 sigma lambda, A's entries are 2 r) and of a distance to the bound (s_bound)
        sigma = math.sqrt(float(np.median(sigma2)))
        distance = np.maximum(s_bound - np.abs(s), 0.0) / s_bound
        bound_score = np.abs(col_dual) * m * sigma / 2.0 / np.maximum(distance, 1e-300)
        fixed = np.where(bound_score > 1.0, np.sign(s), 0).astype(np.int8)
    wall_i = np.nonzero(fixed)[0]
    ci = np.concatenate([pi[near], wall_i])
    cj = np.concatenate([pj[near], np.full(wall_i.size, n)])  # node n: the wall of the s bounds, never a rattler
    rattler = rattler_mask(n + 1, ci, cj, dim + 1)[:n]
    fixed[rattler] = 0
    n_stable = n - int(np.count_nonzero(rattler))
    nu = dim * (n_stable - 1) + 1 - int(np.count_nonzero(fixed))
    stable = np.flatnonzero(~rattler[pi] & ~rattler[pj])
    if n_stable < dim + 2 or nu < 1 or stable.size < nu:
        return None
    top = stable[np.argsort(-score[stable], kind="stable")[:nu]]
    return np.sort(pi[top] * n + pj[top]), rattler, fixed


def solve_active_set(rij, sigma2, pi, pj, n, contact_keys, rattler, *, s_bound, pinned, gamma_bounds,
                     feasibility=1e-12, max_pivots=None, rattler_s=None, fixed=None) -> LPSolution | None:
    """Solve the LP from a predicted active set by primal simplex pivots; None if that does not work out.

    The prediction is the isostatic contact network of the previous LP (``contact_keys`` = i*N + j of its contacts,
    ``rattler`` its rattlers). Its rows, as equalities, form a square system in the displacements of the stable,
    non-pinned particles and Gamma (N_c = d(N_s - 1) + 1 unknowns); a sparse LU gives the vertex and, with the
    transpose, the duals. While a dual is negative, that contact is released along the edge that keeps the others
    tight and the first pair row to close enters (the primal simplex method with the exact ratio test; every
    pivot refactorises). The vertex is returned only when it is *certified optimal*: all duals > 0, all rows and
    bounds satisfied (to ``feasibility``, absolute, sigma^2 units), i.e. primal and dual feasible with complementary
    slackness. Rattlers start from ``rattler_s`` ((N, d), e.g. an interior point, whose rattlers sit inside their
    cages; default 0) and are pushed out of rows they violate. ``fixed`` ((N, d) of -1 / 0 / +1) predicts s
    components of stable particles held at their lower / upper s bound: they leave the unknowns (one contact fewer
    each), and their bound multipliers must come out >= 0, else None (bounds never pivot). Anything else -- a
    rattler joining the network, another active s or a Gamma bound, a singular system, more than ``max_pivots``
    pivots -- returns None and the caller solves the LP with HiGHS. Near convergence the active set barely
    changes, and this replaces a HiGHS solve (seconds) by a few factorisations (milliseconds).
    """
    from scipy.sparse import csr_matrix
    from scipy.sparse.linalg import splu

    t0 = time.perf_counter()
    dim = rij.shape[1]
    if rattler[pinned]:
        return None
    free = ~rattler
    free[pinned] = False
    fixed = np.zeros((n, dim), dtype=np.int8) if fixed is None else np.where(free[:, None], fixed, 0).astype(np.int8)
    # unknowns: the s components of stable, non-pinned particles not held at a bound, then Gamma
    free_comp = np.repeat(free, dim) & (fixed.ravel() == 0)
    col_of = np.full(n * dim + 1, -1, dtype=np.int64)
    col_of[:-1][free_comp] = np.arange(np.count_nonzero(free_comp))
    nu = int(np.count_nonzero(free_comp)) + 1
    col_of[-1] = nu - 1
    if contact_keys.size != nu:
        return None  # not isostatic: no square system
    # the rows among stable particles, in the reduced columns (pinned particle and fixed components dropped)
    stable_rows = np.flatnonzero(~rattler[pi] & ~rattler[pj])
    start, index, value, rhs = constraint_rows(rij[stable_rows], sigma2[stable_rows], pi[stable_rows],
                                               pj[stable_rows], n)
    keep = col_of[index] >= 0
    row_id = np.repeat(np.arange(stable_rows.size), np.diff(start))
    a_all = csr_matrix((value[keep], (row_id[keep], col_of[index][keep])), shape=(stable_rows.size, nu))
    s_fixed = np.append(fixed.ravel() * float(s_bound), 0.0)
    held = s_fixed[index] != 0.0
    if np.any(held):  # a held component moves to the right-hand side
        rhs = rhs - np.bincount(row_id[held], weights=value[held] * s_fixed[index][held], minlength=rhs.size)
    key = pi[stable_rows] * n + pj[stable_rows]
    basis = np.flatnonzero(np.isin(key, contact_keys))
    if basis.size != nu:
        return None  # a predicted contact left the cutoff or involves a particle that is now a rattler
    if max_pivots is None:
        max_pivots = 10  # each pivot refactorises; beyond a few, HiGHS is cheaper
    e_gamma = np.zeros(nu)
    e_gamma[-1] = 1.0
    for pivot in range(max_pivots + 1):
        try:
            lu = splu(a_all[basis].tocsc())
        except RuntimeError:  # singular
            return None
        u = lu.solve(rhs[basis])
        lam = lu.solve(e_gamma, trans="T")
        if not (np.all(np.isfinite(u)) and np.all(np.isfinite(lam))):
            return None
        slack = rhs - a_all @ u
        if pivot == 0:
            in_basis = np.zeros(stable_rows.size, dtype=bool)
            in_basis[basis] = True
            if np.min(slack[~in_basis], initial=0.0) < -feasibility:
                return None  # the predicted vertex is not feasible at the new positions
        if np.max(np.abs(u[:-1]), initial=0.0) > s_bound or not (gamma_bounds[0] - 1e-13 <= u[-1] <= gamma_bounds[1]):
            return None
        k = int(np.argmin(lam))
        if lam[k] > 0.0:
            break
        if pivot == max_pivots:
            return None
        # release row basis[k]: direction d with A_B d = -e_k; Gamma grows at rate -lam_k > 0
        e_k = np.zeros(nu)
        e_k[k] = -1.0
        d = lu.solve(e_k)
        rate = a_all @ d
        rate[basis] = 0.0
        blocking = np.flatnonzero(rate > 1e-14)
        if blocking.size == 0:
            return None  # unbounded edge: only the s bounds stop it
        ratios = np.maximum(slack[blocking], 0.0) / rate[blocking]
        j = int(np.argmin(ratios))
        step = ratios[j]
        if np.max(np.abs(u[:-1] + step * d[:-1]), initial=0.0) > s_bound:
            return None  # an s bound would block first
        basis[k] = blocking[j]
    if np.any(held):
        # bound multipliers: mu = -(A^T lambda)_j at an upper bound, +(A^T lambda)_j at a lower one, both >= 0
        row_lam = np.zeros(stable_rows.size)
        row_lam[basis] = lam
        at = np.zeros(n * dim + 1)
        np.add.at(at, index[held], value[held] * row_lam[row_id[held]])
        comps = np.flatnonzero(fixed.ravel())
        if np.any(-fixed.ravel()[comps] * at[comps] < 0.0):
            return None
    gamma = max(float(u[-1]), gamma_bounds[0])
    s = np.zeros((n, dim)) if rattler_s is None else np.clip(rattler_s, -s_bound, s_bound)
    s[pinned] = 0.0
    s.ravel()[free_comp] = u[:-1]
    s[fixed != 0] = fixed[fixed != 0] * float(s_bound)
    active = np.zeros(len(pi), dtype=bool)
    active[stable_rows[basis]] = True
    # every row of the LP: |r|^2 + 2 r.(s_i - s_j) - Gamma sigma^2 >= 0. Rattlers (columns without active rows)
    # may be pushed away from a neighbour their cage wall has come to touch; this keeps the solution optimal.
    for _ in range(20):
        slack = np.einsum("ij,ij->i", rij, rij + 2.0 * (s[pi] - s[pj])) - gamma * sigma2
        bad = (slack < feasibility) & ~active
        if not np.any(bad):
            break
        if np.any(bad & ~rattler[pi] & ~rattler[pj] & (slack < -feasibility)):
            return None
        for k in np.flatnonzero(bad & (rattler[pi] | rattler[pj])):
            push = 2.0 * (feasibility - slack[k]) / (2.0 * float(np.dot(rij[k], rij[k])))
            if rattler[pi[k]]:
                s[pi[k]] += push * rij[k]
            else:
                s[pj[k]] -= push * rij[k]
    else:
        return None
    if np.min(slack[~active], initial=0.0) < -feasibility or np.max(np.abs(s)) > s_bound:
        return None
    duals = np.zeros(len(pi))
    duals[stable_rows[basis]] = lam
    return LPSolution(s, gamma, duals, time.perf_counter() - t0, f"active-set+{pivot}")


# --- cutoff and bounds --------------------------------------------------------------------------------------------


def cutoff_and_bound(sqrt_gamma_prev: float, radius: float, cutoff0: float, dim: int, box: float,
                     thresholds=REGIME_THRESHOLDS, s_bound: float | None = None):
    """The cutoff l, the per-component bound s_bound and Gamma_max of one iteration (absolute lengths).

    ``radius`` is the current largest radius R, ``cutoff0`` the user cutoff l0, ``s_bound`` an optional fixed
    bound overriding the regimes. Returns ``(l, s_bound, gamma_max, regime)``; guarantees s_bound > 0,
    l <= box/2 and gamma_max > 1 (see the module docstring), else raises :class:`InputError`.
    """
    R = radius
    rd = math.sqrt(dim)
    g = sqrt_gamma_prev - 1.0
    if g > thresholds[0]:
        regime = 1
        grow = max(1.5, sqrt_gamma_prev)
        ell = max(cutoff0, 2.0 * (grow * R + MIN_FAR_BOUND * R))
        sb = (ell / 2.0 - grow * R) / rd
    else:
        regime = 2 if g > thresholds[1] else 3
        frac = REGIME_S_BOUNDS[regime - 2]
        sb = frac * R
        ell = min(REGIME_CUTOFFS[regime - 2] * R, cutoff0)
        # keep sqrt(Gamma_max) >= 1.1 (l0 fixed while R grows)
        ell = max(ell, 2.2 * R + 2.0 * rd * sb)
    if s_bound is not None:
        sb = s_bound
        ell = max(ell, 2.2 * R + 2.0 * rd * sb)
    if ell > box / 2.0:
        ell = box / 2.0
        sb = min(sb, (ell - 2.0 * R * (1.0 + 1e-3)) / (2.0 * rd))
        if sb <= 1e-6 * R:
            raise InputError(
                f"box={box!r}: too small for CALiPPSO (cutoff must stay below L/2 = {box / 2:.6g} while exceeding "
                f"the contact distance {2 * R:.6g}); use more particles"
            )
    gamma_max = ((ell - 2.0 * rd * sb) / (2.0 * R)) ** 2
    return ell, sb, gamma_max, regime


def nearest_gap_median(positions: np.ndarray, diameters: np.ndarray, box: float, scale: float = 1.5) -> float:
    """Median over particles of the nearest-neighbour gap h = r/sigma - 1 (capped at scale - 1)."""
    i, j, r = pairs_within(positions, diameters, box, scale)
    h = r / (0.5 * (diameters[i] + diameters[j])) - 1.0
    best = np.full(len(positions), scale - 1.0)
    np.minimum.at(best, i, h)
    np.minimum.at(best, j, h)
    return float(np.median(best))


# --- contact network ------------------------------------------------------------------------------------------------


def contact_network(rij, sigma2, pi, pj, duals, n, dim, zero_force):
    """Contacts, rattlers and force balance from LP duals.

    Returns ``(contact_mask over pairs, rattler mask, n_contacts among non-rattlers, isostatic, residual)``.
    """
    from ..analysis.contacts import rattler_mask

    contact = duals * sigma2 * n > zero_force
    ci, cj = pi[contact], pj[contact]
    rattler = rattler_mask(n, ci, cj, dim + 1)
    stable_pair = contact & ~rattler[pi] & ~rattler[pj]
    n_contacts = int(np.count_nonzero(stable_pair))
    n_stable = n - int(np.count_nonzero(rattler))
    isostatic = bool(n_stable > 0 and n_contacts == dim * (n_stable - 1) + 1)
    # every contact force counts (in a degenerate, crystalline vertex a "rattler" can hold d collinear forces)
    weight = np.where(contact, duals, 0.0)
    residual = force_balance(rij, weight, pi, pj, n, rattler)
    return contact, rattler, n_contacts, isostatic, residual


def force_balance(rij, weight, pi, pj, n, rattler) -> float:
    """max over non-rattlers of |sum_j w_ij r_ij| divided by the mean w_ij |r_ij| over pairs with w > 0."""
    active = weight > 0
    if not np.any(active) or np.all(rattler):
        return math.inf
    mean_force = float(np.mean(weight[active] * np.linalg.norm(rij[active], axis=1)))
    net = particle_force_sums(rij, weight, pi, pj, n)
    return float(np.max(np.linalg.norm(net[~rattler], axis=1)) / mean_force)


# --- the driver -------------------------------------------------------------------------------------------------------


def _validate(packing, max_iterations, gamma_tolerance, displacement_tolerance, s_bound, cutoff, initial_sqrt_gamma,
              zero_force, solver_tolerance, overlap_tolerance, gap_range, progress_interval, checkpoint_interval,
              regime_thresholds):
    require(isinstance(packing, Packing), "packing", type(packing).__name__, "must be a Packing")
    require(isinstance(max_iterations, (int, np.integer)) and max_iterations >= 1, "max_iterations",
            max_iterations, "must be an integer >= 1")
    for name, value in (("gamma_tolerance", gamma_tolerance), ("displacement_tolerance", displacement_tolerance),
                        ("zero_force", zero_force), ("solver_tolerance", solver_tolerance),
                        ("overlap_tolerance", overlap_tolerance), ("gap_range", gap_range),
                        ("checkpoint_interval", checkpoint_interval)):
        require(isinstance(value, (int, float)) and math.isfinite(value) and value > 0, name, value,
                "must be a finite number > 0")
    require(isinstance(progress_interval, (int, float)) and progress_interval >= 0, "progress_interval",
            progress_interval, "must be a number >= 0")
    require(1e-10 <= solver_tolerance <= 1e-5, "solver_tolerance", solver_tolerance, "must be in [1e-10, 1e-5]")
    require(s_bound is None or (math.isfinite(s_bound) and 0 < s_bound < 0.5), "s_bound", s_bound,
            "must be None or in (0, 0.5) (units of the largest diameter)")
    require(cutoff is None or (math.isfinite(cutoff) and cutoff > 1), "cutoff", cutoff,
            "must be None or > 1 (units of the initial largest diameter)")
    require(initial_sqrt_gamma is None or (math.isfinite(initial_sqrt_gamma) and initial_sqrt_gamma >= 1),
            "initial_sqrt_gamma", initial_sqrt_gamma, "must be None or >= 1")
    th = tuple(regime_thresholds)
    require(len(th) == 2 and all(math.isfinite(t) and t > 0 for t in th) and th[0] > th[1], "regime_thresholds",
            regime_thresholds, "must be two numbers > 0, the first larger")


def run_calippso(
    packing: Packing,
    *,
    max_iterations: int = 1000,
    gamma_tolerance: float = 1e-12,
    displacement_tolerance: float = 1e-9,
    s_bound: float | None = None,
    cutoff: float | None = None,
    initial_sqrt_gamma: float | None = None,
    regime_thresholds: tuple[float, float] = REGIME_THRESHOLDS,
    zero_force: float = 1e-10,
    solver_tolerance: float = 1e-9,
    solver_options: dict[str, Any] | None = None,
    overlap_tolerance: float = DEFAULT_OVERLAP_TOLERANCE,
    gap_range: float = 0.5,
    fine_tune: bool = True,
    active_set: bool = True,
    warm_start: bool = True,
    require_convergence: bool = False,
    checkpoint: str | Path | None = None,
    checkpoint_interval: float = 300.0,
    progress_interval: float = 10.0,
    solver: str = "auto",
    threads: int = 1,
    crossover: bool | None = None,
) -> CalippsoResult:
    """Jam ``packing`` with CALiPPSO and return the jammed packing, its contact network and forces.

    Parameters
    ----------
    packing : Packing
        Overlap-free start (any d from 2 to 5, any polydispersity); overlaps beyond ``overlap_tolerance`` raise
        :class:`OverlapError`. The box must exceed about 4 largest diameters (cutoff < L/2).
    max_iterations : int
        Iteration cap (1000). Not converged by then: ``converged=False`` (or an error if ``require_convergence``).
    gamma_tolerance : float
        Convergence when sqrt(Gamma) - 1 <= this (1e-12) ...
    displacement_tolerance : float
        ... and max |s_{i,mu}| over non-rattlers <= this times the current largest diameter (1e-9).
    s_bound : float or None
        Fixed per-component displacement bound, in units of the current largest diameter; None = the spec's
        regimes (0.05 / 0.005 of the diameter near jamming).
    cutoff : float or None
        l0, the regime-1 cutoff on centre distances, in units of the initial largest diameter; None = 2 (4 R0).
        It is enlarged automatically when it becomes too small (see the module docstring).
    initial_sqrt_gamma : float or None
        sqrt(Gamma_prev) for the first regime choice; None = 1 + median nearest-neighbour gap.
    regime_thresholds : (float, float)
        Thresholds on sqrt(Gamma_prev) - 1 between regimes 1/2 and 2/3 ((5e-4, 1e-5)).
    zero_force : float
        A pair is a contact iff its dual share lambda sigma^2 exceeds zero_force / N (1e-10).
    solver_tolerance : float
        HiGHS primal/dual feasibility and IPM optimality tolerances (1e-9).
    solver_options : dict or None
        Extra HiGHS options (e.g. ``{"threads": 1}``); passed verbatim.
    overlap_tolerance : float
        Relative overlap 1 - r/sigma accepted in the input and the output (1e-10, as ``Packing.check``).
    gap_range : float
        Keep the gaps h < gap_range of non-contact pairs among non-rattlers (0.5).
    fine_tune : bool
        Solve the final unbounded LP for the forces (True).
    active_set : bool
        Try the certified active-set solve (:func:`solve_active_set`) before HiGHS whenever the previous LP was
        isostatic and no warm start is available, and for the final force LP (True). Off: every LP goes to HiGHS.
    warm_start : bool
        Start each HiGHS solve from the previous LP's basis (primal simplex), falling back to a cold solve
        (True; never from N = :data:`WARM_START_MAX_N` on). Off: a cold solve every time.
    require_convergence : bool
        Raise :class:`SimulationError` instead of returning an unconverged result.
    checkpoint : path or None
        Save the state there every ``checkpoint_interval`` seconds and when the run stops unconverged; a call
        with an existing checkpoint of the same input and parameters (``max_iterations`` may differ) resumes from
        it. Removed when the run converges.
    progress_interval : float
        Seconds between progress lines (logger ``spherejam``).
    solver : str
        HiGHS solver of a cold LP solve: "hipo" (sparse-direct interior point), "ipx" (interior point),
        "simplex" (dual simplex), or "auto" (the default: the faster one measured at this N, HiPO from
        :data:`AUTO_HIPO_MIN_N` on, else IPX). Recorded per LP in ``history["solver"]`` (:data:`SOLVER_CODES`)
        and, resolved, in the parameters.
    threads : int
        Threads of HiGHS and of HiPO's BLAS (1: workflow jobs get one core each). HiGHS keeps the count of a
        process's first solve.
    crossover : bool or None
        Always run HiGHS's crossover after an interior point (False: certify the interior point's active set with
        :func:`solve_active_set` and cross over only when that fails; both give exact vertex duals). None (the
        default): False for HiPO, True for IPX, the faster pairing of each.
    """
    _validate(packing, max_iterations, gamma_tolerance, displacement_tolerance, s_bound, cutoff, initial_sqrt_gamma,
              zero_force, solver_tolerance, overlap_tolerance, gap_range, progress_interval, checkpoint_interval,
              regime_thresholds)
    require(solver in (*SOLVERS, "auto"), "solver", solver, f"must be one of auto, {', '.join(SOLVERS)}")
    if solver == "auto":  # without highspy-extras HiGHS has no HiPO
        solver = "hipo" if packing.n >= AUTO_HIPO_MIN_N and _highspy_extras() is not None else "ipx"
    if crossover is None:
        crossover = solver != "hipo"
    require(isinstance(threads, (int, np.integer)) and threads >= 1, "threads", threads, "must be an integer >= 1")
    wall0 = time.perf_counter()
    report = packing.check(overlap_tolerance)
    if not report.ok:
        raise OverlapError(f"CALiPPSO input: {report}")
    n, dim = packing.n, packing.dim
    unit = float(packing.diameters.max())  # internal length unit: the initial largest diameter
    box = packing.box / unit
    x = packing.positions / unit
    dia = packing.diameters / unit
    phi_initial = packing.phi
    cutoff0 = 2.0 if cutoff is None else float(cutoff)
    if initial_sqrt_gamma is None:
        initial_sqrt_gamma = 1.0 + nearest_gap_median(x, dia, box)
    parameters = {
        "max_iterations": int(max_iterations), "gamma_tolerance": gamma_tolerance,
        "displacement_tolerance": displacement_tolerance, "s_bound": s_bound, "cutoff": cutoff0,
        "initial_sqrt_gamma": float(initial_sqrt_gamma), "regime_thresholds": list(regime_thresholds),
        "zero_force": zero_force, "solver_tolerance": solver_tolerance, "overlap_tolerance": overlap_tolerance,
        "fine_tune": bool(fine_tune), "active_set": bool(active_set), "warm_start": bool(warm_start),
        "solver": solver, "threads": int(threads), "crossover": bool(crossover),
        "highs_version": _highs_version(),
    }
    warm_start = warm_start and n < WARM_START_MAX_N  # no basis is kept either: the force LP starts cold too

    history = History()
    sqrt_gamma_prev = float(initial_sqrt_gamma)
    pinned = _initial_pin(x, dia, box)
    iteration = 0
    converged = False
    lp_time = 0.0
    lp_cpu_time = 0.0  # this call's, not resumed from a checkpoint
    methods: dict[str, int] = {}
    solvers: dict[str, int] = {}  # LPs per HiGHS solver ("none": active set alone), incl. the force LP
    predicted = None  # (contact keys, rattler mask) of the last LP, when isostatic
    basis = None  # HiGHS basis of the last HiGHS-solved LP, the next one's warm start (regimes 2-3)
    warm_failures = 0  # failed warm starts in a row
    warm_skip = 0  # LPs left to solve without a warm start (back-off after failures)
    warm_attempts = 0
    bound_hit, prev_sb = False, 0.0
    ckpt = Path(checkpoint) if checkpoint is not None else None
    # a resumed run may use another thread count (same trajectory)
    fingerprint = _fingerprint(packing, {k: v for k, v in parameters.items() if k not in ("max_iterations", "threads")})
    if ckpt is not None and ckpt.exists():
        x, dia, state, rows = _load_state(ckpt, fingerprint)
        iteration, sqrt_gamma_prev, pinned = state["iteration"], state["sqrt_gamma_prev"], state["pinned"]
        lp_time = state["lp_time"]
        history = History(rows)
    last_save = time.perf_counter()
    progress = Progress(f"calippso N={n} d={dim}", progress_interval)
    last = None  # (rij, sigma2, pi, pj, solution, rattler) of the latest LP

    while iteration < max_iterations:
        R = 0.5 * float(dia.max())
        fixed_sb = None if s_bound is None else s_bound * 2.0 * R
        if fixed_sb is None and prev_sb > 0:
            # a stable particle stopped by its bound means the regime's bound is too tight for this packing:
            # double it (up to 0.1 R); once no bound stops anyone, relax back towards the regime's value
            regime_sb = cutoff_and_bound(sqrt_gamma_prev, R, cutoff0, dim, box, regime_thresholds)[1]
            grown = min(2.0 * prev_sb, MAX_ESCALATED_BOUND * R) if bound_hit else 0.5 * prev_sb
            if grown > regime_sb:
                fixed_sb = grown
        ell, sb, gamma_max, regime = cutoff_and_bound(sqrt_gamma_prev, R, cutoff0, dim, box, regime_thresholds,
                                                      fixed_sb)
        pi, pj, _ = pairs_in_cutoff(x, box, ell)
        rij = pair_vectors(x, box, pi, pj)
        sigma2 = (0.5 * (dia[pi] + dia[pj])) ** 2
        sol = None
        cpu0 = time.process_time()
        # a warm-started HiGHS solve is faster than the active-set pivots (measured: failed attempts cost more than
        # the successful ones save), so the main loop uses the shortcut only when there is no basis to start from
        if predicted is not None and (basis is None or regime == 1):
            t_try = time.perf_counter()
            sol = solve_active_set(rij, sigma2, pi, pj, n, *predicted, s_bound=sb, pinned=pinned,
                                   gamma_bounds=(1.0, gamma_max))
            if sol is None:
                lp_time += time.perf_counter() - t_try  # a failed attempt is LP time too
        if sol is None:
            warm = basis if regime > 1 and warm_skip == 0 else None
            warm_skip = max(warm_skip - 1, 0)
            sol = solve_lp(rij, sigma2, pi, pj, n, s_bound=sb, pinned=pinned, gamma_bounds=(1.0, gamma_max),
                           tolerance=solver_tolerance, options=solver_options, iteration=iteration, warm=warm,
                           solver=solver, threads=threads, crossover=crossover)
            basis = sol.basis if warm_start else None
            if warm is not None:
                warm_attempts += 1
                warm_failures = 0 if sol.method == "warm" else warm_failures + 1
                warm_skip = 2**warm_failures - 1
        iteration += 1
        lp_cpu = time.process_time() - cpu0
        lp_cpu_time += lp_cpu
        lp_time += sol.solve_time
        methods[sol.method.split("+")[0]] = methods.get(sol.method.split("+")[0], 0) + 1
        solvers[sol.solver] = solvers.get(sol.solver, 0) + 1
        contact, rattler, n_contacts, isostatic, _ = contact_network(rij, sigma2, pi, pj, sol.duals, n, dim,
                                                                     zero_force)
        predicted = _prediction(contact, rattler, pi, pj, n, isostatic, active_set)
        sqrt_gamma = math.sqrt(max(sol.gamma, 1.0))
        # step: move, inflate, and make sure round-off in the solver left no overlap
        x = np.mod(x + sol.s, box)
        dia = dia * sqrt_gamma
        h_min = _closest_h(x, dia, box)
        correction = 0.0
        if h_min < 1.0:
            correction = 1.0 - h_min
            if correction > MAX_OVERLAP_CORRECTION:
                raise SimulationError(
                    f"CALiPPSO iteration {iteration}: the LP step overlaps by {correction:.3e} (relative); "
                    "the linearised constraints or the cutoff were violated"
                )
            dia = dia * h_min
            sqrt_gamma *= h_min
        moving = ~rattler if np.any(~rattler) else np.ones(n, dtype=bool)
        max_s = float(np.max(np.abs(sol.s[moving]))) / float(dia.max())
        max_s_all = float(np.max(np.abs(sol.s))) / float(dia.max())
        phi = _phi(dia, box, dim)
        history.append(
            sqrt_gamma_minus_1=sqrt_gamma - 1.0, max_displacement=max_s, max_displacement_all=max_s_all, phi=phi,
            n_constraints=len(pi), solve_time=sol.solve_time, cpu_time=lp_cpu, cutoff=ell / dia.max(),
            s_bound=sb / dia.max(),
            regime=regime, method=METHOD_CODES[sol.method.split("+")[0]], solver=SOLVER_CODES[sol.solver],
            n_contacts=n_contacts,
            n_rattlers=int(np.count_nonzero(rattler)),
            isostatic=int(isostatic), overlap_correction=correction,
        )
        progress.update(
            f"it {iteration}: sqrt(G)-1 {sqrt_gamma - 1:.3e}, max|s| {max_s:.3e}, phi {phi:.8f}, "
            f"rows {len(pi)}, contacts {n_contacts}, rattlers {int(rattler.sum())}, iso {isostatic}, "
            f"LP {sol.solve_time:.2f} s ({sol.method}, {sol.solver})",
            fields={"LP": iteration, "√Γ-1": sqrt_gamma - 1.0, "LP time": f"{sol.solve_time:.2f} s"},
        )
        last = (rij, sigma2, pi, pj, sol, rattler)
        bound_hit = bool(np.any(~rattler)) and float(np.max(np.abs(sol.s[~rattler]))) >= (1.0 - 1e-9) * sb
        prev_sb = sb
        sqrt_gamma_prev = sqrt_gamma
        if rattler[pinned] and np.any(~rattler):
            pinned = _repin(contact, pi, pj, rattler, n)
        if sqrt_gamma - 1.0 <= gamma_tolerance and max_s <= displacement_tolerance:
            converged = True
            break
        if ckpt is not None and time.perf_counter() - last_save >= checkpoint_interval:
            _save_state(ckpt, fingerprint, x, dia, history, iteration, sqrt_gamma_prev, pinned, lp_time)
            last_save = time.perf_counter()

    if not converged and require_convergence:
        raise SimulationError(f"CALiPPSO did not converge in {max_iterations} iterations "
                              f"(last sqrt(Gamma)-1 = {history.last('sqrt_gamma_minus_1'):.3e}, "
                              f"max|s| = {history.last('max_displacement'):.3e})")

    # forces: one more LP at the final configuration, nothing moves (docs §2.3)
    fine_tuned = False
    fine_gamma = math.nan
    R = 0.5 * float(dia.max())
    ell = cutoff_and_bound(1.0, R, cutoff0, dim, box, regime_thresholds)[0]  # the final regime's cutoff
    pi, pj, _ = pairs_in_cutoff(x, box, ell)
    rij = pair_vectors(x, box, pi, pj)
    sigma2 = (0.5 * (dia[pi] + dia[pj])) ** 2
    duals = None
    cpu0 = time.process_time()
    if fine_tune:
        try:
            fine = None
            if predicted is not None:
                fine = solve_active_set(rij, sigma2, pi, pj, n, *predicted, s_bound=R, pinned=pinned,
                                        gamma_bounds=(-math.inf, math.inf))
            if fine is None:
                fine = solve_lp(rij, sigma2, pi, pj, n, s_bound=R, pinned=pinned,
                                gamma_bounds=(-math.inf, math.inf), tolerance=solver_tolerance,
                                options=solver_options, iteration=iteration + 1, warm=basis, solver=solver,
                                threads=threads, crossover=crossover)
            methods[fine.method.split("+")[0]] = methods.get(fine.method.split("+")[0], 0) + 1
            solvers[fine.solver] = solvers.get(fine.solver, 0) + 1
            lp_time += fine.solve_time
            duals = fine.duals
            fine_gamma = fine.gamma
            fine_tuned = True
        except SimulationError:
            duals = None
    lp_cpu_time += time.process_time() - cpu0
    if duals is None:
        if last is None:
            raise SimulationError("CALiPPSO: no LP solved (checkpoint already at max_iterations?)")
        # the main loop's last LP: its pair vectors are at the positions before the last (tiny) step
        rij, sigma2, pi, pj, sol, _ = last
        duals = sol.duals
    contact, rattler, n_contacts, isostatic, residual = contact_network(rij, sigma2, pi, pj, duals, n, dim,
                                                                        zero_force)
    stable_pair = contact & ~rattler[pi] & ~rattler[pj]
    r_norm = np.linalg.norm(rij, axis=1)
    f = duals[stable_pair] * r_norm[stable_pair]
    forces = f / f.mean() if f.size else f
    pairs = np.stack([pi[stable_pair], pj[stable_pair]], axis=1)
    vectors = rij[stable_pair] / r_norm[stable_pair, None]
    gaps, gap_pairs = _near_gaps(x, dia, box, gap_range, rattler, pairs, n)

    out = Packing(
        x * unit, dia * unit, packing.box,
        {
            **{k: v for k, v in packing.metadata.items() if k not in ("provenance", "reduced_pressure")},
            "algorithm": "calippso",
            "parameters": {**parameters, "input_algorithm": packing.metadata.get("algorithm")},
        },
    )
    final_report = out.check(overlap_tolerance)
    if not final_report.ok:  # cannot happen by construction; never return an overlapping packing
        raise SimulationError(f"CALiPPSO output overlaps: {final_report}")
    wall = time.perf_counter() - wall0
    counters = {
        "iterations": iteration, "converged": converged, "lp_time": lp_time, "lp_cpu_time": lp_cpu_time,
        "wall_time": wall,
        "lp_methods": methods, "lp_solvers": solvers, "warm_attempts": warm_attempts, "fine_tuned": fine_tuned,
        "fine_tune_sqrt_gamma_minus_1": math.sqrt(fine_gamma) - 1.0 if fine_gamma > 0 else math.nan,
        "phi_initial": phi_initial, "phi_final": out.phi, "n_contacts": n_contacts,
        "n_rattlers": int(rattler.sum()), "isostatic": isostatic, "force_balance_residual": residual,
        "worst_overlap": final_report.worst_overlap, "pinned": int(pinned),
    }
    out.metadata["counters"] = counters
    if ckpt is not None:
        if converged:
            ckpt.unlink(missing_ok=True)
        else:  # a later call with a larger max_iterations continues from here
            _save_state(ckpt, fingerprint, x, dia, history, iteration, sqrt_gamma_prev, pinned, lp_time)
    return CalippsoResult(
        packing=out, converged=converged, iterations=iteration, history=history.as_arrays(), pairs=pairs,
        forces=forces, contact_vectors=vectors, rattlers=rattler, n_contacts=n_contacts, isostatic=isostatic,
        force_balance_residual=residual, gaps=gaps, gap_pairs=gap_pairs, phi_initial=phi_initial, wall_time=wall,
        fine_tuned=fine_tuned, counters=counters,
    )


# --- helpers ----------------------------------------------------------------------------------------------------------


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


def _highs_version() -> str:
    import highspy

    return highspy.Highs().version()



def _phi(dia, box, dim) -> float:
    return float(np.sum(math.pi ** (dim / 2) / math.gamma(dim / 2 + 1) * (0.5 * dia) ** dim) / box**dim)


def _closest_h(x, dia, box) -> float:
    i, j, r = pairs_within(x, dia, box, 1.0 + 1e-6)
    if len(r) == 0:
        return math.inf
    return float(np.min(r / (0.5 * (dia[i] + dia[j]))))


def _initial_pin(x, dia, box) -> int:
    """The particle with the most neighbours within 1.05 sigma (likely part of the rigid network)."""
    i, j, _ = pairs_within(x, dia, box, 1.05)
    if len(i) == 0:
        return len(x) - 1
    count = np.bincount(np.concatenate([i, j]), minlength=len(x))
    return int(np.argmax(count))


def _prediction(contact, rattler, pi, pj, n, isostatic, enabled):
    if not (enabled and isostatic):
        return None
    stable = contact & ~rattler[pi] & ~rattler[pj]
    return np.sort(pi[stable] * n + pj[stable]), rattler.copy()


def _repin(contact, pi, pj, rattler, n) -> int:
    count = np.bincount(np.concatenate([pi[contact], pj[contact]]), minlength=n)
    count[rattler] = -1
    return int(np.argmax(count))


def _near_gaps(x, dia, box, gap_range, rattler, contact_pairs, n):
    i, j, r = pairs_within(x, dia, box, 1.0 + gap_range)
    keep = ~rattler[i] & ~rattler[j]
    i, j, r = i[keep], j[keep], r[keep]
    key = i * n + j
    is_contact = np.isin(key, contact_pairs[:, 0] * n + contact_pairs[:, 1])
    i, j, r = i[~is_contact], j[~is_contact], r[~is_contact]
    h = r / (0.5 * (dia[i] + dia[j])) - 1.0
    return h, np.stack([i, j], axis=1)


def _fingerprint(packing: Packing, parameters: dict[str, Any]) -> str:
    import hashlib
    import json

    digest = hashlib.sha256()
    digest.update(np.ascontiguousarray(packing.positions).tobytes())
    digest.update(np.ascontiguousarray(packing.diameters).tobytes())
    digest.update(json.dumps({"box": packing.box, **parameters}, sort_keys=True, default=str).encode())
    return digest.hexdigest()[:32]


def _save_state(path, fingerprint, x, dia, history, iteration, sqrt_gamma_prev, pinned, lp_time):
    from ..core.checkpoint import save_checkpoint

    arrays = {"positions": x, "diameters": dia}
    arrays.update({f"history_{k}": v for k, v in history.as_arrays().items()})
    save_checkpoint(path, CHECKPOINT_KIND, arrays, {
        "fingerprint": fingerprint, "iteration": iteration, "sqrt_gamma_prev": sqrt_gamma_prev,
        "pinned": int(pinned), "lp_time": lp_time,
    })


def _load_state(path, fingerprint):
    from ..core.checkpoint import load_checkpoint
    from ..core.errors import PackingFileError

    arrays, state = load_checkpoint(path, CHECKPOINT_KIND)
    if state.get("fingerprint") != fingerprint:
        raise PackingFileError(f"{path}: checkpoint of a different CALiPPSO input or parameters")
    rows = {k[len("history_"):]: v for k, v in arrays.items() if k.startswith("history_")}
    return arrays["positions"], arrays["diameters"], state, rows


# --- distributions --------------------------------------------------------------------------------------------------


#: Mean-field exponents (Charbonneau, Kurchan, Parisi, Urbani, Zamponi 2014): gaps g(h) ~ h^-gamma, extended forces
#: P(f) ~ f^theta_e.
MEAN_FIELD_GAMMA = 0.41269
MEAN_FIELD_THETA_E = 0.42311


@dataclass(frozen=True)
class PowerLawFit:
    """Maximum-likelihood fit of a density p(x) ∝ x^(a-1) on [lo, hi] (i.e. a cumulative C(x) ∝ x^a there).

    ``exponent`` is the derived physical exponent (gaps: gamma = 1 - a; forces: theta = a - 1), ``stderr`` its
    asymptotic standard error (Fisher information), ``n`` the number of samples in [lo, hi] out of ``n_total``.
    """

    cumulative_exponent: float
    exponent: float
    stderr: float
    lo: float
    hi: float
    n: int
    n_total: int


def fit_cumulative_power_law(values: np.ndarray, lo: float, hi: float) -> tuple[float, float, int]:
    """MLE of a in p(x) ∝ x^(a-1) on [lo, hi] from the samples inside; returns ``(a, stderr, n)``."""
    from scipy.optimize import minimize_scalar

    require(0 <= lo < hi, "fit range", (lo, hi), "must satisfy 0 <= lo < hi")
    v = np.asarray(values, dtype=float)
    v = v[(v >= lo) & (v <= hi) & (v > 0)]
    k = v.size
    if k < 5:
        return math.nan, math.nan, k
    u = np.log(v / hi)  # <= 0
    mean_u = float(u.mean())
    rho = lo / hi

    def negloglik(a):
        # -(1/k) log L, with normaliser (1 - rho^a)/a of x^(a-1) on [rho, 1] after scaling by hi
        norm = -math.expm1(a * math.log(rho)) if rho > 0 else 1.0
        return -(math.log(a) + (a - 1.0) * mean_u - math.log(norm))

    res = minimize_scalar(negloglik, bounds=(1e-3, 20.0), method="bounded", options={"xatol": 1e-10})
    a = float(res.x)
    # Fisher information per sample: 1/a^2 - rho^a (ln rho)^2 / (1 - rho^a)^2
    info = 1.0 / a**2
    if rho > 0:
        ra = rho**a
        info -= ra * math.log(rho) ** 2 / (1.0 - ra) ** 2
    stderr = 1.0 / math.sqrt(k * info) if info > 0 else math.nan
    return a, stderr, k


def gap_exponent(gaps: np.ndarray, lo: float = 1e-8, hi: float = 1e-2) -> PowerLawFit:
    """Fit g(h) ~ h^-gamma at small h: the cumulative count of gaps below h grows as h^(1-gamma) on [lo, hi].

    Default range: h from 1e-8 (below, gaps are not resolved by a 1e-9 displacement tolerance) to 1e-2 (above,
    the distribution leaves the power law). Compare with the mean-field gamma = 0.41269.
    """
    a, se, k = fit_cumulative_power_law(gaps, lo, hi)
    return PowerLawFit(a, 1.0 - a, se, lo, hi, k, int(np.size(gaps)))


def force_exponent(forces: np.ndarray, lo: float = 1e-6, hi: float = 0.2) -> PowerLawFit:
    """Fit P(f) ~ f^theta at small f (forces in units of their mean): cumulative ∝ f^(1+theta) on [lo, hi].

    Compare with theta_e = 0.42311 for extended forces (use :func:`extended_forces`) or theta_l = 0.17462 when
    buckler forces are included.
    """
    a, se, k = fit_cumulative_power_law(forces, lo, hi)
    return PowerLawFit(a, a - 1.0, se, lo, hi, k, int(np.size(forces)))


def extended_forces(result: CalippsoResult) -> np.ndarray:
    """Forces (units of the mean) of contacts whose two particles both have more than d + 1 contacts.

    Bucklers -- stable particles with exactly d + 1 contacts -- carry the localised weak forces (theta_l); leaving
    out every contact that touches one isolates the extended ones (theta_e). This is our operational split, not a
    quote of the paper's.
    """
    return result.forces[contact_arrays(result)["extended"]]


def contact_arrays(result: CalippsoResult) -> dict[str, np.ndarray]:
    """The contact network, forces and near-contact gaps of a result, as arrays for the packing file."""
    n = result.rattlers.size
    z = np.bincount(result.pairs.ravel(), minlength=n)
    buckler = z == result.packing.dim + 1
    extended = ~buckler[result.pairs[:, 0]] & ~buckler[result.pairs[:, 1]]
    return {
        "pairs": result.pairs, "forces": result.forces, "extended": extended,
        "contact_vectors": result.contact_vectors, "rattlers": result.rattlers,
        "gaps": result.gaps, "gap_pairs": result.gap_pairs,
    }


#: name -> (long_name, units) of the summary scalars (the dataset prefixes them with ``calippso_``).
VARIABLES: dict[str, tuple[str, str]] = {
    "phi": ("packing fraction of the CALiPPSO-jammed packing", "1"),
    "delta_phi": ("packing fraction change, CALiPPSO minus input (MLS)", "1"),
    "iterations": ("linear programs solved", "1"),
    "converged": ("1 if both convergence tolerances were met", "1"),
    "is_isostatic": ("1 if N_c = d (N_s - 1) + 1 among non-rattlers", "1"),
    "rattler_fraction": ("fraction of rattlers (outside the (d+1)-core of the contact network)", "1"),
    "force_balance_residual": ("largest net contact force on a non-rattler, in units of the mean force", "1"),
    "n_contacts": ("contacts among non-rattlers N_c", "1"),
    "n_stable": ("non-rattlers N_s", "1"),
    "isostatic_excess": ("N_c - (d (N_s - 1) + 1)", "1"),
    "wall_time": ("wall time of the CALiPPSO run", "s"),
    "gap_gamma": ("small-gap power-law exponent gamma of P(h) ~ h^-gamma (mean field 0.41269)", "1"),
    "force_theta_all": ("small-force exponent theta of P(f) ~ f^theta, all contacts", "1"),
    "force_theta_extended": ("small-force exponent theta_e, extended contacts (mean field 0.42311)", "1"),
}


def distributions(result: CalippsoResult) -> dict[str, float]:
    """Flat scalars of the small-argument fits of one jammed packing (for the results dataset)."""
    g = gap_exponent(result.gaps)
    f_all = force_exponent(result.forces)
    f_ext = force_exponent(extended_forces(result))
    return {
        "gap_gamma": g.exponent, "gap_gamma_stderr": g.stderr, "gap_fit_n": float(g.n),
        "gap_fit_lo": g.lo, "gap_fit_hi": g.hi,
        "force_theta_all": f_all.exponent, "force_theta_all_stderr": f_all.stderr, "force_fit_n": float(f_all.n),
        "force_theta_extended": f_ext.exponent, "force_theta_extended_stderr": f_ext.stderr,
        "force_extended_fit_n": float(f_ext.n), "force_fit_lo": f_all.lo, "force_fit_hi": f_all.hi,
    }
