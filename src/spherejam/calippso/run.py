"""CALiPPSO: jam a hard-sphere packing by iterative linear programming, with contact forces from the LP duals.

Artiaco, Díaz Hernández Rojas, Parisi, Ricci-Tersenghi, Phys. Rev. E 106, 055310 (2022), following the reference code
CALiPPSO.jl v0.2.2 with the deviations listed in docs/calippso.md (cited as "docs §x").

:func:`run_calippso` is the driver. Each iteration takes the cutoff l, the bound s_bound and Gamma_max from
:mod:`.schedule` (docs §1.3-§1.6), builds the pair rows (:mod:`.constraints`), solves the LP (:mod:`.lp`, or from the
previous LP's contact network by :mod:`.active_set`: docs §5), reads the contact network from the duals
(:mod:`.network`, docs §3), then moves r_i <- r_i + s_i and inflates every diameter by sqrt(Gamma), Gamma being the
LP's inflation factor (``inflation`` in the code). Lengths inside are in units of the *initial* largest diameter. It
stops when sqrt(Gamma) - 1 <= ``inflation_tolerance`` and max |s_{i,mu}| over non-rattlers <=
``displacement_tolerance`` times the current largest diameter (docs §2.1), then solves one more LP at the final
positions for the forces (docs §2.3). Checkpoints: docs §7.
"""

from __future__ import annotations

import logging
import math
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ..core import interrupt
from ..core.calippso_path import interior_steps_at
from ..core.checkpoint import Checkpoint, fingerprint
from ..core.errors import OverlapError, SimulationError, require
from ..core.history import History
from ..core.neighbours import Frame, pairs_within
from ..core.packing import DEFAULT_OVERLAP_TOLERANCE, Packing
from ..core.progress import Progress
from .active_set import (PIVOTS_PER_CHANGE, network_pivot_limit, network_prediction, solve_active_set,
                         vertex_prediction)
from .constraints import Pins, as_pins, closable_reach, cutoff_rows, pair_keys
from .creep import creep_message, creeping
from .generation import GAMMA_GUESS_FACTOR, near_rows, solve_generated
from .lp import NEAR_CONVERGED_SCALE, WARM_START_MAX_N, highs_version, resolve_solver, solve_lp
from .lp_log import LPLog
from .network import (balanced_forces, contact_network, escape_motion, free_directions, initial_pin, near_gaps,
                      repin)
from .schedule import (REFERENCE_INITIAL_SQRT_INFLATION, REGIME_THRESHOLDS, SCHEDULES, cutoff_and_bound,
                       nearest_gap_median, step_limits)
from .solution import LPBasis, LPSolution, METHOD_CODES, SOLVER_CODES
from .walls import LPWalls

_log = logging.getLogger("spherejam")

#: Largest correction of sqrt(Gamma) tolerated for solver round-off before the step is declared broken (docs §1.8).
MAX_OVERLAP_CORRECTION = 1e-8
CHECKPOINT_KIND = "calippso"
#: Why a run stopped: both tolerances met, the iteration cap reached first, or the tolerances met without a force
#: network to certify (no contact among non-rattlers, or forces that do not balance: :func:`has_force_network`).
STOP_REASONS = ("converged", "max_iterations", "no_force_network")
#: With ``interior_steps``, an LP whose previous sqrt(Gamma) - 1 exceeds this is an intermediate step taken from the
#: interior point; below it the LPs are vertices again, which the convergence test needs (docs §10).
INTERIOR_STEP_MIN = 1e-9
#: On either path, an LP whose interior point's vertex is not certified steps from that interior point where the
#: alternative is a crossover (lp.solve_lp's ``interior_fallback``), unless the point's sqrt(Gamma) - 1 is within this
#: factor of ``inflation_tolerance``: only such an LP can be the run's last, whose test needs a vertex (docs §5.2).
LAST_LP_MARGIN = 10.0
#: A cold HiGHS solve (N >= SCALED_MIN_N: no warm start, lp.WARM_START_MAX_N) gets its LP in lp.NEAR_CONVERGED_SCALE
#: units once the previous sqrt(Gamma) - 1 is below SCALED_BELOW: at 1e-11 HiGHS's interior point predicted nothing
#: and its crossover failed, while at 1e-10 - 5e-10 it gave the scaled solve's vertex in 0.4-0.8 of its time
#: (docs §5.8)
SCALED_BELOW = 1e-10
SCALED_MIN_N = WARM_START_MAX_N
#: Parameters a resumed run may change (the same trajectory): they do not enter the checkpoint's fingerprint.
RESUMABLE_CHANGES = ("max_iterations", "threads")
#: Settings that choose only how the LPs are solved, and so the trajectory, never the convergence criteria: a run
#: may be resumed from a checkpoint written under other values of them (docs §10.6). The output's parameters then
#: list each change and the LP it took effect at (``trajectory_changes``).
#: The schedule may change between "adaptive" and "trust", which start alike; the reference's starts from another
#: sqrt(Gamma_prev) (``initial_sqrt_inflation``, part of the fingerprint).
TRAJECTORY_CHANGES = ("interior_steps", "solver", "crossover", "active_set", "warm_start", "constraint_generation",
                      "schedule")


# --- result -----------------------------------------------------------------------------------------------------


@dataclass
class CalippsoResult:
    """A CALiPPSO run.

    Attributes
    ----------
    packing : Packing
        The jammed packing with ACTUAL diameters (same box and length unit as the input); metadata
        ``algorithm="calippso"``, ``parameters``, ``counters``.
    stop_reason : str
        One of :data:`STOP_REASONS`: "converged" (both tolerances met, and a force network certifies it),
        "max_iterations", or "no_force_network" (the tolerances met, but no contact among non-rattlers or an
        infinite force balance: nothing is certified).
    iterations : int
        LPs solved in the main loop (the final force LP not included).
    history : dict of arrays, one row per iteration
        ``sqrt_inflation_minus_1`` (sqrt(Gamma) - 1), ``max_displacement`` (non-rattlers, units of the largest
        diameter), ``max_displacement_all``, ``phi``, ``n_constraints``, ``solve_time`` (s), ``cpu_time`` (CPU s of
        this process for the LP, incl. a failed active-set attempt: the figure to compare on a busy machine),
        ``cutoff`` and ``s_bound`` (units of the largest diameter), ``regime``, ``method`` (:data:`METHOD_CODES`),
        ``solver`` (:data:`SOLVER_CODES`), ``n_contacts``, ``n_rattlers``, ``isostatic``, ``overlap_correction``,
        ``contact_changes`` (contacts among non-rattlers gained or lost since the previous LP; -1 for the first),
        ``contacts_gained`` and ``contacts_lost`` (the two parts of it; -1 for the first), ``iteration_cpu_time``
        and ``iteration_wall_time`` (s, the whole iteration: rows, solve, contact network, step),
        ``bound_active`` (s components of non-rattlers at their bound), ``lp_rows`` (rows of the LP as solved:
        fewer than ``n_constraints`` under constraint generation) and ``rows_added`` (rows constraint generation
        added after the first solve, docs §5.7).
    pairs : (K, 2) int array
        Contacts i < j among non-rattlers (a contact = pair with a positive dual, docs §3).
    forces : (K,) float array
        Contact force magnitudes f_ij = lambda_ij r_ij, divided by their mean (so mean 1; in a container the mean
        is over the wall forces too, ``wall_forces``).
    contact_vectors : (K, d) float array
        Unit vectors (r_i - r_j)/|r_i - r_j| (of the contact's image: in a small box a pair may touch through
        several images and is listed once per image): the force on i from j is ``forces * contact_vectors``.
    rattlers : (N,) bool array
        Particles outside the (d+1)-core of the contact graph.
    n_contacts : int
        Contacts among non-rattlers, N_c (sphere-wall contacts included).
    isostatic : bool
        N_c == d (N_s - 1) + 1 with N_s non-rattlers (one state of self-stress); in a container N_c == d N_s - z + 1,
        z its zero modes (``Container.isostatic_contacts``, docs/containers.md §4); less ``free_directions``.
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
    wall_contacts, walls, wall_forces, wall_vectors : arrays
        In a container (docs/containers.md §5): the sphere of each contact with a wall among non-rattlers, its wall
        (the planes in axis order, low side first, then the curved wall), the force (in units of the mean over every
        contact, walls included; ``forces`` shares that unit) and its unit vector from the wall to the centre (the
        wall pushes the sphere along it). Empty in a periodic box.
    free_directions : int
        F, the directions of the partial rattlers (non-rattlers whose contacts span fewer than d dimensions) that no
        contact loads; the isostatic count is d N_s - z + 1 - F (docs/containers.md §4, §5). 0 in a generic packing.
    """

    packing: Packing
    stop_reason: str
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
    wall_contacts: np.ndarray = field(default_factory=lambda: np.empty(0, dtype=np.int64))
    walls: np.ndarray = field(default_factory=lambda: np.empty(0, dtype=np.int64))
    wall_forces: np.ndarray = field(default_factory=lambda: np.empty(0))
    wall_vectors: np.ndarray = field(default_factory=lambda: np.empty((0, 3)))
    free_directions: int = 0

    @property
    def completed(self) -> bool:
        """Both convergence tolerances were met (``stop_reason == "converged"``)."""
        return self.stop_reason == "converged"

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
        """Flat scalars for a results table (flags as 0/1; names and meanings in :data:`VARIABLES`)."""
        return {
            "phi": self.packing.phi,
            "delta_phi": self.packing.phi - self.phi_initial,
            "iterations": float(self.iterations),
            "converged": float(self.completed),
            "is_isostatic": float(self.isostatic),
            "rattler_fraction": self.n_rattlers / self.rattlers.size,
            "force_balance_residual": self.force_balance_residual,
            "n_contacts": float(self.n_contacts),
            "n_stable": float(self.n_stable),
            "isostatic_excess": float(self.n_contacts - self.packing.container.isostatic_contacts(
                self.n_stable, self.free_directions)),
            "wall_time": self.wall_time,
        }


