"""The closest jammed configuration of a packing: the paper's modified Lubachevsky–Stillinger (MLS) search.

Paper §III.B (docs/algorithms.md §3). From any packing (rescaled so that its closest pair touches), with fresh
Maxwell–Boltzmann velocities at T = 0.2:

1. compress with LS at the initial rate gamma_0 (10) until the reduced pressure of a window (20 events per
   particle) reaches p_max (1e12);
2. equilibrate at zero rate until p < p_max; if p is still >= p_max after ``max_equilibration_windows`` (50)
   windows in a row, the packing is jammed: stop;
3. compress again at gamma_k = gamma_0 / f^k (f = 2, k = number of restarts so far);
4. stop at the first window with p >= p_max while compressing at a rate <= the final rate (1e-4).

One rule is ours, not the paper's: a compression whose pressure has stalled counts as having reached p_max. In the
slow stages near p_max = 1e12 of a box of >= 10^4 spheres, the growth of the diameters during one window is at or
below the spacing of double-precision coordinates, so it is absorbed as round-off overlaps, which the collision rule
resolves, and the pressure stops rising below p_max (the measurements: docs/cluster.md, 'Pressure floor at
N = 10⁴'). So if, while compressing, p >= ``STALL_PRESSURE_FRACTION`` * p_max and p has stayed within a factor
``STALL_BAND`` for ``stall_windows`` windows in a row, the stage ends as if p_max were reached (counted in
``stalled_stages``; at the final rate the stop reason is "final_rate_stalled").

The closest jamming density phi_J is the packing fraction when the loop stops. Fast compressions at the start keep
the configuration in its initial basin; slow ones at the end make the high pressure a sign of true jamming.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..core.errors import require
from ..core.packing import Packing
from ..core.rate_ladder import final_stage, stage_rate
from ..core.validation import check_mls
from .driver import RunOptions
from .event_driven import DEFAULT_TEMPERATURE, WindowStats
from .lubachevsky_stillinger import _finite, run_windows, validate_ls_options
from .rate_controller import Controller, RateState
from .result import LSCounts, MLSCounts, RunResult

CHECKPOINT_KIND_MLS = "mls"
#: A stall counts only at p >= this fraction of p_max: lower plateaus are not the precision floor.
STALL_PRESSURE_FRACTION = 0.1
#: p "has not changed" while it stays within this factor of its value when the count started.
STALL_BAND = 1.1
#: Default ``stall_windows``: far longer than a normal stage stays flat, shorter than a stall (docs/cluster.md).
DEFAULT_STALL_WINDOWS = 1000


@dataclass
class MLSState(RateState):
    """Where the MLS search is (a checkpoint saves it whole). The stall fields default to a fresh count, as for a
    checkpoint written before the stall rule."""

    restarts: int = 0  #: k, the rate decreases so far
    equilibration_count: int = 0  #: zero-rate windows in a row with p >= p_max
    stage: int = 0  #: 0 = first compression, 1 = first equilibration, 2 = compression at gamma_0/f, ...
    last_growth_rate: float = 0.0  #: the rate of the last compression stage
    equilibration_windows: int = 0  #: zero-rate windows in all
    stall_reference: float = 0.0  #: p when the current flat stretch began (0: none yet in this stage)
    stall_count: int = 0
    stalled_stages: int = 0


class MLSController(Controller):
    """The MLS state machine, evaluated after every window; its changing part is ``state`` (an :class:`MLSState`)."""

    kind = CHECKPOINT_KIND_MLS

    def __init__(self, initial_rate: float, decrease_factor: float, final_rate: float, p_max: float,
                 max_equilibration_windows: int, stall_windows: int | None = DEFAULT_STALL_WINDOWS):
        super().__init__(initial_rate, p_max)
        self.state = MLSState(rate=float(initial_rate), last_growth_rate=float(initial_rate))
        self.initial_rate = float(initial_rate)
        self.decrease_factor = float(decrease_factor)
        self.final_rate = float(final_rate)
        self.final_stage = final_stage(self.initial_rate, self.decrease_factor, self.final_rate)
        self.max_equilibration_windows = int(max_equilibration_windows)
        self.stall_windows = 0 if stall_windows is None else int(stall_windows)  # 0: rule off

    def _stalled(self, p: float) -> bool:
        s = self.state
        if s.stall_reference > 0 and s.stall_reference / STALL_BAND <= p <= s.stall_reference * STALL_BAND:
            s.stall_count += 1
        else:
            s.stall_reference, s.stall_count = p, 0
        return (self.stall_windows > 0 and s.stall_count >= self.stall_windows
                and p >= STALL_PRESSURE_FRACTION * self.p_max)

    def after_window(self, stats: WindowStats) -> str | None:
        p, s = stats.pressure, self.state
        if s.rate > 0:
            stalled = bool(p < self.p_max and self._stalled(p))
            if p >= self.p_max or stalled:
                s.stalled_stages += int(stalled)
                if s.rate <= self.final_rate:
                    return "final_rate_stalled" if stalled else "final_rate"
                s.last_growth_rate = s.rate
                s.rate = 0.0
                s.equilibration_count = 0
                s.stall_reference, s.stall_count = 0.0, 0
                s.stage += 1
        else:
            s.equilibration_windows += 1
            if p < self.p_max:
                s.restarts += 1
                s.rate = stage_rate(self.initial_rate, self.decrease_factor, s.restarts)
                s.stage += 1
            else:
                s.equilibration_count += 1
                if s.equilibration_count >= self.max_equilibration_windows:
                    return "jammed"
        return None

    def extra_row(self) -> dict[str, Any]:
        return {"stage": self.state.stage}

    def progress_fields(self) -> dict[str, Any]:
        s = self.state
        return {"stage": s.stage, "γ": s.rate, "stages left": max(self.final_stage - s.restarts, 0)}

    def extras(self, counts: LSCounts) -> MLSCounts:
        s = self.state
        return MLSCounts(
            **dataclasses.asdict(counts),
            stages=s.stage + 1,
            rate_decreases=s.restarts,
            equilibration_windows=s.equilibration_windows,
            final_rate_reached=s.rate if s.rate > 0 else s.last_growth_rate,
            stalled_stages=s.stalled_stages,
        )


def find_closest_jamming(packing: Packing, *, initial_rate: float = 10.0, decrease_factor: float = 2.0,
                         final_rate: float = 1e-4, p_max: float = 1e12, max_equilibration_windows: int = 50,
                         stall_windows: int | None = DEFAULT_STALL_WINDOWS, seed: int = 0,
                         events_per_particle: int = 20, max_collisions: int | None = None,
                         max_wall_time: float | None = None,
                         checkpoint=None, checkpoint_interval: float = 300.0, progress_interval: float = 10.0,
                         count_collisions_only: bool = False, temperature: float = DEFAULT_TEMPERATURE,
                         callback: Callable[[int, WindowStats], None] | None = None,
                         engine_options: dict[str, Any] | None = None) -> RunResult:
    """Closest jammed configuration of ``packing`` and its density phi_J, by the paper's MLS algorithm.

    Parameters
    ----------
    packing : Packing
        Any start (d = 3): Poisson, LS, FB...; rescaled so that its closest pair touches.
    initial_rate : float
        gamma_0 > 0, first compression rate d rho / dt (paper: 10).
    decrease_factor : float
        f > 1: after each jam + re-equilibration the rate becomes gamma_0 / f^k (paper: 2).
    final_rate : float
        Stop when p >= p_max is reached at a rate <= this (> 0; paper: 1e-4).
    p_max : float
        Reduced-pressure threshold (> 1; paper: 1e12).
    max_equilibration_windows : int
        Zero-rate windows in a row with p >= p_max after which the packing counts as jammed (paper: 50).
    stall_windows : int or None
        Compression windows in a row with p >= p_max / 10 staying within a factor 1.1 after which the stage counts
        as having reached p_max (the double-precision floor; see the module docstring). None turns the rule off
        (the paper's algorithm exactly, which can then compress forever at N >= 10^4).
    max_collisions : int, optional
        Cut the search after this many collisions in total (``stop_reason="max_collisions"``). Unlike
        ``max_wall_time`` the cut is deterministic: the same input and seed give the same output on any machine.
    seed, events_per_particle, max_wall_time, checkpoint, checkpoint_interval, progress_interval,
    count_collisions_only, temperature, callback, engine_options :
        As in :func:`spherejam.engines.lubachevsky_stillinger.run_ls`. A ``max_wall_time`` stop keeps the
        checkpoint, so a later call with the same checkpoint path continues the search.

    Returns
    -------
    RunResult
        The jammed packing (actual diameters; metadata ``algorithm="mls"``), per-window history (as LS plus
        ``stage``) and ``stats`` (:class:`~spherejam.engines.result.RunStats`): ``phi_final`` is phi_J;
        stop_reason "final_rate", "final_rate_stalled", "jammed", "max_collisions" or "max_wall_time"; steps =
        windows; extras :class:`~spherejam.engines.result.MLSCounts` (stages, rate_decreases,
        equilibration_windows, final_rate_reached, stalled_stages and the event totals).
    """
    validate_ls_options(packing, p_max=p_max, seed=seed, events_per_particle=events_per_particle,
                        temperature=temperature, max_collisions=max_collisions)
    options = RunOptions(max_wall_time=max_wall_time, checkpoint=checkpoint,
                         checkpoint_interval=checkpoint_interval, progress_interval=progress_interval)
    require(_finite(initial_rate) and initial_rate > 0, "initial_rate", initial_rate, "must be a finite number > 0")
    require(_finite(decrease_factor) and decrease_factor > 1, "decrease_factor", decrease_factor,
            "must be a finite number > 1")
    require(_finite(final_rate) and final_rate > 0, "final_rate", final_rate, "must be a finite number > 0")
    require(isinstance(max_equilibration_windows, (int, np.integer)) and max_equilibration_windows >= 1,
            "max_equilibration_windows", max_equilibration_windows, "must be an integer >= 1")
    require(stall_windows is None or (isinstance(stall_windows, (int, np.integer)) and stall_windows >= 1),
            "stall_windows", stall_windows, "must be an integer >= 1 or None")
    check_mls(initial_rate, decrease_factor, final_rate, ("initial_rate", "decrease_factor", "final_rate"))
    parameters = {
        "initial_rate": float(initial_rate), "decrease_factor": float(decrease_factor),
        "final_rate": float(final_rate), "p_max": float(p_max),
        "max_equilibration_windows": int(max_equilibration_windows),
        "stall_windows": None if stall_windows is None else int(stall_windows), "seed": int(seed),
        "events_per_particle": int(events_per_particle), "max_wall_time": max_wall_time,
        "max_collisions": None if max_collisions is None else int(max_collisions),
        "count_collisions_only": bool(count_collisions_only), "temperature": float(temperature),
    }
    controller = MLSController(initial_rate, decrease_factor, final_rate, p_max, max_equilibration_windows,
                               stall_windows)
    return run_windows(packing, controller, options, algorithm="mls", parameters=parameters, seed=seed,
                       events_per_particle=events_per_particle, count_collisions_only=count_collisions_only,
                       temperature=temperature, target_phi=None, max_collisions=max_collisions,
                       engine_options=engine_options, callback=callback)
