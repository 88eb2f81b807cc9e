"""Cluster resources of one workflow job: SLURM time limit, memory and cores from the protocol, N and the rates.

The workflow's rules take their ``resources:`` from :func:`job_resources` (``**job_resources("ls", EXP.size_of)``), so
these functions must stay cheap and import nothing heavy (no numpy, no numba): Snakemake evaluates them for every
job when it builds the DAG. The stages are the rules' names; ``spherejam cost CONFIG`` prints a whole config's
jobs and hours per stage (:func:`plan`).

The expected CPU seconds of one job are start-up plus work / speed, per stage (the constants below; their
calibration on the development machine: docs/cluster.md §3, 'Cost model'):

* LS: ``LS_BASE + LS_AT_1E2 (1e-2 / gamma)^LS_EXPONENT`` collisions per particle from a Poisson start to
  p = 1e12, at ``COLLISIONS_PER_SECOND (N / 1000)^SPEED_EXPONENT`` collisions per CPU second (LS and MLS), both for
  equal spheres; a size distribution divides that speed by its :func:`distribution_factor`
  ``1 + DISTRIBUTION_COEFFICIENT (N / 1000)^-DISTRIBUTION_SIZE_EXPONENT (W - 1)``, W its :func:`pair_load` at that N
  (1 for equal spheres), and keeps the collisions per particle of equal spheres (docs/algorithms.md §7.9).
* MLS: the LS collisions of every rate of its ladder (:mod:`spherejam.core.rate_ladder`), times
  ``MLS_PHASE_FRACTION`` (a stage ends early while the packing is still jammed) and ``(N / 1000)^MLS_SIZE_EXPONENT``
  (a larger packing unjams more often in the slow stages).
* FB: ``FB_BASE + FB_PER_INVERSE_RATE / gamma`` iterations of ``FB_SECONDS N`` seconds each.
* CALiPPSO: ``CALIPPSO_LPS (N / 1000)^CALIPPSO_LPS_EXPONENT`` LPs up to N = 1000 (``CALIPPSO_LPS_LARGE_EXPONENT``
  from there on) of :func:`calippso_lp_seconds` each, for the LP path that runs at that N
  (:func:`spherejam.core.calippso_path.interior_steps_at`, or ``calippso.interior_steps``):
  ``CALIPPSO_LP_SECONDS (N / 1000)^CALIPPSO_EXPONENT`` on the vertex path (``CALIPPSO_COLD_LP_SECONDS (N /
  1000)^CALIPPSO_COLD_EXPONENT`` from ``CALIPPSO_COLD_MIN_N`` on, where no LP is warm-started),
  ``CALIPPSO_INTERIOR_LP_SECONDS (N / 1000)^CALIPPSO_INTERIOR_EXPONENT`` with interior steps (the per-LP time
  includes the run's share of its force LP and start-up).
* seed and analyze: linear in N, seconds at N = 10^4 (start-up dominates).

The speed factor counts an N below 1000 as 1000; the MLS size factor holds at every N.

The time limit is the expected time times ``SAFETY`` (3) plus start-up, rounded up to whole minutes, clipped to
[floor, ceiling], and multiplied by the attempt number: a job killed at its limit is submitted again by Snakemake
(``restart-times``), resumes from its checkpoint, and gets a longer limit each time. The ceiling (default 24 h, a
common partition limit) can be changed with the environment variable ``SPHEREJAM_MAX_RUNTIME`` (minutes), read on
the submitting node; a job longer than the ceiling simply continues over several submissions.
"""

from __future__ import annotations

import math
import operator
import os
from dataclasses import dataclass

from ..core.calippso_path import interior_steps_at
from ..core.errors import InputError, require
from ..core.rate_ladder import ladder_rates
from .pair_load import LIST_SKIN, pair_load  # noqa: F401 (part of this module's interface)

#: Stages (rule kinds) with a cost model.
STAGES = ("seed", "ls", "fb", "mls", "calippso", "analyze")