#: name -> (long_name, units) of the scalars of :meth:`CalippsoResult.summary`. A CALiPPSO summary file adds, for a
#: converged run, the fitted exponents of the analysis layer (``spherejam.analysis.distributions.VARIABLES``); the
#: dataset prefixes both with ``calippso_``.
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
}


# --- the driver -------------------------------------------------------------------------------------------------------


def _validate(packing, max_iterations, inflation_tolerance, displacement_tolerance, s_bound, cutoff,
              initial_sqrt_inflation, zero_force, solver_tolerance, overlap_tolerance, gap_range, progress_interval,
              regime_thresholds, threads, schedule):
    require(isinstance(packing, Packing), "packing", type(packing).__name__, "must be a Packing")
    require(isinstance(max_iterations, (int, np.integer)) and max_iterations >= 1, "max_iterations",
            max_iterations, "must be an integer >= 1")
    for name, value in (("inflation_tolerance", inflation_tolerance),
                        ("displacement_tolerance", displacement_tolerance),
                        ("zero_force", zero_force), ("solver_tolerance", solver_tolerance),
                        ("overlap_tolerance", overlap_tolerance), ("gap_range", gap_range)):
        require(isinstance(value, (int, float)) and math.isfinite(value) and value > 0, name, value,
                "must be a finite number > 0")
    require(isinstance(progress_interval, (int, float)) and progress_interval >= 0, "progress_interval",
            progress_interval, "must be a number >= 0")
    require(1e-10 <= solver_tolerance <= 1e-5, "solver_tolerance", solver_tolerance, "must be in [1e-10, 1e-5]")
    require(s_bound is None or (math.isfinite(s_bound) and 0 < s_bound < 0.5), "s_bound", s_bound,
            "must be None or in (0, 0.5) (units of the largest diameter)")
    require(cutoff is None or (math.isfinite(cutoff) and cutoff > 1), "cutoff", cutoff,
            "must be None or > 1 (units of the initial largest diameter)")
    require(initial_sqrt_inflation is None or (math.isfinite(initial_sqrt_inflation) and initial_sqrt_inflation >= 1),
            "initial_sqrt_inflation", initial_sqrt_inflation, "must be None or >= 1")
    th = tuple(regime_thresholds)
    require(len(th) == 2 and all(math.isfinite(t) and t > 0 for t in th) and th[0] > th[1], "regime_thresholds",
            regime_thresholds, "must be two numbers > 0, the first larger")
    require(isinstance(threads, (int, np.integer)) and threads >= 1, "threads", threads, "must be an integer >= 1")
    require(schedule in SCHEDULES, "schedule", schedule, f"must be one of {', '.join(SCHEDULES)}")


