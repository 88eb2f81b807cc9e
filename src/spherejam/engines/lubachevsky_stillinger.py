"""Lubachevsky–Stillinger (LS) compression: event-driven MD of hard spheres whose diameters grow linearly in time.

Physics (paper §III.B; docs/algorithms.md §2). Mass m = 1, k_B = 1, temperature T = 0.2 (rms speed sqrt(3 T)).
Diameters are D_i(t) = D_i0 (rho0 + gamma t): D_i0 are the nominal diameters (the input's actual diameters divided
by their mean, so mean 1 in the box's length unit), rho0 starts at the input's closest-pair ratio (the closest pair
touches) and gamma = d rho/dt is the compression rate (per unit time). Collisions are elastic in the frame of the
growing surfaces: the normal relative speed w becomes 2 g - w, g = gamma D_ij.

Windows. The run is a sequence of windows of ``events_per_particle`` x N events (all event kinds, as in the
paper's C++ code; or collisions only, ``count_collisions_only=True``). After each window:

* reduced pressure p = PV/(N k_B T) = 1 + |X| / (2 E dt) from the collision virial X = sum |r_ij| (v_i - v_j).n_ij
  (pre-collision velocities, growth term excluded), E = kinetic energy at the end of the window, dt its duration;
* thermostat: velocities are rescaled to exactly E = (3/2) N T;
* clock reset: rho0 += gamma dt, t = 0 (keeps times small near jamming; every event is re-predicted, none lost);
* audit: every listed pair is checked for overlap (relative tolerance 1e-10), else :class:`SimulationError`.

The run stops at p >= p_max (1e12), at ``target_phi``, after ``max_collisions`` or after ``max_wall_time`` seconds of
the call. The result is audited again with an independent all-pairs cell search; an overlapping packing is never
returned. :class:`WindowRun` is the window step that :func:`spherejam.engines.driver.drive` runs, for LS and MLS.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from ..core.checkpoint import fingerprint
from ..core.errors import InputError, SimulationError, require
from ..core.history import History
from ..core.neighbours import cell_sort, cells_per_side, closest_pair
from ..core.packing import Packing, ball_volume
from ..core.progress import log_fraction
from ..core.progress import rate as rate_of
from ..core.validation import EVENTS_PER_PARTICLE
from .driver import RunOptions, Stepper, drive
from .kernels import event_driven as ed
from .result import LSCounts, RunResult, RunStats

if TYPE_CHECKING:
    from .result import MLSCounts

DEFAULT_TEMPERATURE = 0.2
#: Relative overlap that makes a window audit (or the final audit) fail.
AUDIT_TOLERANCE = 1e-10
CHECKPOINT_KIND_LS = "ls"
#: Largest Verlet skin, in box lengths, when pairs meet through several images: a pair then reaches at most the
#: images one box length from its minimum image (list cutoff <= L + 2 skin < 1.5 L).
MULTI_IMAGE_MAX_SKIN = 0.2


@dataclass
class WindowStats:
    """One window: simulated duration, reduced pressure p, end temperature (before the thermostat), counts."""

    duration: float
    pressure: float
    temperature: float
    collisions: int
    events: int
    skin_events: int
    moves: int
    null_collisions: int
    list_rebuilds: int
    reached_target: bool
    self_contact: bool = False  #: the largest sphere touched its own image (rho reached rho_limit)


def _aligned_zeros(shape, dtype=np.float64) -> np.ndarray:
    """Zeroed C-contiguous array starting on a 64-byte boundary (NumPy only guarantees 16 bytes): a row of ``st``
    (8 doubles) or 16 neighbour indices then fill exactly one cache line instead of straddling two."""
    dtype = np.dtype(dtype)
    nbytes = int(np.prod(shape)) * dtype.itemsize
    buf = np.zeros(nbytes + 64, dtype=np.uint8)
    off = -buf.ctypes.data % 64
    return buf[off:off + nbytes].view(dtype).reshape(shape)


def _aligned_copy(a: np.ndarray) -> np.ndarray:
    out = _aligned_zeros(a.shape, a.dtype)
    out[...] = a
    return out


def _round_cap(cap: float) -> int:
    """Neighbour-list capacity rounded up to whole cache lines of int32 (16 per line)."""
    return -(-int(cap) // 16) * 16


class LSEngine:
    """Event-driven MD state of N growing hard spheres in a periodic cube (d = 3).

    Parameters
    ----------
    positions : (N, 3) float64
    nominal : (N,) float64
        Nominal diameters D_i0 (any scale; actual diameters are ``rho * nominal``).
    box : float
        Side L of the periodic cube.
    rho : float
        Current diameter scale factor rho0; no pair may overlap at it.
    velocities : (N, 3) float64
    gamma : float
        Compression rate d rho / dt (>= 0).
    temperature : float
        Target temperature T of the thermostat (k_B = m = 1).
    skin_fraction : float
        Verlet skin as a fraction of the mean actual diameter in dense states.
    list_margin : float
        Lists are built for diameters up to (1 + list_margin) times the current ones while compressing.
    dilute_neighbours : float
        In dilute states the list radius is widened so that about this many centres fall inside it.
    all_images : bool
        Predict collisions through every periodic image even where the minimum image suffices (a list cutoff
        below L/2): the slower path of small boxes, for tests.
    """

    def __init__(self, positions, nominal, box, rho, velocities, gamma, temperature=DEFAULT_TEMPERATURE, *,
                 skin_fraction=0.2, list_margin=0.02, dilute_neighbours=8.0, all_images=False):
        positions = np.asarray(positions, dtype=np.float64)
        n = positions.shape[0]
        self.n = n
        self.box = float(box)
        self.st = _aligned_zeros((n, 8))
        self.st[:, 0:3] = positions
        self.st[:, 3:6] = velocities
        self.st[:, 7] = nominal
        self.rho0 = float(rho)
        self.gamma = float(gamma)
        self.temperature = float(temperature)
        self.skin_fraction = float(skin_fraction)
        self.list_margin = float(list_margin)
        self.dilute_neighbours = float(dilute_neighbours)
        self.all_images = bool(all_images)
        self.allocate_events()
        self.list_rebuilds = 0
        self.perm = np.arange(n)  # internal index -> input index (particles are renumbered in cell order)
        self.refs = None  # set by rebuild_lists
        self.rebuild_lists(0.0)

    # --- neighbour lists ------------------------------------------------------------------------------------

    def allocate_events(self) -> None:
        """Per-particle event arrays and the heap (contents are set by the first event initialisation)."""
        n = self.n
        self.ev_time = np.zeros(n)
        self.ev_type = np.zeros(n, dtype=np.int8)
        self.ev_partner = np.full(n, -1, dtype=np.int32)
        self.heap = np.zeros(n, dtype=np.int32)
        self.hpos = np.zeros(n, dtype=np.int32)
        self.hkey = np.zeros(n)

    @property
    def rho_limit(self) -> float:
        """The scale factor at which the largest sphere touches its own periodic image (diameter L): no sphere can
        grow beyond it."""
        return self.box / float(self.st[:, 7].max())

    def rebuild_lists(self, t: float) -> None:
        """Rebuild all Verlet lists at time t (every particle must be synchronised to t)."""
        n, box = self.n, self.box
        nominal = self.st[:, 7]
        rho = self.rho0 + self.gamma * t
        dmean, dmax = float(nominal.mean()), float(nominal.max())
        margin = self.list_margin if self.gamma > 0 else 0.0
        spacing = (box**3 / n) ** (1.0 / 3.0)
        r_dilute = spacing * (3.0 * self.dilute_neighbours / (4.0 * math.pi)) ** (1.0 / 3.0)
        limit = 0.45 * box  # single image: every list cutoff stays below L/2
        self.multi = self.all_images or not rho * dmax < 0.9 * limit
        if not self.multi:
            rho_list = min(rho * (1.0 + margin), 0.95 * limit / dmax)
            max_skin = limit - rho_list * dmax
        else:  # pairs may meet through several images (docs/algorithms.md, "Any box, any size ratio")
            rho_list = min(rho * (1.0 + margin), self.rho_limit)
            max_skin = MULTI_IMAGE_MAX_SKIN * box  # images one box away suffice (ed.image_collision)
        skin = min(max(self.skin_fraction * rho_list * dmean, r_dilute - rho_list * dmean), max_skin)
        m = cells_per_side(box, rho_list * dmax + skin, 3, n)
        self._sort_by_cell(m)
        cap = 16 if self.refs is None else self.nbr.shape[1]
        while True:
            nbr = _aligned_zeros((n, cap), np.int32)
            refs, nnb, head, nxt, prv, cellof, max_count = ed.build_lists(self.st, box, rho_list, skin, m, nbr)
            if max_count + 4 <= cap:
                break
            cap = _round_cap(1.5 * max_count + 16)
        self.refs, self.nbr, self.nnb = refs, nbr, nnb
        self.head, self.nxt, self.prv, self.cellof = head, nxt, prv, cellof
        self.m, self.rho_list, self.skin = m, rho_list, skin
        self.scratch = np.zeros((1, max(cap, 64)), dtype=np.int32)
        self.list_rebuilds += 1

    def _sort_by_cell(self, m: int) -> None:
        """Renumber particles in cell order so that neighbours sit close in memory (all particles synchronised)."""
        order = cell_sort(np.mod(self.st[:, 0:3], self.box), self.box, m)[2]
        if np.any(order != np.arange(self.n)):
            self.st = _aligned_copy(self.st[order])
            self.perm = self.perm[order]

    def _enlarge_lists(self) -> None:
        cap = self.nbr.shape[1]
        new_cap = _round_cap(1.5 * cap + 8)
        nbr = _aligned_zeros((self.n, new_cap), np.int32)
        nbr[:, :cap] = self.nbr
        self.nbr = nbr
        self.scratch = np.zeros((1, new_cap), dtype=np.int32)

    # --- windows --------------------------------------------------------------------------------------------
    def _original_order(self, columns: slice) -> np.ndarray:
        out = np.empty((self.n, columns.stop - columns.start))
        out[self.perm] = self.st[:, columns]
        return out

    @property
    def velocities(self) -> np.ndarray:
        """(N, 3) velocities in the input's particle order (a copy)."""
        return self._original_order(slice(3, 6))

    @property
    def positions(self) -> np.ndarray:
        """(N, 3) positions in the input's particle order (a copy; synchronised between windows)."""
        return self._original_order(slice(0, 3))

    @property
    def nominal(self) -> np.ndarray:
        """Nominal diameters in the input's particle order."""
        return self._original_order(slice(7, 8))[:, 0]

    def kinetic_energy(self) -> float:
        v = self.st[:, 3:6]
        return 0.5 * float(np.sum(v * v))

    def thermalise(self) -> None:
        """Rescale velocities to exactly E = (3/2) N T."""
        e = self.kinetic_energy()
        if not e > 0:
            raise SimulationError(f"kinetic energy {e!r}: cannot rescale to T = {self.temperature}")
        self.st[:, 3:6] *= math.sqrt(1.5 * self.n * self.temperature / e)

    def window(self, target: int, count_collisions: bool = False, rho_target: float | None = None) -> WindowStats:
        """Run one window of ``target`` events (or collisions), then pressure, thermostat and clock reset.

        If ``rho_target`` is reached first, the window ends there (``reached_target``).
        """
        t = 0.0
        counters = np.zeros(ed.N_COUNTERS, dtype=np.int64)
        acc = np.zeros(1)
        rebuilds0 = self.list_rebuilds
        need_init = True
        reached = self_contact = False
        if not np.all(self.st[:, 6] == 0.0):
            raise SimulationError("window started with unsynchronised particles")
        while True:
            g = self.gamma
            t_list = (self.rho_list - self.rho0) / g if g > 0 else math.inf
            t_target = (rho_target - self.rho0) / g if (rho_target is not None and g > 0) else math.inf
            t_limit = max((self.rho_limit - self.rho0) / g, 0.0) if g > 0 else math.inf
            horizon = min(t_list, t_target, t_limit)
            if need_init:
                ed.init_events(t, self.st, self.refs, self.ev_time, self.ev_type, self.ev_partner, self.heap,
                               self.hpos, self.hkey, self.nbr, self.nnb, self.box, self.rho0, g, self.skin,
                               self.rho_list, self.multi)
            status, t = ed.run_events(
                self.st, self.refs, self.ev_time, self.ev_type, self.ev_partner, self.heap, self.hpos, self.hkey,
                self.nbr, self.nnb, self.head, self.nxt, self.prv, self.cellof, self.scratch, self.box, self.m,
                self.rho0, g, self.rho_list, self.skin, self.multi, t, target, count_collisions, horizon, counters,
                acc,
            )
            if status == ed.WINDOW_DONE:
                break
            if status == ed.OVERFLOW:
                self._enlarge_lists()
                need_init = False
            elif status == ed.HORIZON:
                if t >= t_limit:
                    self_contact = True
                    break
                if t >= t_target:
                    reached = True
                    break
                self.rebuild_lists(t)
                need_init = True
            else:
                raise SimulationError(f"event queue inconsistent at t={t!r} (an event time went backwards or NaN)")
        e = self.kinetic_energy()
        if not (math.isfinite(e) and e > 0):
            raise SimulationError(f"kinetic energy {e!r} after a window")
        if not t > 0 and not (reached or self_contact) and counters[ed.C_COLLISIONS] == 0:
            # 20 N skin or cell events in zero time are a stuck event loop, not an infinite pressure
            # (docs/algorithms.md, "Rattlers the thermostat has slowed"). Collisions in zero time are a jammed
            # network whose gaps are below double resolution (an N = 2 crystal): p = inf.
            raise SimulationError(f"{int(counters[ed.C_EVENTS])} events took no time: the event loop is stuck")
        pressure = 1.0 + abs(acc[0]) / (2.0 * e * t) if t > 0 else math.inf
        temperature = 2.0 * e / (3.0 * self.n)
        self.thermalise()
        self.rho0 = min(self.rho0 + self.gamma * t, self.rho_limit) if self_contact else self.rho0 + self.gamma * t
        self.st[:, 6] = 0.0
        h = ed.min_listed_ratio(self.st, self.nbr, self.nnb, self.box, self.rho0)
        if h < 1.0 - AUDIT_TOLERANCE:
            raise SimulationError(f"overlap {1.0 - h:.3e} (relative) after a window: an event was lost")
        return WindowStats(
            duration=t, pressure=pressure, temperature=temperature, collisions=int(counters[ed.C_COLLISIONS]),
            events=int(counters[ed.C_EVENTS]), skin_events=int(counters[ed.C_SKIN]),
            moves=int(counters[ed.C_MOVES]), null_collisions=int(counters[ed.C_NULL]),
            list_rebuilds=self.list_rebuilds - rebuilds0, reached_target=reached, self_contact=self_contact,
        )

    # --- checkpoint state -----------------------------------------------------------------------------------
    _ARRAYS = ("st", "perm", "refs", "nbr", "nnb", "head", "nxt", "prv", "cellof")

    def state(self) -> tuple[dict[str, np.ndarray], dict[str, Any]]:
        arrays = {f"engine_{k}": getattr(self, k) for k in self._ARRAYS}
        attrs = {k: getattr(self, k) for k in ("rho0", "gamma", "rho_list", "skin", "m", "list_rebuilds", "multi")}
        return arrays, attrs

    def load_state(self, arrays: dict[str, np.ndarray], attrs: dict[str, Any]) -> None:
        for k in self._ARRAYS:
            setattr(self, k, _aligned_copy(arrays[f"engine_{k}"]))
        self.rho0, self.gamma = float(attrs["rho0"]), float(attrs["gamma"])
        self.rho_list, self.skin = float(attrs["rho_list"]), float(attrs["skin"])
        self.m, self.list_rebuilds = int(attrs["m"]), int(attrs["list_rebuilds"])
        self.multi = bool(attrs.get("multi", False))  # checkpoints from before multi-image lists are single-image
        self.scratch = np.zeros((1, max(self.nbr.shape[1], 64)), dtype=np.int32)