#: LS collisions per particle to p = 1e12: LS_BASE + LS_AT_1E2 * (1e-2 / gamma)^LS_EXPONENT.
LS_BASE = 300.0
LS_AT_1E2 = 2500.0
LS_EXPONENT = 0.92
#: Event-driven collisions per CPU second at N = 1000, and its decrease with N (cache misses).
COLLISIONS_PER_SECOND = 9.5e5
SPEED_EXPONENT = -0.05
#: Slow-down of the event-driven engine (LS, MLS) for a size distribution: equal spheres' collisions per CPU second
#: divided by 1 + DISTRIBUTION_COEFFICIENT (N / 1000)^-DISTRIBUTION_SIZE_EXPONENT (W - 1), W = pair_load: a wide
#: distribution costs more in a small box (its large spheres span more of it: fewer cells, pairs through several
#: images). Fitted to the LS slow-downs of the bidisperse 1:3, 1:5 and 1:10 mixtures at several N and checked on the
#: other distributions (`benchmarks/cost_fit.py fit`, docs/algorithms.md §7.9).
DISTRIBUTION_COEFFICIENT = 0.257
DISTRIBUTION_SIZE_EXPONENT = 0.230
#: Fraction of the summed per-rate LS costs that an MLS run needs at N = 1000, and the growth of its collisions per
#: particle with N, (N / 1000)^MLS_SIZE_EXPONENT at every N: fitted to the mean MLS collisions of the reproduction
#: ladder's searches from fast starts (N = 250, 500, 1000) and of the five N = 10^4 searches
#: (`benchmarks/cost_fit.py fit`, docs/algorithms.md §7.9).
MLS_PHASE_FRACTION = 0.633
MLS_SIZE_EXPONENT = 0.554
#: FB: iterations = FB_BASE + FB_PER_INVERSE_RATE / gamma, seconds per iteration = FB_SECONDS * N.
FB_BASE = 30.0
FB_PER_INVERSE_RATE = 0.13
FB_SECONDS = 3.5e-7
#: CALiPPSO: mean LPs of a certification at N = 1000 and their growth with N up to there, fitted to the reproduction
#: ladder's 244 certifications of MLS outputs (N = 250, 500, 1000: means 3.9, 6.8, 14.7); from N = 1000 on, the
#: growth through the mean of the two whole certifications of N = 1e4 MLS outputs (29 and 173 LPs: 101; refitted
#: when the second, held out, failed the check of docs/calippso.md §10.17). docs/cluster.md §3.
CALIPPSO_LPS = 14.2
CALIPPSO_LPS_EXPONENT = 0.96
CALIPPSO_LPS_LARGE_EXPONENT = 0.852
#: CPU seconds per LP on the vertex path (every LP a vertex; the default, below core.calippso_path's
#: INTERIOR_STEPS_MIN_N when it is set), a power law in two segments joined at CALIPPSO_COLD_MIN_N. Below it most LPs
#: are warm-started or active-set solves: through the mean of 30 archived N = 1000 MLS outputs certified whole (577
#: LPs, start-up and force LPs included) and the vertex path's LPs at N = 4096. From it on no LP is warm-started, and
#: the time grows more slowly: through the N = 4096 LPs and the two whole certifications of N = 1e4 MLS outputs
#: pooled (123.2 s per LP over 202 LPs; 58.1 and 134 s each). Fitted by benchmarks/calippso_cost_fit.py;
#: docs/cluster.md §3.
CALIPPSO_LP_SECONDS = 0.52
CALIPPSO_EXPONENT = 2.81
CALIPPSO_COLD_MIN_N = 4096  # spherejam.calippso.lp.WARM_START_MAX_N, not imported: this module stays light
CALIPPSO_COLD_LP_SECONDS = 2.50
CALIPPSO_COLD_EXPONENT = 1.692
#: CPU seconds per LP with interior steps (config calippso.interior_steps: true; the default from
#: INTERIOR_STEPS_MIN_N on when it is set): through the whole certifications of 29 of the same N = 1000 MLS outputs
#: (268 LPs; IPX below N = 4096) and the mean of the N = 16384 run's 41 interior steps (120 s; HiPO), checked on the
#: interior steps measured at N = 4096 and 10^4. Fitted by benchmarks/calippso_cost_fit.py; docs/cluster.md §3.
CALIPPSO_INTERIOR_LP_SECONDS = 0.787
CALIPPSO_INTERIOR_EXPONENT = 1.799
#: Seconds per particle of the structure analysis (contacts, Voronoi, Q6), generous.
ANALYZE_SECONDS = 1e-3
#: Python, numba cache load and file I/O of one job, seconds (the first run on a node compiles: ~1 min).
STARTUP_SECONDS = 90.0
#: Time limit = STARTUP + SAFETY x expected work.
SAFETY = 3.0
#: Smallest time limit per stage, minutes (seed/analyze are grouped, and a group asks for the sum).
FLOOR_MINUTES = {"seed": 3, "analyze": 5, "fb": 10, "ls": 10, "mls": 15, "calippso": 10}
#: Default largest time limit, minutes; override with $SPHEREJAM_MAX_RUNTIME.
MAX_RUNTIME_MINUTES = 24 * 60
#: Memory: a job runs `snakemake` (the SLURM job step) and `spherejam` side by side, ~200 MB each at N = 10^4.
BASE_MEM_MB = 1000
#: Extra memory per particle, MB (event-driven state and neighbour lists are ~1 kB per particle).
MEM_PER_PARTICLE_MB = {"seed": 0.005, "ls": 0.01, "fb": 0.01, "mls": 0.01, "analyze": 0.05, "calippso": 0.5}