def run_calippso(
    packing: Packing,
    *,
    max_iterations: int = 1000,
    inflation_tolerance: float = 1e-12,
    displacement_tolerance: float = 1e-9,
    s_bound: float | None = None,
    cutoff: float | None = None,
    initial_sqrt_inflation: float | None = None,
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
    constraint_generation: bool = False,
    schedule: str = "adaptive",
    interior_steps: bool | None = None,
    lp_log: str | Path | None = None,
) -> CalippsoResult:
    """Jam ``packing`` with CALiPPSO and return the jammed packing, its contact network and forces.

    Parameters
    ----------
    packing : Packing
        Overlap-free start (any d from 2 to 5, any polydispersity); overlaps beyond ``overlap_tolerance`` raise
        :class:`OverlapError`. Any box: a pair that meets through several periodic images has a row for
        each (docs §1.2).
    max_iterations : int
        Iteration cap (1000). Not converged by then: ``stop_reason="max_iterations"`` (or an error if
        ``require_convergence``).
    inflation_tolerance : float
        Convergence when sqrt(Gamma) - 1 <= this (1e-12; Gamma is the LP's inflation factor) ...
    displacement_tolerance : float
        ... and max |s_{i,mu}| over non-rattlers <= this times the current largest diameter (1e-9).
    s_bound : float or None
        Fixed per-component displacement bound, in units of the current largest diameter; None = the regimes of
        docs §1.3 (0.05 / 0.005 of the diameter near jamming).
    cutoff : float or None
        l0, the regime-1 cutoff on centre distances, in units of the initial largest diameter; None = 2 (4 R0).
        It is enlarged automatically when it becomes too small (docs §1.4).
    initial_sqrt_inflation : float or None
        sqrt(Gamma_prev) for the first regime choice; None = 1 + median nearest-neighbour gap (docs §1.6) under the
        adaptive schedule, 1.01 under the reference's.
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
        Try the certified active-set solve (:func:`~.active_set.solve_active_set`) before HiGHS whenever the
        previous LP was isostatic and no warm start is available, and for the final force LP (True; docs §5.4).
        Off: every LP goes to HiGHS.
    warm_start : bool
        Start each HiGHS solve from the previous LP's basis (primal simplex), falling back to a cold solve
        (True; never from N = :data:`~.lp.WARM_START_MAX_N` on; docs §5.3). Off: a cold solve every time.
    require_convergence : bool
        Raise :class:`SimulationError` instead of returning an unconverged result.
    checkpoint : path or None
        Save the state there every ``checkpoint_interval`` seconds (>= 0) and when the run stops unconverged; a
        call with an existing checkpoint of the same input and parameters (``max_iterations`` and ``threads`` may
        differ) resumes from it and continues as the uninterrupted run would; one that differs also in
        :data:`TRAJECTORY_CHANGES` resumes too and continues on the new path (docs §10.6). Removed when the run
        converges.
    progress_interval : float
        Seconds between progress lines (logger ``spherejam``).
    solver : str
        HiGHS solver of a cold LP solve: "hipo" (sparse-direct interior point), "ipx" (interior point),
        "simplex" (dual simplex), or "auto" (the default: HiPO from :data:`~.lp.AUTO_HIPO_MIN_N` on, else IPX;
        docs §5.1). Recorded per LP in ``history["solver"]`` (:data:`SOLVER_CODES`) and, resolved, in the
        parameters.
    threads : int
        Threads of HiGHS and of HiPO's BLAS (1: workflow jobs get one core each). HiGHS keeps the count of a
        process's first solve.
    crossover : bool or None
        Always run HiGHS's crossover after an interior point (False: certify the interior point's active set with
        :func:`~.active_set.solve_active_set` and cross over only when that fails; both give exact vertex duals;
        docs §5.2). None (the default): False for HiPO, True for IPX, the faster pairing of each.
    constraint_generation : bool
        Solve each HiGHS LP over the rows of the pairs that can close in it, then add the other rows that its
        solution violates and re-solve (dual simplex from its basis) until none is (docs §5.7). The solution is
        an optimum of the full LP either way; off (the default), every row of the cutoff is in the LP.
    schedule : str
        The bounds schedule (docs §10): "adaptive" (the default; the first regime from the input's gaps, a bound
        that stops a stable particle widened, docs §1.5-§1.6) or "reference" (CALiPPSO.jl's: a loose regime-1 first
        LP from sqrt(Gamma_prev) = 1.01, then the regimes of the previous LP's sqrt(Gamma) alone, no widening) or
        "trust" (adaptive, with a trust region: s_bound in regimes 2 and 3 capped at
        :data:`~.schedule.TRUST_FACTOR` sqrt(sqrt(Gamma_prev) - 1) R, the cutoff shrunk with it, docs §10.7).
    interior_steps : bool or None
        Take an LP whose previous sqrt(Gamma) - 1 exceeds :data:`INTERIOR_STEP_MIN` as an intermediate step from its
        interior point, without crossover or a certified vertex (method "interior"; its rows and bounds are checked
        and the overlap guard of docs §1.8 applies); the LPs below it, the convergence test and the force LP take
        vertices as before (docs §10). Off: every LP is a vertex. None (the default): the one rule by N,
        :func:`~spherejam.core.calippso_path.interior_steps_at` (on from its ``INTERIOR_STEPS_MIN_N`` spheres;
        off at every N while that is None, docs §10.11); the parameters record what ran.
    lp_log : path or None
        Write the per-LP record there as CSV (:mod:`.lp_log`, docs §10), one row appended and flushed per LP;
        a resumed run rewrites it from its checkpoint's history first. Not part of the checkpoint's fingerprint.
    """
    _validate(packing, max_iterations, inflation_tolerance, displacement_tolerance, s_bound, cutoff,
              initial_sqrt_inflation, zero_force, solver_tolerance, overlap_tolerance, gap_range, progress_interval,
              regime_thresholds, threads, schedule)
    solver = resolve_solver(solver, packing.n)
    interior_steps = interior_steps_at(packing.n, interior_steps)
    wall0 = time.perf_counter()
    report = packing.check(overlap_tolerance)
    if not report.ok:
        raise OverlapError(f"CALiPPSO input: {report}")
    cfg = _settings(packing, cutoff, s_bound, regime_thresholds, zero_force, inflation_tolerance,
                    displacement_tolerance, solver_tolerance, solver_options, solver, threads, crossover, active_set,
                    warm_start, constraint_generation, schedule, interior_steps)
    run = _Run.start(packing, cfg, initial_sqrt_inflation)
    parameters = _parameters(cfg, run.loop.sqrt_inflation_prev, max_iterations, overlap_tolerance, fine_tune,
                             warm_start)
    hashed = {k: v for k, v in parameters.items() if k not in RESUMABLE_CHANGES}
    if cfg.walls is not None:  # the cube's fingerprint stays as it was
        hashed["container"] = packing.container.to_dict()
    ckpt = Checkpoint(checkpoint, CHECKPOINT_KIND, fingerprint(packing, CHECKPOINT_KIND, hashed), checkpoint_interval)
    run.trajectory = {k: parameters[k] for k in TRAJECTORY_CHANGES}
    run.resume(ckpt, _EarlierTrajectory(packing, hashed))
    if run.changes:
        parameters = {**parameters, "trajectory_changes": run.changes}
    log = LPLog(lp_log)
    log.start(run.history.as_arrays())
    progress = Progress(f"calippso N={cfg.n} d={cfg.dim}", progress_interval)
    converged = _iterate(run, cfg, ckpt, checkpoint, max_iterations, progress, log)
    while converged and _escape(run, cfg):  # converged, but not held: go on (bounded by max_iterations)
        converged = _iterate(run, cfg, ckpt, checkpoint, max_iterations, progress, log)
    if not converged and require_convergence:
        raise SimulationError(f"CALiPPSO did not converge in {max_iterations} iterations "
                              f"(last sqrt(Gamma)-1 = {run.history.last('sqrt_inflation_minus_1'):.3e}, "
                              f"max|s| = {run.history.last('max_displacement'):.3e})")
    result = _result(packing, run, cfg, parameters, ckpt, converged, fine_tune, gap_range, overlap_tolerance, wall0)
    if result.stop_reason == "no_force_network" and require_convergence:
        raise SimulationError(no_force_network_message(result))
    return result


def has_force_network(n_contacts: float, force_balance_residual: float) -> bool:
    """A CALiPPSO certificate certifies something: contacts among non-rattlers whose forces balance (a finite
    residual). The one rule of the run's ``converged`` and of the dataset's rows (docs/robustness.md)."""
    return bool(n_contacts > 0 and math.isfinite(force_balance_residual))


def no_force_network_message(result: CalippsoResult) -> str:
    """One line: why a run whose LPs converged certifies nothing."""
    box, d_max = result.packing.box, float(result.packing.diameters.max())
    why = (f"; the largest sphere (D = {d_max:.6g}) spans the box (L = {box:.6g}) and touches its own image, a "
           "contact the LP does not have" if d_max >= box * (1 - 1e-6) else "")
    return (f"CALiPPSO's LPs converged but left no force network ({result.n_contacts} contacts among non-rattlers, "
            f"{result.n_rattlers} of {result.rattlers.size} spheres rattlers, force balance "
            f"{result.force_balance_residual:.3g}){why}: nothing certified")


# --- setting a run up and assembling its result -----------------------------------------------------------------------


def _settings(packing, cutoff, s_bound, regime_thresholds, zero_force, inflation_tolerance, displacement_tolerance,
              solver_tolerance, solver_options, solver, threads, crossover, active_set, warm_start,
              constraint_generation, schedule, interior_steps) -> _Settings:
    """The run's fixed choices in the driver's units (lengths in initial largest diameters); ``crossover`` None
    becomes False for HiPO, True otherwise (the faster pairing of each)."""
    n = packing.n
    unit = float(packing.diameters.max())  # internal length unit: the initial largest diameter
    container = packing.container
    walls, box, period = None, packing.box / unit, packing.box / unit
    if not container.is_periodic_cube:  # any other container: its frame, walls and zero modes (docs/containers.md §5)
        walls = LPWalls.of(container, unit, n)
        box = Frame.of(walls.container)
        period = min((L for L, p in zip(walls.container.lengths, walls.container.periodic) if p), default=math.inf)
    return _Settings(
        n=n, dim=packing.dim, unit=unit, box=box, period=period, walls=walls,
        cutoff0=2.0 if cutoff is None else float(cutoff),
        s_bound=s_bound, regime_thresholds=tuple(regime_thresholds), zero_force=zero_force,
        inflation_tolerance=inflation_tolerance, displacement_tolerance=displacement_tolerance,
        solver_tolerance=solver_tolerance,
        solver_options=solver_options, solver=solver, threads=int(threads),
        crossover=bool(solver != "hipo" if crossover is None else crossover), active_set=bool(active_set),
        constraint_generation=bool(constraint_generation), schedule=schedule, interior_steps=bool(interior_steps),
        warm_start=warm_start and n < WARM_START_MAX_N,  # no basis is kept either: the force LP starts cold too
    )


def _parameters(cfg: _Settings, initial_sqrt_inflation: float, max_iterations, overlap_tolerance, fine_tune,
                warm_start) -> dict[str, Any]:
    """The run's parameters as the output's metadata records them and the checkpoint's fingerprint hashes them
    (``warm_start`` as asked for, before the limit in N)."""
    return {
        "max_iterations": int(max_iterations), "inflation_tolerance": cfg.inflation_tolerance,
        "displacement_tolerance": cfg.displacement_tolerance, "s_bound": cfg.s_bound, "cutoff": cfg.cutoff0,
        "initial_sqrt_inflation": float(initial_sqrt_inflation), "regime_thresholds": list(cfg.regime_thresholds),
        "zero_force": cfg.zero_force, "solver_tolerance": cfg.solver_tolerance, "overlap_tolerance": overlap_tolerance,
        "fine_tune": bool(fine_tune), "active_set": cfg.active_set, "warm_start": bool(warm_start),
        "solver": cfg.solver, "threads": cfg.threads, "crossover": cfg.crossover,
        "constraint_generation": cfg.constraint_generation, "schedule": cfg.schedule,
        "interior_steps": cfg.interior_steps,
        "highs_version": highs_version(),
    }