# --- LS-type runs (plain LS and MLS): windows under a rate controller --------------------------------------------


def maxwell_velocities(n: int, temperature: float, rng: np.random.Generator) -> np.ndarray:
    """Gaussian velocities (std sqrt(T) per component), zero total momentum, kinetic energy exactly (3/2) N T."""
    v = rng.normal(0.0, math.sqrt(temperature), size=(n, 3))
    v -= v.mean(axis=0)
    v *= math.sqrt(1.5 * n * temperature / (0.5 * float(np.sum(v * v))))
    return v


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


class Controller:
    """Decides the compression rate window by window (plain LS: constant rate, stop at p >= p_max)."""

    kind = CHECKPOINT_KIND_LS

    def __init__(self, rate: float, p_max: float):
        self.rate = float(rate)
        self.p_max = float(p_max)

    def after_window(self, stats: WindowStats) -> str | None:
        """Update the rate after a window; return a stop reason or None."""
        return "p_max" if stats.pressure >= self.p_max else None

    def extra_row(self) -> dict[str, Any]:
        """Columns the controller adds to the history row of a window."""
        return {}

    def progress_fields(self) -> dict[str, Any]:
        """What the live status line shows of the controller (the driver adds p, phi, collisions/s)."""
        return {"γ": self.rate}

    def state(self) -> dict[str, Any]:
        return {"rate": self.rate}

    def load(self, state: dict[str, Any]) -> None:
        self.rate = float(state["rate"])

    def extras(self, counts: LSCounts) -> LSCounts | MLSCounts:
        """The extras of the run's :class:`RunStats`, from the event totals."""
        return counts