@dataclass(frozen=True)
class JobEstimate:
    """Resources of one job: what SLURM is asked for, and the expected CPU time behind it."""

    runtime: int  # time limit, minutes
    mem_mb: int
    cpus_per_task: int
    cpu_seconds: float  # expected CPU seconds, without margin (for sizing a whole run)


def _check_stage(stage: str) -> None:
    require(stage in STAGES, "stage", stage, f"must be one of {', '.join(STAGES)}")


def _check_n(n) -> int:
    ok = not isinstance(n, bool) and hasattr(n, "__index__") and operator.index(n) >= 2
    require(ok, "n", n, "must be an integer >= 2")
    return operator.index(n)


def _positive(field: str, value) -> float:
    require(isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value) and value > 0,
            field, value, "must be a finite number > 0")
    return float(value)


def collisions_per_second(n: int) -> float:
    """Expected event-driven (LS/MLS) speed at N particles, collisions per CPU second."""
    n = _check_n(n)
    return COLLISIONS_PER_SECOND * (max(n, 1000) / 1000.0) ** SPEED_EXPONENT


def distribution_factor(load: float, n: int) -> float:
    """Slow-down of the event-driven engine for a size distribution of :func:`pair_load` W at N spheres: equal
    spheres' collisions per CPU second over the distribution's,
    1 + DISTRIBUTION_COEFFICIENT (N / 1000)^-DISTRIBUTION_SIZE_EXPONENT (W - 1) (1 for equal spheres).

    The LS and MLS estimates keep equal spheres' collisions per particle: measured from phi = 0.58 at gamma = 1e-2,
    wide mixtures needed 0.37-1.05 of them (docs/algorithms.md §7.5), so for them the estimate errs long."""
    load = _positive("load", load)
    n = _check_n(n)
    return 1.0 + DISTRIBUTION_COEFFICIENT * (n / 1000.0) ** -DISTRIBUTION_SIZE_EXPONENT * max(load - 1.0, 0.0)


def ls_collisions_per_particle(rate: float) -> float:
    """Collisions per particle of an LS compression at rate gamma from a Poisson start to p = 1e12."""
    rate = _positive("rate", rate)
    return LS_BASE + LS_AT_1E2 * (1e-2 / rate) ** LS_EXPONENT


def mls_rates(initial_rate: float = 10.0, decrease_factor: float = 2.0, final_rate: float = 1e-4) -> list[float]:
    """The MLS rate ladder gamma_0 / f^k, k = 0, 1, ..., ending with the first rate <= gamma_final (checked
    arguments; :func:`spherejam.core.rate_ladder.ladder_rates`)."""
    g0 = _positive("initial_rate", initial_rate)
    f = _positive("decrease_factor", decrease_factor)
    gf = _positive("final_rate", final_rate)
    require(f > 1.0, "decrease_factor", decrease_factor, "must be > 1")
    return ladder_rates(g0, f, gf)


def mls_collisions_per_particle(initial_rate: float = 10.0, decrease_factor: float = 2.0,
                                final_rate: float = 1e-4, n: int = 1000) -> float:
    """Expected collisions per particle of one MLS run of N particles (paper defaults: 10 -> 1e-4, factor 2)."""
    n = _check_n(n)
    ladder = mls_rates(initial_rate, decrease_factor, final_rate)
    size = (n / 1000.0) ** MLS_SIZE_EXPONENT
    return MLS_PHASE_FRACTION * sum(ls_collisions_per_particle(g) for g in ladder) * size