class _EarlierTrajectory:
    """Accepts a checkpoint whose LPs were solved under other :data:`TRAJECTORY_CHANGES` and the same everything
    else (docs §10.6). A checkpoint records its settings (``trajectory``); one written before it did had the
    defaults of then (every LP a vertex: interior steps became a default later, docs §10.11)."""

    def __init__(self, packing: Packing, hashed: dict[str, Any]):
        self.packing, self.hashed = packing, hashed
        solver = resolve_solver("auto", packing.n)
        self.defaults = {"interior_steps": False, "solver": solver, "crossover": solver != "hipo",
                         "active_set": True, "warm_start": True, "constraint_generation": False,
                         "schedule": "adaptive"}

    def settings(self, attrs) -> dict[str, Any]:
        return {**self.defaults, **attrs.get("trajectory", {})}

    def __call__(self, attrs) -> bool:
        return attrs.get("fingerprint") == fingerprint(self.packing, CHECKPOINT_KIND,
                                                       {**self.hashed, **self.settings(attrs)})


def _result(packing, run: _Run, cfg: _Settings, parameters, ckpt, converged: bool, fine_tune: bool, gap_range: float,
            overlap_tolerance: float, wall0: float) -> CalippsoResult:
    """Assemble the result: the forces of one more LP (docs §2.3), their contact network and the gaps, the jammed
    packing in the input's units and the counters. The checkpoint goes once the run has converged; otherwise it is
    saved for a later call with a larger ``max_iterations`` to continue from."""
    lp, duals, fine_tuned, fine_inflation = _force_lp(run, cfg, fine_tune)
    pins = None if cfg.walls is None else _pins(run.loop, cfg)
    contact, rattler, n_contacts, isostatic, residual = contact_network(lp.rij, lp.sigma2, lp.pi, lp.pj, duals,
                                                                        cfg.nodes, cfg.dim, cfg.zero_force, pins)
    if converged and not has_force_network(n_contacts, residual):  # a degenerate dual (a crystal): seek the forces
        duals = balanced_forces(lp.rij, lp.sigma2, lp.pi, lp.pj, cfg.nodes, cfg.n)
        contact, rattler, n_contacts, isostatic, residual = contact_network(lp.rij, lp.sigma2, lp.pi, lp.pj, duals,
                                                                            cfg.nodes, cfg.dim, cfg.zero_force, pins)
    pairs, forces, vectors, stable_pair, on_wall = _contact_forces(lp, duals, contact, rattler, cfg.n)
    free = free_directions(lp.rij, contact & ~rattler[lp.pi] & ~rattler[lp.pj], lp.pi, lp.pj, rattler, cfg.n)
    gaps, gap_pairs = near_gaps(run.x, run.dia, cfg.box, gap_range, rattler,
                                pair_keys(lp.pi, lp.pj, cfg.nodes)[stable_pair], cfg.nodes)
    rattler = rattler[:cfg.n]
    out = _jammed_packing(packing, run.x * cfg.unit, run.dia * cfg.unit, parameters)
    final_report = out.check(overlap_tolerance)
    if not final_report.ok:  # cannot happen by construction; never return an overlapping packing
        raise SimulationError(f"CALiPPSO output overlaps: {final_report}")
    wall = time.perf_counter() - wall0
    stop_reason = "converged" if converged else "max_iterations"
    if converged and not has_force_network(n_contacts, residual):  # converged LPs, nothing that certifies them
        stop_reason, converged = "no_force_network", False
        ckpt.discard()  # more iterations would not make one
    phi_initial = packing.phi
    counters = {
        "iterations": run.iteration, "stop_reason": stop_reason, "converged": converged,
        "lp_time": run.tally.lp_time, "lp_cpu_time": run.tally.lp_cpu_time, "wall_time": wall,
        "lp_methods": run.tally.methods, "lp_solvers": run.tally.solvers, "warm_attempts": run.tally.warm_attempts,
        "fine_tuned": fine_tuned,
        "fine_tune_sqrt_inflation_minus_1": math.sqrt(fine_inflation) - 1.0 if fine_inflation > 0 else math.nan,
        "phi_initial": phi_initial, "phi_final": out.phi, "n_contacts": n_contacts,
        "n_rattlers": int(rattler.sum()), "isostatic": isostatic, "force_balance_residual": residual,
        "worst_overlap": final_report.worst_overlap, "pinned": int(run.loop.pinned),
        # a run that made no escape, with no partial rattler, records what it did before
        **({"escapes": run.loop.escapes} if run.loop.escapes else {}), **({"free_directions": free} if free else {}),
    }
    out.metadata["counters"] = counters
    if converged:
        ckpt.discard()
    elif stop_reason == "max_iterations":  # a later call with a larger max_iterations continues from here
        run.save(ckpt)
    return CalippsoResult(
        packing=out, stop_reason=stop_reason, iterations=run.iteration, history=run.history.as_arrays(),
        pairs=pairs, forces=forces, contact_vectors=vectors, rattlers=rattler, n_contacts=n_contacts,
        isostatic=isostatic, force_balance_residual=residual, gaps=gaps, gap_pairs=gap_pairs, phi_initial=phi_initial,
        wall_time=wall, fine_tuned=fine_tuned, counters=counters, free_directions=free, **on_wall,
    )


def _contact_forces(lp: _LP, duals, contact, rattler, n: int):
    """The contacts among non-rattlers: ``(pairs (K, 2), forces f_ij = lambda_ij r_ij divided by their mean, unit
    vectors (r_i - r_j)/|r_i - r_j|, the mask of these sphere-sphere rows among the LP's, the wall contacts)``. Rows
    with a node >= ``n`` are a container's wall contacts (docs/containers.md §5), returned apart as the
    :class:`CalippsoResult` fields ``wall_contacts``, ``walls``, ``wall_forces``, ``wall_vectors``; the mean force
    is over every contact, walls included."""
    stable = contact & ~rattler[lp.pi] & ~rattler[lp.pj]
    r_norm = np.linalg.norm(lp.rij, axis=1)
    f = duals * r_norm
    mean = f[stable].mean() if np.any(stable) else 1.0
    stable_pair = stable & (lp.pj < n)
    forces = f[stable_pair] / mean
    pairs = np.stack([lp.pi[stable_pair], lp.pj[stable_pair]], axis=1)
    vectors = lp.rij[stable_pair] / r_norm[stable_pair, None]
    on = stable & (lp.pj >= n)
    on_wall = {"wall_contacts": lp.pi[on], "walls": lp.pj[on] - n, "wall_forces": f[on] / mean,
               "wall_vectors": lp.rij[on] / r_norm[on, None]}
    return pairs, forces, vectors, stable_pair, on_wall


def _jammed_packing(packing: Packing, positions, diameters, parameters) -> Packing:
    """The output packing: the input's box or container and metadata (but its provenance and pressure), marked as
    CALiPPSO's."""
    return Packing(
        positions, diameters, packing.box,
        {
            **{k: v for k, v in packing.metadata.items() if k not in ("provenance", "reduced_pressure")},
            "algorithm": "calippso",
            "parameters": {**parameters, "input_algorithm": packing.metadata.get("algorithm")},
        },
        None if packing.container.is_periodic_cube else packing.container,
    )


# --- the main loop: iterate until converged, each iteration in its steps (docs §1-§2) --------------------------------


def _iterate(run: _Run, cfg: _Settings, ckpt: Checkpoint, checkpoint, max_iterations: int, progress: Progress,
             log: LPLog) -> bool:
    """Iterate until both tolerances are met (True) or ``max_iterations`` LPs have been solved (False). Each LP's
    history row goes to the LP log at once; the state is saved whenever the checkpoint is due, and on
    SIGTERM/SIGINT, which then stop the run."""
    told = False  # the creep is told once per process
    while run.iteration < max_iterations:
        sqrt_inflation, max_s = _iteration(run, cfg, progress)
        columns = run.history.as_arrays()
        log.append({k: run.history.last(k) for k in columns}, run.iteration)
        vertex = run.last[1].method_name != "interior"  # an interior step's s is no vertex's: never converged on
        if cfg.walls is not None:  # a step deflated by a curved wall's margin is no closer to jamming
            sqrt_inflation = 1.0 + abs(sqrt_inflation - 1.0)
        if vertex and _converged(sqrt_inflation, max_s, cfg.inflation_tolerance, cfg.displacement_tolerance):
            return True
        if not told:
            told = creeping(columns["sqrt_inflation_minus_1"], columns["contact_changes"])
            if told:
                _log.warning(creep_message(run.iteration, sqrt_inflation - 1.0))
        if ckpt.due():
            run.save(ckpt)
        if interrupt.requested() is not None:  # SIGTERM/SIGINT: save and stop
            run.save(ckpt)
            interrupt.stop(checkpoint, f"after {run.iteration} iterations")
    return False


