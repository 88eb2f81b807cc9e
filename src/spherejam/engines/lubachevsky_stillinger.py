"""Lubachevsky–Stillinger (LS) compression: windows of the event-driven engine under a compression-rate
controller, from a packing to its jammed state.

The physics, the windows and their audit are those of :class:`~.event_driven.LSEngine` (paper §III.B;
docs/algorithms.md §2); the rate gamma window by window is the :class:`~.rate_controller.Controller`'s. The run is a
sequence of windows of ``events_per_particle`` x N events (all event kinds, as in the paper's C++ code; or collisions
only, ``count_collisions_only=True``), from Maxwell–Boltzmann velocities at T = 0.2 and the input's diameters scaled
so that the closest pair touches.

The run stops at p >= p_max (1e12), at ``target_phi``, after ``max_collisions`` or after ``max_wall_time`` seconds of
the call. The result is audited again with an independent all-pairs cell search; an overlapping packing is never
returned. :class:`WindowRun` is the window step that :func:`spherejam.engines.driver.drive` runs, for LS and MLS.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable
from typing import Any

import numpy as np

from ..core.checkpoint import fingerprint
from ..core.errors import InputError, SimulationError, require
from ..core.history import History
from ..core.neighbours import closest_pair
from ..core.packing import Packing, ball_volume
from ..core.progress import log_fraction, per_second
from ..core.validation import EVENTS_PER_PARTICLE
from .driver import RunOptions, Stepper, drive
from .event_driven import AUDIT_TOLERANCE, DEFAULT_TEMPERATURE, ListOptions, LSEngine, WindowStats, restore_state
from .rate_controller import Controller
from .result import LSCounts, RunResult, RunStats


def maxwell_velocities(n: int, temperature: float, rng: np.random.Generator) -> np.ndarray:
    """Gaussian velocities (std sqrt(T) per component), zero total momentum, kinetic energy exactly (3/2) N T."""
    v = rng.normal(0.0, math.sqrt(temperature), size=(n, 3))
    v -= v.mean(axis=0)
    v *= math.sqrt(1.5 * n * temperature / (0.5 * float(np.sum(v * v))))
    return v


def without_rotation(v: np.ndarray, positions: np.ndarray, container, temperature: float) -> np.ndarray:
    """Velocities with no angular momentum about a cylinder's axis or a sphere's centre, rescaled to E = (3/2) N T.

    Smooth curved walls push along their normals only, so that angular momentum is conserved: left in, it is a
    rigid rotation of the whole packing that never jams (a zero mode, docs/containers.md §4)."""
    r = positions - container.centre
    if container.curved == "cylinder":
        a = container.axis
        e = np.zeros(3)
        e[a] = 1.0
        r = r.copy()
        r[:, a] = 0.0
        inertia = float(np.sum(r * r))
        if inertia > 0:
            omega = float(np.sum(np.cross(r, v) @ e)) / inertia
            v = v - omega * np.cross(e, r)
    else:
        moment = np.sum(np.cross(r, v), axis=0)
        inertia = float(np.sum(r * r)) * np.eye(3) - r.T @ r
        omega = np.linalg.solve(inertia, moment)
        v = v - np.cross(omega, r)
    return v * math.sqrt(1.5 * len(v) * temperature / (0.5 * float(np.sum(v * v))))


def validate_ls_options(packing, *, p_max, seed, events_per_particle, temperature, max_collisions=None) -> None:
    """The checks of the arguments that LS and MLS share (the run options are checked by :class:`RunOptions`)."""
    require(isinstance(packing, Packing), "packing", type(packing).__name__, "must be a spherejam Packing")
    require(packing.n >= 2, "N", packing.n, "must be >= 2")
    require(packing.dim == 3, "dim", packing.dim, "the LS engine supports d = 3 only")
    require(_finite(p_max) and p_max > 1, "p_max", p_max, "must be a finite number > 1")
    require(isinstance(seed, (int, np.integer)) and seed >= 0, "seed", seed, "must be an integer >= 0")
    require(isinstance(events_per_particle, (int, np.integer)) and EVENTS_PER_PARTICLE.ok(events_per_particle),
            "events_per_particle", events_per_particle, EVENTS_PER_PARTICLE.rule())  # int64 window counters
    require(max_collisions is None or (isinstance(max_collisions, (int, np.integer)) and max_collisions >= 1),
            "max_collisions", max_collisions, "must be None or an integer >= 1")
    require(_finite(temperature) and temperature > 0, "temperature", temperature, "must be a finite number > 0")


def _finite(x) -> bool:
    return isinstance(x, (int, float, np.integer, np.floating)) and not isinstance(x, bool) and math.isfinite(x)


#: Event totals of a run, as kept in its checkpoint: LSCounts' fields plus collisions and windows.
_TOTALS = ("collisions", "windows") + tuple(f.name for f in dataclasses.fields(LSCounts))
#: Prefix of the engine state's arrays in a checkpoint.
_ENGINE = "engine_"
#: Parameters that only bound the run: they do not enter the checkpoint's fingerprint.
_BUDGETS = ("max_wall_time", "max_collisions", "checkpoint_interval", "progress_interval")


class WindowRun(Stepper):
    """LS windows under a :class:`Controller` (plain LS or MLS), as :func:`~.driver.drive` steps them."""

    step_name = "window"

    def __init__(self, packing: Packing, controller: Controller, *, algorithm: str, parameters: dict[str, Any],
                 seed: int, events_per_particle: int, count_collisions_only: bool, temperature: float,
                 target_phi: float | None, max_collisions: int | None, engine_options: dict[str, Any] | None,
                 callback: Callable[[int, WindowStats], None] | None):
        self.input, self.controller = packing, controller
        self.kind, self.label, self.algorithm = controller.kind, algorithm, algorithm
        self.parameters, self.seed = parameters, int(seed)
        self.target = int(events_per_particle) * packing.n
        self.count_collisions_only, self.temperature = bool(count_collisions_only), float(temperature)
        self.max_collisions, self.engine_options, self.user_callback = max_collisions, engine_options, callback
        self.nominal = packing.diameters / packing.diameters.mean()
        self.phi_nominal = float(np.sum(ball_volume(self.nominal, 3)) / packing.volume)
        self.rho_target = None if target_phi is None else (target_phi / self.phi_nominal) ** (1.0 / 3.0)
        self.rng = np.random.default_rng(np.random.SeedSequence(self.seed))
        self.history = History()
        self.totals = dict.fromkeys(_TOTALS, 0)
        self.last_stats: WindowStats | None = None
        self.last_pressure = math.nan

    def fingerprint(self) -> str:
        return fingerprint(self.input, self.kind, {k: v for k, v in self.parameters.items() if k not in _BUDGETS})

    # --- Stepper ---------------------------------------------------------------------------------------------
    def start(self, wall_time) -> None:
        packing, container = self.input, self.input.container
        rho = closest_pair(packing.positions, self.nominal, packing.frame)[2]
        period = min((L for L, p in zip(container.lengths, container.periodic) if p), default=math.inf)
        rho = min(rho, period / float(self.nominal.max()))  # nor may a sphere overlap its own image
        rho = min(rho, container.max_scale(packing.positions, self.nominal))  # nor cross a wall
        velocities = maxwell_velocities(packing.n, self.temperature, self.rng)
        if container.curved is not None:
            velocities = without_rotation(velocities, packing.positions, container, self.temperature)
        self.engine = LSEngine.start(packing.positions, self.nominal, container, rho, velocities,
                                     self.controller.rate, self.temperature, **(self.engine_options or {}))
        self._phi_initial = self.phi_nominal * rho**3

    def load(self, arrays, attrs, history) -> None:
        saved = {k[len(_ENGINE):]: v for k, v in arrays.items() if k.startswith(_ENGINE)}
        state = restore_state(saved, attrs["engine"], self.input.container)
        self.engine = LSEngine(state, self.temperature, ListOptions(**(self.engine_options or {})))
        self.controller.restore(attrs["controller"])
        self.history = History(history)
        self.totals = dict(attrs["totals"])
        self.rng.bit_generator.state = attrs["rng_state"]
        self._phi_initial = float(attrs["phi_initial"])
        self.last_pressure = float(self.history.last("pressure", math.nan))

    def state(self):
        arrays, scalars = self.engine.state.persistent()
        attrs = {"engine": scalars, "controller": dataclasses.asdict(self.controller.state), "totals": self.totals,
                 "rng_state": self.rng.bit_generator.state, "phi_initial": self._phi_initial}
        return {_ENGINE + k: v for k, v in arrays.items()}, attrs

    def stop_before(self) -> str | None:
        return "target_phi" if self.rho_target is not None and self.engine.rho0 >= self.rho_target else None

    def step(self, wall_time) -> str | None:
        rate = self.controller.rate
        self.engine.set_rate(rate)
        stats = self.engine.window(self.target, self.count_collisions_only, self.rho_target)
        for key in _TOTALS[2:]:
            self.totals[key] += getattr(stats, key)
        self.totals["collisions"] += stats.collisions
        self.totals["windows"] += 1
        self.last_stats, self.last_pressure = stats, stats.pressure
        self.history.append(window=self.totals["windows"], phi=self.phi, pressure=stats.pressure, rate=rate,
                            collisions=stats.collisions, events=stats.events, duration=stats.duration,
                            temperature=stats.temperature, wall_time=wall_time(), **self.controller.extra_row())
        stop = "self_contact" if stats.self_contact else self.controller.after_window(stats)
        if stop is None and stats.reached_target:
            stop = "target_phi"
        if stop is None and self.max_collisions is not None and self.totals["collisions"] >= self.max_collisions:
            stop = "max_collisions"
        return stop

    def report(self, progress, stop, wall_time) -> None:
        p, phi, collisions = self.last_pressure, self.phi, self.totals["collisions"]
        progress.update(
            f"window {self.totals['windows']}: phi={phi:.6f} p={p:.4g} rate={self.history.last('rate'):.4g} "
            f"collisions={collisions:,} ({collisions / max(wall_time, 1e-9):,.0f}/s)"
            + (f" stop={stop}" if stop else ""),
            fields={**self.controller.progress_fields(), "p": p, "φ": phi,
                    "collisions/s": per_second(collisions, wall_time)},
            bar=(log_fraction(p, self.controller.p_max), "log p/log p_max"),
        )

    def callback(self) -> None:
        if self.user_callback is not None:
            self.user_callback(self.totals["windows"], self.last_stats)

    @property
    def steps(self) -> int:
        return self.totals["windows"]

    @property
    def collisions(self) -> int:
        return self.totals["collisions"]

    @property
    def phi_initial(self) -> float:
        return self._phi_initial

    @property
    def phi(self) -> float:
        return self.phi_nominal * self.engine.rho0**3

    def extras(self):
        return self.controller.extras(LSCounts(**{k: self.totals[k] for k in _TOTALS[2:]}))

    def result(self, stats: RunStats) -> Packing:
        metadata = dict(self.input.metadata)
        metadata.pop("provenance", None)
        metadata.update({
            "algorithm": self.algorithm,
            "seed": self.seed,
            "parameters": dict(self.parameters, input_seed=self.input.metadata.get("seed"),
                               input_algorithm=self.input.metadata.get("algorithm")),
            "reduced_pressure": self.last_pressure,
            "counters": stats.as_dict(),
        })
        engine = self.engine
        result = Packing(engine.positions, engine.rho0 * engine.nominal, self.input.box, metadata,
                         self.input.container)
        report = result.check(AUDIT_TOLERANCE)
        if not report.ok:
            raise SimulationError(f"{self.algorithm}: final audit failed, the result is discarded: {report}")
        return result


def run_windows(packing: Packing, controller: Controller, options: RunOptions, **kwargs) -> RunResult:
    """Drive LS windows under ``controller`` (the arguments of :class:`WindowRun`) with the run ``options``."""
    run = WindowRun(packing, controller, **kwargs)
    return drive(run, options, run.fingerprint(), callback=run.callback)


def run_ls(packing: Packing, rate: float, *, p_max: float = 1e12, seed: int = 0, target_phi: float | None = None,
           max_collisions: int | None = None, max_wall_time: float | None = None, events_per_particle: int = 20,
           count_collisions_only: bool = False, temperature: float = DEFAULT_TEMPERATURE, checkpoint=None,
           checkpoint_interval: float = 300.0, progress_interval: float = 10.0,
           callback: Callable[[int, WindowStats], None] | None = None,
           engine_options: dict[str, Any] | None = None) -> RunResult:
    """Compress ``packing`` with the Lubachevsky–Stillinger algorithm.

    Parameters
    ----------
    packing : Packing
        Start configuration (d = 3, any density, any polydispersity); its diameters are rescaled so that the
        closest pair touches.
    rate : float
        Compression rate gamma = d rho / dt >= 0 (the paper's gamma; diameters grow by gamma D_i0 per unit time,
        time unit = mean nominal diameter / sqrt(k_B T / m) with T = 0.2, i.e. m = k_B = 1).
    p_max : float
        Stop at the first window whose reduced pressure p = PV/(N k_B T) reaches p_max (> 1).
    seed : int
        Seed of the initial Maxwell–Boltzmann velocities; same input and seed give identical output.
    target_phi, max_collisions :
        Optional further stops: packing fraction reached, total collisions (resumed windows included).
    max_wall_time, checkpoint, checkpoint_interval, progress_interval :
        The run options (:class:`spherejam.engines.driver.RunOptions`): seconds of this call; the checkpoint
        (resumed if it matches, saved every ``checkpoint_interval`` wall seconds at window ends, removed when the
        run ends except after a ``max_wall_time`` stop, so that a later call continues); seconds between progress
        lines.
    events_per_particle : int
        Window length in events (or collisions) per particle (20 in the paper).
    count_collisions_only : bool
        Count only collisions towards the window length (the paper's wording) instead of all events (the
        paper's C++ code: collisions, re-predictions and neighbour-list updates). Near jamming they nearly agree.
    temperature : float
        Thermostat temperature T (0.2).
    callback : callable(window_index, WindowStats) or None
        Called after every window (e.g. for monitoring; an exception aborts the run, keeping the checkpoint).
    engine_options : dict or None
        Tuning of the neighbour lists (``skin_fraction``, ``list_margin``, ``dilute_neighbours``, ``all_images``);
        no effect on the physics.

    Returns
    -------
    RunResult
        Packing with actual diameters (metadata ``algorithm="ls"``), per-window history (``window, phi, pressure,
        rate, collisions, events, duration, temperature, wall_time``; counts per window, wall time cumulative) and
        ``stats`` (:class:`~spherejam.engines.result.RunStats`: stop_reason "p_max", "target_phi",
        "max_collisions" or "max_wall_time"; steps = windows; extras :class:`~spherejam.engines.result.LSCounts`).
    """
    validate_ls_options(packing, p_max=p_max, seed=seed, events_per_particle=events_per_particle,
                        temperature=temperature, max_collisions=max_collisions)
    options = RunOptions(max_wall_time=max_wall_time, checkpoint=checkpoint,
                         checkpoint_interval=checkpoint_interval, progress_interval=progress_interval)
    require(_finite(rate) and rate >= 0, "rate", rate, "must be a finite number >= 0")
    require(target_phi is None or (_finite(target_phi) and 0 < target_phi < 1), "target_phi", target_phi,
            "must be None or in (0, 1)")
    if rate == 0 and target_phi is not None:
        raise InputError(f"target_phi={target_phi!r}: cannot be reached at rate=0")
    if rate == 0 and max_collisions is None and max_wall_time is None:
        raise InputError("rate=0.0: zero-rate MD may never reach p_max; give max_collisions or max_wall_time")
    parameters = {
        "rate": float(rate), "p_max": float(p_max), "seed": int(seed), "target_phi": target_phi,
        "max_collisions": max_collisions, "max_wall_time": max_wall_time,
        "events_per_particle": int(events_per_particle), "count_collisions_only": bool(count_collisions_only),
        "temperature": float(temperature),
    }
    return run_windows(packing, Controller(rate, p_max), options, algorithm="ls", parameters=parameters, seed=seed,
                       events_per_particle=events_per_particle, count_collisions_only=count_collisions_only,
                       temperature=temperature, target_phi=target_phi, max_collisions=max_collisions,
                       engine_options=engine_options, callback=callback)