def fb_iterations(rate: float) -> float:
    """Expected FB iterations at contraction rate gamma (dimensionless, per iteration)."""
    rate = _positive("rate", rate)
    require(rate < 1.0, "rate", rate, "must be < 1 for FB")
    return FB_BASE + FB_PER_INVERSE_RATE / rate


def calippso_lps(n: int) -> float:
    """Expected number of LPs of one CALiPPSO certification of an MLS output of N spheres (a mean: the median is
    smaller, and a few certifications take tens of times more, docs/calippso.md §9)."""
    n = _check_n(n)
    return CALIPPSO_LPS * (n / 1000.0) ** (CALIPPSO_LPS_EXPONENT if n <= 1000 else CALIPPSO_LPS_LARGE_EXPONENT)


def calippso_lp_seconds(n: int, interior_steps: bool | None = None) -> float:
    """Expected CPU seconds of one CALiPPSO LP at N spheres (the run's start-up and force LP shared out), on the path
    that runs: ``interior_steps`` as the config forces it, None the package's rule by N (docs/cluster.md §3)."""
    n = _check_n(n)
    if interior_steps_at(n, interior_steps):
        return CALIPPSO_INTERIOR_LP_SECONDS * (n / 1000.0) ** CALIPPSO_INTERIOR_EXPONENT
    if n >= CALIPPSO_COLD_MIN_N:
        return CALIPPSO_COLD_LP_SECONDS * (n / 1000.0) ** CALIPPSO_COLD_EXPONENT
    return CALIPPSO_LP_SECONDS * (n / 1000.0) ** CALIPPSO_EXPONENT


def cpu_seconds(stage: str, n: int, rate: float | None = None, *, initial_rate: float = 10.0,
                decrease_factor: float = 2.0, final_rate: float = 1e-4, load: float = 1.0,
                interior_steps: bool | None = None) -> float:
    """Expected CPU seconds of the work of one job (no start-up, no margin).

    ``rate`` is the generation rate gamma of an ``ls`` or ``fb`` job (required there, ignored elsewhere);
    ``initial_rate``, ``decrease_factor`` and ``final_rate`` describe an ``mls`` job; ``load`` is the size
    distribution's :func:`pair_load` W (1: equal spheres), which scales the event-driven stages (ls, mls) by
    :func:`distribution_factor`; ``interior_steps`` is a ``calippso`` job's LP path (None: the package's rule by N).
    """
    _check_stage(stage)
    n = _check_n(n)
    factor = distribution_factor(load, n)
    if stage in ("ls", "fb"):
        require(rate is not None, "rate", rate, f"is required for stage {stage!r}")
    if stage == "ls":
        return n * ls_collisions_per_particle(rate) / collisions_per_second(n) * factor
    if stage == "fb":
        return fb_iterations(rate) * FB_SECONDS * n
    if stage == "mls":
        return (n * mls_collisions_per_particle(initial_rate, decrease_factor, final_rate, n) / collisions_per_second(n)
                * factor)
    if stage == "calippso":
        return calippso_lps(n) * calippso_lp_seconds(n, interior_steps)
    if stage == "analyze":
        return ANALYZE_SECONDS * n
    return 1e-4 * n  # seed


def max_runtime_minutes() -> int:
    """The time-limit ceiling: $SPHEREJAM_MAX_RUNTIME (minutes) if set, else 24 h."""
    raw = os.environ.get("SPHEREJAM_MAX_RUNTIME")
    if raw is None or raw.strip() == "":
        return MAX_RUNTIME_MINUTES
    try:
        value = int(raw)
    except ValueError:
        raise InputError(f"SPHEREJAM_MAX_RUNTIME={raw!r}: must be a whole number of minutes") from None
    require(value >= 1, "SPHEREJAM_MAX_RUNTIME", raw, "must be >= 1 minute")
    return value


def _check_attempt(attempt) -> int:
    ok = not isinstance(attempt, bool) and hasattr(attempt, "__index__") and operator.index(attempt) >= 1
    require(ok, "attempt", attempt, "must be an integer >= 1")
    return operator.index(attempt)