def _iteration(run: _Run, cfg: _Settings, progress: Progress) -> tuple[float, float]:
    """One iteration: schedule, solve, check, step, record, hand over. Returns what convergence is judged on:
    ``(sqrt(Gamma) as applied, max |s_{i,mu}| over non-rattlers in units of the largest diameter)``."""
    loop = run.loop
    cpu_it, wall_it = time.process_time(), time.perf_counter()
    previous = None
    if run.iteration > 0 and cfg.walls is not None:
        previous = run.history.last("max_displacement") * float(run.dia.max())
    lp = _schedule(run.x, run.dia, loop, cfg, previous)
    cpu0 = time.process_time()
    sol = _solve(lp, loop, cfg, run.tally, run.iteration)
    run.iteration += 1
    lp_cpu = time.process_time() - cpu0
    run.tally.count(sol, lp_cpu)
    contact, rattler, n_contacts, isostatic, gained, lost = _check(lp, sol, loop, cfg)
    at_bound = int(np.count_nonzero(np.abs(sol.s[~rattler]) >= (1.0 - 1e-9) * lp.s_bound))  # docs §1.5
    run.x, run.dia, sqrt_inflation, correction = _step(run.x, run.dia, sol, lp, cfg, run.iteration)
    max_s, max_s_all = _largest_displacements(sol.s, rattler, run.dia)
    phi = _phi(run.dia, cfg)
    run.history.append(
        sqrt_inflation_minus_1=sqrt_inflation - 1.0, max_displacement=max_s, max_displacement_all=max_s_all,
        phi=phi, n_constraints=len(lp.pi), solve_time=sol.solve_time, cpu_time=lp_cpu,
        cutoff=lp.ell / run.dia.max(), s_bound=lp.s_bound / run.dia.max(), regime=lp.regime,
        method=METHOD_CODES[sol.method_name], solver=SOLVER_CODES[sol.solver], n_contacts=n_contacts,
        n_rattlers=int(np.count_nonzero(rattler)), isostatic=int(isostatic), overlap_correction=correction,
        contact_changes=gained + lost if gained >= 0 else -1, contacts_gained=gained, contacts_lost=lost,
        bound_active=at_bound, lp_rows=sol.rows if sol.rows >= 0 else len(lp.pi), rows_added=sol.rows_added,
        iteration_cpu_time=time.process_time() - cpu_it, iteration_wall_time=time.perf_counter() - wall_it,
    )
    progress.update(
        f"it {run.iteration}: sqrt(G)-1 {sqrt_inflation - 1:.3e}, max|s| {max_s:.3e}, phi {phi:.8f}, "
        f"rows {len(lp.pi)}, contacts {n_contacts}, rattlers {int(rattler.sum())}, iso {isostatic}, "
        f"LP {sol.solve_time:.2f} s, CPU {lp_cpu:.2f} s ({sol.method}, {sol.solver})",
        fields={"LP": run.iteration, "√Γ-1": sqrt_inflation - 1.0, "LP time": f"{sol.solve_time:.2f} s"},
    )
    if sol.failed:  # what a fallback cost is spent on: in the log, not only in the method code
        _log.info("calippso it %d solved by %s after: %s", run.iteration, sol.method, sol.failed)
    run.last = (lp, sol, rattler)
    _hand_over(loop, lp, at_bound, contact, rattler, sqrt_inflation, cfg, run.x)
    return sqrt_inflation, max_s


# --- the steps of one iteration: schedule, solve, check, step, converge (docs §1-§2) ---------------------------------


@dataclass(frozen=True)
class _Settings:
    """The run's fixed choices, in the driver's units (lengths in initial largest diameters)."""

    n: int
    dim: int
    unit: float  # the initial largest diameter, in the input's length unit
    box: float | Frame  # the cube's side, or a container's frame (periodic along some axes only)
    period: float  # the shortest periodic length (inf: none): the cap of the cutoff (docs/calippso.md §1.4)
    walls: LPWalls | None  # a container's walls and zero modes (None: the periodic cube)
    cutoff0: float  # l0
    s_bound: float | None  # a fixed bound in units of the current largest diameter (None: the regimes)
    regime_thresholds: tuple[float, float]
    zero_force: float
    inflation_tolerance: float  # the convergence test's, on sqrt(Gamma) - 1 (docs §2.1)
    displacement_tolerance: float  # and on max |s_{i,mu}| of the non-rattlers, units of the largest diameter
    solver_tolerance: float
    solver_options: dict[str, Any] | None
    solver: str
    threads: int
    crossover: bool
    active_set: bool
    warm_start: bool
    constraint_generation: bool
    schedule: str  # the bounds schedule (schedule.SCHEDULES)
    interior_steps: bool  # intermediate LPs stepped from their interior point (docs §10)

    @property
    def nodes(self) -> int:
        """The LP's nodes: the spheres, then a container's walls (docs/containers.md §5)."""
        return self.n if self.walls is None else self.walls.nodes


@dataclass
class _LP:
    """One iteration's LP: its limits (docs §1.3-§1.5) and its pair rows (docs §1.1)."""

    ell: float  # cutoff l
    s_bound: float  # per-component bound
    inflation_max: float  # Gamma_max (docs §1.4)
    regime: int
    pi: np.ndarray
    pj: np.ndarray
    rij: np.ndarray
    sigma2: np.ndarray
    # Gamma's lower bound: 1, but below 1 where a curved wall's margin asks a sphere touching it for room it does
    # not have at s = 0 (docs/containers.md §5)
    inflation_min: float = 1.0

    def subset(self, rows: np.ndarray) -> _LP:
        """The same LP over the rows ``rows`` only."""
        return _LP(self.ell, self.s_bound, self.inflation_max, self.regime, self.pi[rows], self.pj[rows],
                   self.rij[rows], self.sigma2[rows], self.inflation_min)


@dataclass
class _Tally:
    """LP counts and times of this call (lp_time is carried over by a checkpoint, the CPU time is not)."""

    lp_time: float = 0.0
    lp_cpu_time: float = 0.0
    methods: dict[str, int] = field(default_factory=dict)
    solvers: dict[str, int] = field(default_factory=dict)  # "none": active set alone; incl. the force LP
    warm_attempts: int = 0

    def count(self, sol, cpu: float) -> None:
        self.lp_cpu_time += cpu
        self.lp_time += sol.solve_time
        self.methods[sol.method_name] = self.methods.get(sol.method_name, 0) + 1
        self.solvers[sol.solver] = self.solvers.get(sol.solver, 0) + 1


def _rows(x, dia, cfg: _Settings, ell, s_bound, inflation_max, regime=0, margin: bool = True) -> _LP:
    # only the pairs a step can close (docs §1.4): the same optimum as every pair within l, and in a polydisperse
    # packing a fraction of the rows, since l is set by the largest sphere
    reach = np.minimum(closable_reach(dia, math.sqrt(inflation_max), s_bound, x.shape[1]), ell)
    pi, pj, rij = cutoff_rows(x, cfg.box, reach)
    sigma2 = (0.5 * (dia[pi] + dia[pj])) ** 2
    if cfg.walls is not None:  # the sphere-wall rows a step can violate, after each sphere's pair rows
        wi, wj, wr, ws = cfg.walls.rows(x, dia, math.sqrt(inflation_max), s_bound, margin)
        pi, pj = np.concatenate([pi, wi]), np.concatenate([pj, wj])
        rij, sigma2 = np.concatenate([rij, wr]), np.concatenate([sigma2, ws])
        order = np.lexsort((pj, pi))  # stable: a pair's images keep their order by distance (docs §1.2)
        pi, pj, rij, sigma2 = pi[order], pj[order], rij[order], sigma2[order]
        if margin and cfg.walls.container.curved is not None and wi.size:
            # s = 0 stays feasible: a sphere at the wall with less room than its margin deflates the step a little
            inflation_min = min(1.0, float(np.min(np.einsum("ij,ij->i", wr, wr) / ws)) * (1.0 - 1e-12))
            return _LP(ell, s_bound, inflation_max, regime, pi, pj, rij, sigma2, inflation_min)
    return _LP(ell, s_bound, inflation_max, regime, pi, pj, rij, sigma2)