#: Event totals of a run, as kept in its checkpoint: LSCounts' fields plus collisions and windows.
_TOTALS = ("collisions", "windows") + tuple(f.name for f in dataclasses.fields(LSCounts))
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
        self.phi_nominal = float(np.sum(ball_volume(self.nominal, 3)) / packing.box**3)
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
        rho = closest_pair(self.input.positions, self.nominal, self.input.box)[2]
        rho = min(rho, self.input.box / float(self.nominal.max()))  # nor may a sphere overlap its own image
        velocities = maxwell_velocities(self.input.n, self.temperature, self.rng)
        self.engine = LSEngine(self.input.positions, self.nominal, self.input.box, rho, velocities,
                               self.controller.rate, self.temperature, **(self.engine_options or {}))
        self._phi_initial = self.phi_nominal * rho**3

    def load(self, arrays, attrs, history) -> None:
        self.engine = LSEngine.__new__(LSEngine)
        _init_bare(self.engine, self.input.n, self.input.box, self.temperature, self.engine_options)
        self.engine.load_state(arrays, attrs["engine"])
        self.controller.load(attrs["controller"])
        self.history = History(history)
        self.totals = dict(attrs["totals"])
        self.rng.bit_generator.state = attrs["rng_state"]
        self._phi_initial = float(attrs["phi_initial"])
        self.last_pressure = float(self.history.last("pressure", math.nan))

    def state(self):
        arrays, engine_attrs = self.engine.state()
        return arrays, {"engine": engine_attrs, "controller": self.controller.state(), "totals": self.totals,
                        "rng_state": self.rng.bit_generator.state, "phi_initial": self._phi_initial}

    def stop_before(self) -> str | None:
        return "target_phi" if self.rho_target is not None and self.engine.rho0 >= self.rho_target else None

    def step(self, wall_time) -> str | None:
        rate = self.engine.gamma = self.controller.rate
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
                    "collisions/s": rate_of(collisions, wall_time)},
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
        result = Packing(engine.positions, engine.rho0 * engine.nominal, self.input.box, metadata)
        report = result.check(AUDIT_TOLERANCE)
        if not report.ok:
            raise SimulationError(f"{self.algorithm}: final audit failed, the result is discarded: {report}")
        return result


def run_windows(packing: Packing, controller: Controller, options: RunOptions, **kwargs) -> RunResult:
    """Drive LS windows under ``controller`` (the arguments of :class:`WindowRun`) with the run ``options``."""
    run = WindowRun(packing, controller, **kwargs)
    return drive(run, options, run.fingerprint(), callback=run.callback)


def _init_bare(engine: LSEngine, n: int, box: float, temperature: float, options: dict[str, Any] | None) -> None:
    opts = {"skin_fraction": 0.2, "list_margin": 0.02, "dilute_neighbours": 8.0, "all_images": False}
    opts.update(options or {})
    engine.n, engine.box, engine.temperature = n, float(box), float(temperature)
    engine.skin_fraction = float(opts["skin_fraction"])
    engine.list_margin = float(opts["list_margin"])
    engine.dilute_neighbours = float(opts["dilute_neighbours"])
    engine.all_images = bool(opts["all_images"])
    engine.allocate_events()


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