def runtime_minutes(stage: str, n: int, rate: float | None = None, attempt: int = 1, *, initial_rate: float = 10.0,
                    decrease_factor: float = 2.0, final_rate: float = 1e-4, load: float = 1.0,
                    interior_steps: bool | None = None) -> int:
    """SLURM time limit of one job, minutes (Snakemake's ``runtime`` resource).

    ``attempt`` is Snakemake's attempt counter (1 on the first submission): the limit grows with it, so a job that
    was killed at its limit and resumed from its checkpoint gets more time, up to the ceiling.
    """
    attempt = _check_attempt(attempt)
    work = cpu_seconds(stage, n, rate, initial_rate=initial_rate, decrease_factor=decrease_factor,
                       final_rate=final_rate, load=load, interior_steps=interior_steps)
    minutes = math.ceil((STARTUP_SECONDS + SAFETY * work) / 60.0)
    minutes = max(minutes, FLOOR_MINUTES[stage]) * attempt
    return int(min(minutes, max_runtime_minutes()))


def mem_mb(stage: str, n: int, attempt: int = 1) -> int:
    """Memory of one job, MB (Snakemake's ``mem_mb``); grows with the attempt number (an OOM kill is retried)."""
    _check_stage(stage)
    n = _check_n(n)
    attempt = _check_attempt(attempt)
    base = BASE_MEM_MB + MEM_PER_PARTICLE_MB[stage] * n
    return int(math.ceil(base / 100.0) * 100) * attempt


def cpus_per_task(stage: str, threads: int = 1) -> int:
    """Cores of one job, at any N: every engine is single-threaded (numba without parallel loops); a CALiPPSO job
    gets its ``threads`` (config ``calippso.threads``, HiGHS and HiPO's BLAS), 1 by default."""
    _check_stage(stage)
    if stage != "calippso":
        return 1
    from ..core.validation import THREADS  # stdlib only, like this module

    THREADS.check("calippso.threads", threads)
    return int(threads)


def estimate(stage: str, n: int, rate: float | None = None, attempt: int = 1, *, initial_rate: float = 10.0,
             decrease_factor: float = 2.0, final_rate: float = 1e-4, load: float = 1.0) -> JobEstimate:
    """All resources of one job at once (see :func:`runtime_minutes`, :func:`mem_mb`, :func:`cpus_per_task`)."""
    kw = {"initial_rate": initial_rate, "decrease_factor": decrease_factor, "final_rate": final_rate, "load": load}
    return JobEstimate(
        runtime=runtime_minutes(stage, n, rate, attempt, **kw),
        mem_mb=mem_mb(stage, n, attempt),
        cpus_per_task=cpus_per_task(stage),
        cpu_seconds=cpu_seconds(stage, n, rate, **kw),
    )


def job_resources(stage: str, n, ladder=None, threads: int = 1, load=None, interior_steps: bool | None = None) -> dict:
    """The ``resources:`` of a workflow rule: time limit and memory as functions of a job's wildcards and attempt,
    and its cores. ``n`` is the number of spheres N, or a function of the wildcards giving it (a ladder of N);
    ``ladder(wildcards)`` gives an ``mls`` job's rate ladder (``initial_rate``, ``decrease_factor``,
    ``final_rate``); ``ls`` and ``fb`` jobs take their rate gamma from the ``rate`` wildcard; ``threads`` are a
    ``calippso`` job's cores (:func:`cpus_per_task`) and ``interior_steps`` its LP path (config
    ``calippso.interior_steps``; None: by N); ``load(wildcards)`` gives the job's size distribution's
    :func:`pair_load` at its N (None: equal spheres)."""
    _check_stage(stage)
    if callable(n):
        size = n
    else:
        fixed = _check_n(n)

        def size(wildcards):
            return fixed

    def runtime(wildcards, attempt):
        rate = float(wildcards.rate) if stage in ("ls", "fb") else None
        return runtime_minutes(stage, size(wildcards), rate, attempt, **(ladder(wildcards) if ladder else {}),
                               load=load(wildcards) if load else 1.0, interior_steps=interior_steps)

    def memory(wildcards, attempt):
        return mem_mb(stage, size(wildcards), attempt)

    return {"runtime": runtime, "mem_mb": memory, "cpus_per_task": cpus_per_task(stage, threads)}