def _schedule(x, dia, loop, cfg: _Settings, previous_step: float | None = None) -> _LP:
    """Schedule: the cutoff, s bound and Gamma_max from the previous LP (docs §1.3-§1.6), and the LP's rows;
    ``previous_step`` is the previous LP's largest |s_mu| of a stable sphere (absolute; None before the first)."""
    R = 0.5 * float(dia.max())
    ell, sb, inflation_max, regime = step_limits(
        loop.sqrt_inflation_prev, R, cfg.cutoff0, cfg.dim, cfg.period, cfg.regime_thresholds,
        None if cfg.s_bound is None else cfg.s_bound * 2.0 * R, loop.prev_s_bound, loop.bound_hit,
        widen=cfg.schedule != "reference", trust=cfg.schedule == "trust")
    if cfg.walls is not None:  # a curved wall's margin vanishes with the steps (docs/containers.md §5)
        capped = cfg.walls.capped_bound(sb, previous_step, dia, math.sqrt(inflation_max))
        if capped < sb:
            sb = capped
            inflation_max = ((ell - 2.0 * math.sqrt(cfg.dim) * sb) / (2.0 * R)) ** 2
        if cfg.walls.container.curved is not None:
            # a small container: keep R - sqrt(Gamma_max) r >= 2 sqrt(m) s_bound for every sphere, so that the
            # margin is defined (half the room the largest sphere has at Gamma = 1 bounds the step)
            wall_r, across = cfg.walls.container.radius, math.sqrt(cfg.walls.across)
            sb = min(sb, (wall_r - R) / (4.0 * across))
            inflation_max = min(inflation_max, ((ell - 2.0 * math.sqrt(cfg.dim) * sb) / (2.0 * R)) ** 2,
                                ((wall_r - 2.0 * across * sb) / R) ** 2)
    return _rows(x, dia, cfg, ell, sb, inflation_max, regime)


def _solve(lp: _LP, loop, cfg: _Settings, tally: _Tally, iteration: int) -> LPSolution:
    """Solve: the previous contact network certified by the active-set solve where no warm start is at hand
    (docs §5.4), else HiGHS, warm-started from the previous basis with a back-off after failures (docs §5.1-§5.3)."""
    sol = None
    if cfg.interior_steps and loop.sqrt_inflation_prev - 1.0 > INTERIOR_STEP_MIN:  # docs §10
        return solve_lp(lp.rij, lp.sigma2, lp.pi, lp.pj, cfg.nodes, s_bound=lp.s_bound, pinned=_pins(loop, cfg),
                        inflation_bounds=(lp.inflation_min, lp.inflation_max), tolerance=cfg.solver_tolerance,
                        options=cfg.solver_options, iteration=iteration, solver=cfg.solver, threads=cfg.threads,
                        crossover=cfg.crossover, interior=True)
    # a warm-started HiGHS solve is faster than the active-set pivots (docs §5.4), so the main loop uses the
    # shortcut only when there is no basis to start from
    cold = loop.basis is None
    if loop.predicted is not None and cold and loop.contact_swaps * PIVOTS_PER_CHANGE > network_pivot_limit(cfg.n):
        # each contact that changes takes pivots, and the flow that changed them goes on (docs §5.4)
        _log.info("calippso it %d: the previous contact network is not tried: the last LP changed %d contacts, more "
                  "than its %d pivots allow (%d each)", iteration + 1, loop.contact_swaps, network_pivot_limit(cfg.n),
                  PIVOTS_PER_CHANGE)
    elif loop.predicted is not None and (cold or lp.regime == 1):
        t_try = time.perf_counter()
        why: list[str] = []
        keys, rattler, held = loop.predicted
        sol = solve_active_set(lp.rij, lp.sigma2, lp.pi, lp.pj, cfg.nodes, keys, rattler, s_bound=lp.s_bound,
                               pinned=_pins(loop, cfg), inflation_bounds=(lp.inflation_min, lp.inflation_max), why=why,
                               max_pivots=network_pivot_limit(cfg.n) if cold else None, fixed=held)
        if sol is None:
            tally.lp_time += time.perf_counter() - t_try  # a failed attempt is LP time too
            _log.info("calippso it %d: the previous contact network is not this LP's vertex (%.1f s): %s",
                      iteration + 1, time.perf_counter() - t_try, "; ".join(why))
    if sol is None:
        sol = _solve_highs(lp, loop, cfg, tally, iteration)
    return sol


def _lp_scale(loop, cfg: _Settings) -> float:
    """The unit of HiGHS's LP (:func:`~.lp.solve_lp`'s ``scale``): :data:`~.lp.NEAR_CONVERGED_SCALE` for a cold solve
    (N >= SCALED_MIN_N) once the last gain is below HiGHS's absolute tolerances (sqrt(Gamma) - 1 < SCALED_BELOW),
    else 1 (docs §5.8)."""
    if cfg.n >= SCALED_MIN_N and loop.sqrt_inflation_prev - 1.0 < SCALED_BELOW:
        return NEAR_CONVERGED_SCALE
    return 1.0


def _solve_highs(lp: _LP, loop, cfg: _Settings, tally: _Tally, iteration: int) -> LPSolution:
    """The HiGHS part of the solve: warm-started from the previous basis, with a back-off after failures (docs
    §5.3); under constraint generation over the near rows first, re-solved by dual simplex from its own basis while
    other rows are violated (docs §5.7)."""
    warm = loop.basis if lp.regime > 1 and loop.warm_skip == 0 else None
    loop.warm_skip = max(loop.warm_skip - 1, 0)
    first: list[LPSolution] = []  # the first round's solution: its method tells whether the warm start worked

    def highs(rows, previous: LPSolution | None) -> LPSolution:
        sub = lp if rows is None else lp.subset(rows)
        cuts = previous is not None and previous.basis is not None
        sol = solve_lp(sub.rij, sub.sigma2, sub.pi, sub.pj, cfg.nodes, s_bound=lp.s_bound, pinned=_pins(loop, cfg),
                       inflation_bounds=(lp.inflation_min, lp.inflation_max), tolerance=cfg.solver_tolerance,
                       options=cfg.solver_options, iteration=iteration, warm=previous.basis if cuts else warm,
                       solver=cfg.solver, threads=cfg.threads, crossover=cfg.crossover, cuts=cuts,
                       interior_fallback=LAST_LP_MARGIN * cfg.inflation_tolerance if rows is None else None,
                       scale=_lp_scale(loop, cfg))
        if previous is None:
            first.append(sol)
        return sol

    near = None
    if cfg.constraint_generation:
        guess = min(1.0 + GAMMA_GUESS_FACTOR * (loop.sqrt_inflation_prev - 1.0), math.sqrt(lp.inflation_max))
        near = near_rows(lp.rij, lp.sigma2, lp.s_bound, guess)
    if near is None or near.all():
        sol = highs(None, None)
    else:
        sol, rows, added = solve_generated(lp.rij, lp.sigma2, lp.pi, lp.pj, near, highs)
        sol.rows, sol.rows_added = rows, added
    loop.basis = sol.basis if cfg.warm_start else None
    if warm is not None:  # after k failed warm starts in a row the next 2^k - 1 LPs skip it (docs §5.3)
        tally.warm_attempts += 1
        loop.warm_failures = 0 if first[0].method == "warm" else loop.warm_failures + 1
        loop.warm_skip = 2**loop.warm_failures - 1
    return sol


def _check(lp: _LP, sol: LPSolution, loop, cfg: _Settings):
    """Check: the contact network of the LP's duals (docs §3); an isostatic one predicts the next LP's vertex, and so
    does one that is isostatic with the components held at the s bound (docs §5.4). Returns ``(contact mask,
    rattler mask, n_contacts, isostatic, gained, lost)``, the last two the contacts among non-rattlers gained and
    lost since the previous LP (-1 each for the first)."""
    pins = _pins(loop, cfg)
    contact, rattler, n_contacts, isostatic, _ = contact_network(lp.rij, lp.sigma2, lp.pi, lp.pj, sol.duals,
                                                                 cfg.nodes, cfg.dim, cfg.zero_force,
                                                                 None if cfg.walls is None else pins)
    network = network_prediction(contact, rattler, lp.pi, lp.pj, cfg.nodes)
    loop.predicted = None
    if sol.method_name == "interior":
        # an interior point's duals are no vertex's: nothing to predict from, and no basis to warm-start from
        loop.basis = None
    elif cfg.active_set and isostatic:
        loop.predicted = (*network, None)
    elif cfg.active_set:
        loop.predicted = vertex_prediction(contact, sol.duals, sol.s, lp.s_bound, lp.rij, lp.pi, lp.pj, cfg.nodes,
                                           pins)
    gained = lost = -1
    if loop.contacts is not None:
        gained = int(np.setdiff1d(network[0], loop.contacts, assume_unique=True).size)
        lost = int(np.setdiff1d(loop.contacts, network[0], assume_unique=True).size)
    loop.contacts = network[0]
    loop.contact_swaps = gained + lost if gained >= 0 else -1
    return contact, rattler, n_contacts, isostatic, gained, lost