def plan(config: dict) -> dict[int | str, dict[str, dict[str, float]]]:
    """Per N of the experiment: jobs, expected CPU hours and requested (time-limit) hours per stage.

    Mirrors the workflow's jobs: per generated packing one seed, one generation (ls/fb), one MLS, and (when enabled)
    one analyze and one calippso job (none for a packing CALiPPSO does not certify); plus one MLS job per
    validation-grid run. First attempts only. With containers the key is ``"<N> in <container> (<spec>)"``: a
    packing in a container is priced at its own N (the experiment's, or the one its container fixes,
    :meth:`Experiment.size`), by the same per-collision and per-iteration model as in bulk (the wall events' cost
    is not calibrated separately).
    """
    from .experiment import Experiment  # lazy: the rules' resource lambdas never need it

    exp = Experiment(config)
    mls = config.get("mls", {})
    mls_kw = {"initial_rate": float(mls.get("initial_rate", 10.0)),
              "decrease_factor": float(mls.get("decrease_factor", 2.0)),
              "final_rate": float(mls.get("final_rate", 1e-4))}
    jobs: list[tuple[int, int | str, str, float | None, dict]] = []

    def group(run) -> int | str:
        n = exp.size(run)
        return n if not exp.has_containers else f"{n} in {run.container} ({exp.container(run.container).spec})"

    for run in exp.runs():
        n, where = exp.size(run), group(run)
        load = {"load": exp.pair_load(run.dist, n)}
        jobs += [(n, where, "seed", None, {}), (n, where, run.protocol, run.rate, load),
                 (n, where, "mls", None, {**mls_kw, **load})]
        if config.get("analysis", {}).get("enabled", False):
            jobs.append((n, where, "analyze", None, {}))
        if exp.certifies(run):
            jobs.append((n, where, "calippso", None, {"interior_steps": exp.calippso_interior_steps}))
    for g in exp.grid_runs():
        n = exp.size(g.source)
        jobs.append((n, group(g.source), "mls_grid", None, {**g.ladder, "load": exp.pair_load(g.source.dist, n)}))
    tables: dict[int | str, dict[str, dict[str, float]]] = {} if exp.has_containers else {n: {} for n in exp.sizes}
    for n, where, label, rate, kw in jobs:
        stage = "mls" if label == "mls_grid" else label
        row = tables.setdefault(where, {}).setdefault(label, {"jobs": 0, "cpu_hours": 0.0, "requested_hours": 0.0})
        row["jobs"] += 1
        row["cpu_hours"] += cpu_seconds(stage, n, rate, **kw) / 3600.0
        row["requested_hours"] += runtime_minutes(stage, n, rate, **kw) / 60.0
    return tables


def print_plan(config: dict) -> None:
    """Print :func:`plan` of ``config`` as a table per N, and the total of a ladder (``spherejam cost``)."""
    tables = plan(config)
    print("first attempts; expected = model CPU time, requested = sum of SLURM time limits")
    totals = {k: 0.0 for k in ("jobs", "cpu_hours", "requested_hours")}
    for n, table in tables.items():
        print(f"N = {n}")
        print(f"{'stage':10s} {'jobs':>7s} {'expected CPU h':>15s} {'requested h':>12s}")
        for label, row in table.items():
            print(f"{label:10s} {row['jobs']:7d} {row['cpu_hours']:15.1f} {row['requested_hours']:12.1f}")
        total = {k: sum(r[k] for r in table.values()) for k in totals}
        print(f"{'total':10s} {total['jobs']:7d} {total['cpu_hours']:15.1f} {total['requested_hours']:12.1f}")
        totals = {k: totals[k] + total[k] for k in totals}
    if len(tables) > 1:
        label = "all N" if all(isinstance(k, int) for k in tables) else "all"
        print(f"{label:10s} {int(totals['jobs']):7d} {totals['cpu_hours']:15.1f} "
              f"{totals['requested_hours']:12.1f}")


def load_configs(*paths) -> dict:
    """Config files merged as Snakemake merges several ``--configfile`` arguments: later files override earlier
    ones key by key, recursively into nested mappings. (The workflow itself merges no ``--configfile`` over
    config/config.yaml: one file is the whole experiment.)"""
    from .config import load_config_file

    config: dict = {}
    for path in paths:
        _merge(config, load_config_file(path) or {})
    return config


def _merge(base: dict, update: dict) -> None:
    for key, value in update.items():
        if isinstance(value, dict) and isinstance(base.get(key), dict):
            _merge(base[key], value)
        else:
            base[key] = value