def _step(x, dia, sol: LPSolution, lp: _LP, cfg: _Settings, iteration: int):
    """Step: move, inflate, and make sure round-off in the solver left no overlap, nor a sphere in a wall (docs §1.1,
    §1.8; docs/containers.md §5).

    Returns ``(positions, diameters, sqrt(Gamma) as applied, overlap correction)``."""
    sqrt_inflation = math.sqrt(max(sol.inflation, lp.inflation_min))
    dia = dia * sqrt_inflation
    x = _moved(x, sol.s[:cfg.n], cfg)  # the wall nodes' rows of s are 0
    h_min = _closest(x, dia, cfg)
    correction = 0.0
    if h_min < 1.0:
        correction = 1.0 - h_min
        if correction > MAX_OVERLAP_CORRECTION:
            raise SimulationError(
                f"CALiPPSO iteration {iteration}: the LP step overlaps by {correction:.3e} (relative); "
                "the linearised constraints or the cutoff were violated"
            )
        dia = dia * h_min
        sqrt_inflation *= h_min
    return x, dia, sqrt_inflation, correction


def _largest_displacements(s, rattler, dia) -> tuple[float, float]:
    """max |s_{i,mu}| over non-rattlers (all particles if every one is a rattler) and over all particles, in units
    of the current largest diameter."""
    moving = ~rattler if np.any(~rattler) else np.ones(len(s), dtype=bool)
    return (float(np.max(np.abs(s[moving]))) / float(dia.max()),
            float(np.max(np.abs(s))) / float(dia.max()))


def _hand_over(loop, lp: _LP, at_bound: int, contact, rattler, sqrt_inflation: float, cfg: _Settings, x) -> None:
    """What the next iteration's schedule needs from this one: a stable particle at its bound (docs §1.5), the
    bound, sqrt(Gamma), and the pinned particle (docs §1.7); in a container the gauge pins too, chosen again among
    non-rattlers when one of their spheres turned out a rattler (docs/containers.md §5)."""
    loop.bound_hit = at_bound > 0
    loop.prev_s_bound = lp.s_bound
    loop.sqrt_inflation_prev = sqrt_inflation
    if cfg.walls is None:
        if rattler[loop.pinned] and np.any(~rattler):
            loop.pinned = repin(contact, lp.pi, lp.pj, rattler, len(rattler))
        return
    sphere_rattler = rattler[:cfg.n]
    pinned = np.union1d(_pins(loop, cfg).pinned_spheres(), [loop.pinned])
    if np.any(sphere_rattler[pinned]) and np.any(~sphere_rattler):
        if sphere_rattler[loop.pinned]:
            loop.pinned = repin(contact, lp.pi, lp.pj, rattler, len(rattler), cfg.n)
        loop.gauge = cfg.walls.gauge(x, loop.pinned, sphere_rattler).gauge


#: An unheld sphere's escape (docs/containers.md §5): a step of this many largest diameters along the motion that
#: frees it, halved until it overlaps nothing; its loaded contacts open by ~(1e-3)^2 / 2 of a diameter, far above
#: the LP's tolerances, so that the next LPs see the room the network gains.
ESCAPE_STEP = 1e-3


#: An escape after which the LPs converged with phi grown by less than this (relative) freed nothing: the spheres it
#: moved fell back to where their touching rows hold them, and no further escape is tried.
ESCAPE_GAIN = 1e-9


def _escape(run: _Run, cfg: _Settings) -> bool:
    """After convergence: if the last LP's duals load spheres that are not held (:func:`~.network.escape_motion`),
    take a step of :data:`ESCAPE_STEP` largest diameters along the motion that frees them, halved until it overlaps
    nothing, and return True; False (nothing moved) if there is no such motion, or if the previous escape did not
    raise phi by :data:`ESCAPE_GAIN`. Their loaded contacts open at second order, so the network that held the
    packing at first order no longer does, and the LPs go on (docs/containers.md §5)."""
    phi = _phi(run.dia, cfg)
    if run.loop.escapes and phi <= run.loop.escape_phi * (1.0 + ESCAPE_GAIN):  # the last one freed nothing
        return False
    lp, sol, _ = run.last
    pins = as_pins(_pins(run.loop, cfg), cfg.nodes, cfg.dim)
    step = ESCAPE_STEP * float(run.dia.max())
    v = escape_motion(lp.rij, lp.sigma2, lp.pi, lp.pj, sol.duals, cfg.nodes, cfg.dim, cfg.zero_force, pins, step)
    if v is None:
        return False
    floor = min(1.0, _closest(run.x, run.dia, cfg))
    for _ in range(30):
        x = _moved(run.x, step * v[:cfg.n], cfg)
        if _closest(x, run.dia, cfg) >= floor:
            run.x = x
            run.loop.predicted = None  # the last network is not the next LP's
            run.loop.escapes += 1
            run.loop.escape_phi = phi
            return True
        step *= 0.5
    return False


def _converged(sqrt_inflation: float, max_s: float, inflation_tolerance: float,
               displacement_tolerance: float) -> bool:
    """Converge: sqrt(Gamma) - 1 and the largest displacement of a non-rattler both within tolerance (docs §2.1)."""
    return sqrt_inflation - 1.0 <= inflation_tolerance and max_s <= displacement_tolerance


def _force_lp(run: _Run, cfg: _Settings, fine_tune: bool):
    """The forces: one more LP at the final configuration, s bounded by R only and Gamma free; nothing moves
    (docs §2.3). Returns ``(the LP, its duals, fine_tuned, its Gamma)``; without it (``fine_tune`` off, or it
    failed) the last main-loop LP and its duals."""
    loop, tally, iteration = run.loop, run.tally, run.iteration
    R = 0.5 * float(run.dia.max())
    # the final regime's rows: a superset of the contacts, which are all this LP needs
    ell, sb, inflation_max, _ = cutoff_and_bound(1.0, R, cfg.cutoff0, cfg.dim, cfg.period, cfg.regime_thresholds)
    # no margin on a curved wall's rows: this LP takes no step, and its tangent rows are the wall's to first order
    lp = _rows(run.x, run.dia, cfg, ell, sb, inflation_max, margin=False)
    cpu0 = time.process_time()
    if fine_tune:
        try:
            fine = None
            if loop.predicted is not None and loop.predicted[2] is None:  # an isostatic network, no bound held
                fine = solve_active_set(lp.rij, lp.sigma2, lp.pi, lp.pj, cfg.nodes, *loop.predicted[:2], s_bound=R,
                                        pinned=_pins(loop, cfg), inflation_bounds=(-math.inf, math.inf),
                                        max_pivots=network_pivot_limit(cfg.n) if loop.basis is None else None)
            if fine is None:
                fine = solve_lp(lp.rij, lp.sigma2, lp.pi, lp.pj, cfg.nodes, s_bound=R, pinned=_pins(loop, cfg),
                                inflation_bounds=(-math.inf, math.inf), tolerance=cfg.solver_tolerance,
                                options=cfg.solver_options, iteration=iteration + 1, warm=loop.basis,
                                solver=cfg.solver, threads=cfg.threads, crossover=cfg.crossover)
            tally.count(fine, time.process_time() - cpu0)
            return lp, fine.duals, True, fine.inflation
        except SimulationError:
            pass
    tally.lp_cpu_time += time.process_time() - cpu0
    if run.last is None:
        raise SimulationError("CALiPPSO: no LP solved (checkpoint already at max_iterations?)")
    # the main loop's last LP: its pair vectors are at the positions before the last (tiny) step
    lp, sol, _ = run.last
    return lp, sol.duals, False, math.nan


# --- helpers ----------------------------------------------------------------------------------------------------------


@dataclass
class _LoopState:
    """What one iteration hands the next besides positions and diameters; all of it is checkpointed, so that a
    resumed run takes the same path as an uninterrupted one."""

    sqrt_inflation_prev: float
    pinned: int
    prev_s_bound: float = 0.0  # the previous LP's s bound (0: none yet)
    bound_hit: bool = False  # a stable particle ended the previous LP at its s bound
    # (contact keys, rattler mask, held components or None) of a last LP that was isostatic, or isostatic with the
    # components held at its s bound (docs §5.4)
    predicted: tuple[np.ndarray, np.ndarray, np.ndarray | None] | None = None
    basis: LPBasis | None = None  # HiGHS basis of the last HiGHS-solved LP, the next one's warm start
    warm_failures: int = 0  # failed warm starts in a row
    warm_skip: int = 0  # LPs left to solve without a warm start (back-off after failures)
    contacts: np.ndarray | None = None  # contact keys among non-rattlers of the last LP (history's contact_changes)
    gauge: np.ndarray | None = None  # a container's gauge pins, flat s columns (docs/containers.md §5)
    escapes: int = 0  # escapes of unheld spheres after convergence (_escape)
    escape_phi: float = 0.0  # phi at the last one
    contact_swaps: int = -1  # contacts among non-rattlers the last LP gained and lost (-1: no LP before it)

    def arrays(self, x, dia) -> dict[str, np.ndarray]:
        out = {"positions": x, "diameters": dia}
        if self.gauge is not None:
            out.update(gauge=self.gauge)
        if self.predicted is not None:
            out.update(predicted_keys=self.predicted[0], predicted_rattlers=self.predicted[1])
            if self.predicted[2] is not None:
                out.update(predicted_held=self.predicted[2])
        if self.basis is not None:
            out.update(basis_keys=self.basis.keys, basis_rows=self.basis.rows, basis_cols=self.basis.cols)
        if self.contacts is not None:
            out.update(contact_keys=self.contacts)
        return out

    def attrs(self, iteration: int, lp_time: float) -> dict[str, Any]:
        return {"iteration": iteration, "lp_time": lp_time, "sqrt_inflation_prev": self.sqrt_inflation_prev,
                "pinned": int(self.pinned), "prev_s_bound": self.prev_s_bound, "bound_hit": self.bound_hit,
                "warm_failures": self.warm_failures, "warm_skip": self.warm_skip, "contact_swaps": self.contact_swaps,
                **({"escapes": self.escapes, "escape_phi": self.escape_phi} if self.escapes else {})}

    @classmethod
    def restore(cls, arrays: dict[str, np.ndarray], attrs: dict[str, Any]) -> _LoopState:
        predicted = None
        if "predicted_keys" in arrays:
            predicted = (arrays["predicted_keys"], arrays["predicted_rattlers"].astype(bool),
                         arrays["predicted_held"].astype(np.int8) if "predicted_held" in arrays else None)
        basis = None
        if "basis_keys" in arrays:
            basis = LPBasis(arrays["basis_keys"], arrays["basis_rows"], arrays["basis_cols"])
        return cls(float(attrs["sqrt_inflation_prev"]), int(attrs["pinned"]), float(attrs["prev_s_bound"]),
                   bool(attrs["bound_hit"]), predicted, basis, int(attrs["warm_failures"]), int(attrs["warm_skip"]),
                   arrays.get("contact_keys"), arrays.get("gauge"), int(attrs.get("escapes", 0)),
                   float(attrs.get("escape_phi", 0.0)), int(attrs.get("contact_swaps", -1)))


@dataclass
class _Run:
    """Where a run stands: positions and diameters (in the driver's units), the LPs solved so far, what the next
    iteration needs (:class:`_LoopState`), the history, the LP tally, and the latest main-loop LP."""

    x: np.ndarray
    dia: np.ndarray
    loop: _LoopState
    iteration: int = 0
    history: History = field(default_factory=History)
    tally: _Tally = field(default_factory=_Tally)
    last: tuple[_LP, LPSolution, np.ndarray] | None = None  # (the LP, its solution, its rattlers)
    trajectory: dict[str, Any] = field(default_factory=dict)  # this call's TRAJECTORY_CHANGES settings
    changes: list[dict[str, Any]] = field(default_factory=list)  # settings changed on resuming, from which LP

    @classmethod
    def start(cls, packing: Packing, cfg: _Settings, initial_sqrt_inflation: float | None) -> _Run:
        """The input in the driver's units; ``initial_sqrt_inflation`` None: 1 + the median nearest-neighbour gap
        (docs §1.6), or the reference's 1.01 under its schedule (docs §10)."""
        x = packing.positions / cfg.unit
        dia = packing.diameters / cfg.unit
        if initial_sqrt_inflation is None and cfg.schedule == "reference":
            initial_sqrt_inflation = REFERENCE_INITIAL_SQRT_INFLATION
        elif initial_sqrt_inflation is None:
            initial_sqrt_inflation = 1.0 + nearest_gap_median(x, dia, cfg.box)
        loop = _LoopState(sqrt_inflation_prev=float(initial_sqrt_inflation), pinned=initial_pin(x, dia, cfg.box))
        if cfg.walls is not None:
            loop.gauge = cfg.walls.gauge(x, loop.pinned).gauge
        return cls(x, dia, loop)

    def resume(self, ckpt: Checkpoint, earlier: _EarlierTrajectory | None = None) -> None:
        """Continue from the checkpoint's state, if it has one (docs §7), also one written under other trajectory
        settings that ``earlier`` accepts (docs §10.6): the change is recorded with the LP it starts at."""
        resumed = ckpt.resume(earlier)
        if resumed is not None:
            arrays, attrs, rows = resumed
            self.x, self.dia = arrays["positions"], arrays["diameters"]
            self.iteration, self.tally.lp_time = attrs["iteration"], attrs["lp_time"]
            self.loop = _LoopState.restore(arrays, attrs)
            self.history = History(rows)
            self.changes = list(attrs.get("trajectory_changes", []))
            if attrs.get("fingerprint") != ckpt.fingerprint:
                before = earlier.settings(attrs)
                changed = {k: v for k, v in self.trajectory.items() if before[k] != v}
                self.changes.append({"from_lp": self.iteration + 1, **changed})
                _log.info("calippso: resumed at LP %d with other trajectory settings: %s", self.iteration + 1,
                          ", ".join(f"{k}={v}" for k, v in changed.items()))

    def save(self, ckpt: Checkpoint) -> None:
        attrs = {**self.loop.attrs(self.iteration, self.tally.lp_time), "trajectory": self.trajectory,
                 "trajectory_changes": self.changes}
        ckpt.save(self.loop.arrays(self.x, self.dia), attrs, self.history.as_arrays())


def _phi(dia, cfg: _Settings) -> float:
    dim = cfg.dim
    volume = cfg.box**dim if cfg.walls is None else cfg.walls.container.volume
    return float(np.sum(math.pi ** (dim / 2) / math.gamma(dim / 2 + 1) * (0.5 * dia) ** dim) / volume)


def _pins(loop, cfg: _Settings):
    """The LP's fixed columns: the pinned sphere in the periodic cube (docs §1.7); in a container the gauge pins and
    the wall nodes (:class:`~.constraints.Pins`, docs/containers.md §5)."""
    if cfg.walls is None:
        return loop.pinned
    walls = np.arange(cfg.n * cfg.dim, cfg.nodes * cfg.dim, dtype=np.int64)
    return Pins(np.concatenate([loop.gauge, walls]), cfg.n, cfg.dim)


def _moved(x, s, cfg: _Settings):
    """Positions x displaced by s (N, d), wrapped back into the periodic box or along the container's periodic axes."""
    return np.mod(x + s, cfg.box) if cfg.walls is None else cfg.walls.container.wrap(x + s)


def _closest(x, dia, cfg: _Settings) -> float:
    """The closest approach of the packing, pairs and walls alike, as a fraction of contact (< 1: an overlap)."""
    h = _closest_h(x, dia, cfg.box)
    return h if cfg.walls is None else min(h, cfg.walls.distance_ratio(x, dia))


def _closest_h(x, dia, box) -> float:
    i, j, r = pairs_within(x, dia, box, 1.0 + 1e-6)
    if len(r) == 0:
        return math.inf
    return float(np.min(r / (0.5 * (dia[i] + dia[j]))))
