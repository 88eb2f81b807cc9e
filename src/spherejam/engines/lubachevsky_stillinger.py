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
from typing import TYPE_CHECKING, Any, get_type_hints

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


@dataclass(frozen=True)
class ListOptions:
    """Tuning of the Verlet lists (no effect on the physics).

    skin_fraction : Verlet skin as a fraction of the mean actual diameter in dense states.
    list_margin : lists are built for diameters up to (1 + list_margin) times the current ones while compressing.
    dilute_neighbours : in dilute states the list radius is widened so that about this many centres fall inside it.
    all_images : predict collisions through every periodic image even where the minimum image suffices (a list
        cutoff below L/2): the slower path of small boxes, for tests.
    """

    skin_fraction: float = 0.2
    list_margin: float = 0.02
    dilute_neighbours: float = 8.0
    all_images: bool = False


def fresh_state(positions, nominal, box, rho, velocities, gamma) -> ed.EventState:
    """An :class:`~.kernels.event_driven.EventState` of N spheres at time 0 whose lists are still to be built
    (:meth:`LSEngine.rebuild_lists`): positions (N, 3), nominal diameters D_i0 (N,), box side L, scale factor rho0
    (no pair may overlap at it), velocities (N, 3) and compression rate gamma = d rho / dt >= 0."""
    positions = np.asarray(positions, dtype=np.float64)
    n = positions.shape[0]
    st = _aligned_zeros((n, 8))
    st[:, 0:3] = positions
    st[:, 3:6] = velocities
    st[:, 7] = nominal
    cap = 16
    empty = np.zeros(0, dtype=np.int64)
    return ed.EventState(st=st, perm=np.arange(n), refs=np.zeros((n, 3)), nbr=_aligned_zeros((n, cap), np.int32),
                         nnb=np.zeros(n, dtype=np.int32), head=empty, nxt=empty, prv=empty, cellof=empty,
                         **ed.workspace(n, cap), box=float(box), m=1, rho0=float(rho), gamma=float(gamma),
                         rho_list=float(rho), skin=0.0, multi=False, list_rebuilds=0)


def restore_state(arrays: dict[str, np.ndarray], scalars: dict[str, Any], box: float) -> ed.EventState:
    """The state a checkpoint saved (:meth:`~.kernels.event_driven.EventState.persistent`), work space fresh.

    Checkpoints written before the state object lack ``box`` (the input's) and, before multi-image lists,
    ``multi`` (they are single-image); their fields are otherwise the same."""
    scalars = {"box": box, "multi": False, **scalars}
    fields = {}
    for name, kind in get_type_hints(ed.EventState).items():
        if name not in ed.WORKSPACE:
            fields[name] = _aligned_copy(arrays[name]) if kind is np.ndarray else kind(scalars[name])
    return ed.EventState(**fields, **ed.workspace(len(fields["st"]), fields["nbr"].shape[1]))


class LSEngine:
    """Event-driven MD of N growing hard spheres in a periodic cube (d = 3): an
    :class:`~.kernels.event_driven.EventState` (``state``, the only mutable part) stepped by windows.

    Start one with :meth:`start`, or continue a saved ``state`` with ``LSEngine(state, temperature, options)``.
    ``temperature`` is the target T of the thermostat (k_B = m = 1); ``options`` a :class:`ListOptions`.
    """

    def __init__(self, state: ed.EventState, temperature: float = DEFAULT_TEMPERATURE,
                 options: ListOptions | None = None):
        self.state = state
        self.temperature = float(temperature)
        self.options = ListOptions() if options is None else options

    @classmethod
    def start(cls, positions, nominal, box, rho, velocities, gamma, temperature=DEFAULT_TEMPERATURE,
              **options) -> LSEngine:
        """A fresh engine (the arguments of :func:`fresh_state`; ``options`` the fields of :class:`ListOptions`),
        its lists built at t = 0."""
        engine = cls(fresh_state(positions, nominal, box, rho, velocities, gamma), temperature, ListOptions(**options))
        engine.rebuild_lists(0.0)
        return engine

    @property
    def n(self) -> int:
        return self.state.st.shape[0]

    @property
    def rho0(self) -> float:
        """The diameter scale factor now (between windows)."""
        return self.state.rho0

    def set_rate(self, gamma: float) -> None:
        """The compression rate d rho / dt of the following windows."""
        self.state = self.state._replace(gamma=float(gamma))

    @property
    def rho_limit(self) -> float:
        """The scale factor at which the largest sphere touches its own periodic image (diameter L): no sphere can
        grow beyond it."""
        return self.state.box / float(self.state.st[:, 7].max())

    # --- neighbour lists ------------------------------------------------------------------------------------

    def rebuild_lists(self, t: float) -> None:
        """Rebuild all Verlet lists at time t (every particle must be synchronised to t)."""
        s, opt = self.state, self.options
        n, box = self.n, s.box
        nominal = s.st[:, 7]
        rho = s.rho0 + s.gamma * t
        dmean, dmax = float(nominal.mean()), float(nominal.max())
        margin = opt.list_margin if s.gamma > 0 else 0.0
        spacing = (box**3 / n) ** (1.0 / 3.0)
        r_dilute = spacing * (3.0 * opt.dilute_neighbours / (4.0 * math.pi)) ** (1.0 / 3.0)
        limit = 0.45 * box  # single image: every list cutoff stays below L/2
        multi = opt.all_images or not rho * dmax < 0.9 * limit
        if not multi:
            rho_list = min(rho * (1.0 + margin), 0.95 * limit / dmax)
            max_skin = limit - rho_list * dmax
        else:  # pairs may meet through several images (docs/algorithms.md, "Any box, any size ratio")
            rho_list = min(rho * (1.0 + margin), self.rho_limit)
            max_skin = MULTI_IMAGE_MAX_SKIN * box  # images one box away suffice (ed.image_collision)
        skin = min(max(opt.skin_fraction * rho_list * dmean, r_dilute - rho_list * dmean), max_skin)
        m = cells_per_side(box, rho_list * dmax + skin, 3, n)
        st, perm = self._sorted_by_cell(m)
        cap = s.nbr.shape[1]
        while True:
            nbr = _aligned_zeros((n, cap), np.int32)
            refs, nnb, head, nxt, prv, cellof, max_count = ed.build_lists(st, box, rho_list, skin, m, nbr)
            if max_count + 4 <= cap:
                break
            cap = _round_cap(1.5 * max_count + 16)
        self.state = s._replace(st=st, perm=perm, refs=refs, nbr=nbr, nnb=nnb, head=head, nxt=nxt, prv=prv,
                                cellof=cellof, scratch=ed.scratch_row(cap), m=m, rho_list=rho_list, skin=skin,
                                multi=multi, list_rebuilds=s.list_rebuilds + 1)

    def _sorted_by_cell(self, m: int) -> tuple[np.ndarray, np.ndarray]:
        """``(st, perm)`` renumbered in cell order, so that neighbours sit close in memory (all particles
        synchronised)."""
        s = self.state
        order = cell_sort(np.mod(s.st[:, 0:3], s.box), s.box, m)[2]
        if np.any(order != np.arange(self.n)):
            return _aligned_copy(s.st[order]), s.perm[order]
        return s.st, s.perm

    def _enlarge_lists(self) -> None:
        s = self.state
        cap = s.nbr.shape[1]
        new_cap = _round_cap(1.5 * cap + 8)
        nbr = _aligned_zeros((self.n, new_cap), np.int32)
        nbr[:, :cap] = s.nbr
        self.state = s._replace(nbr=nbr, scratch=ed.scratch_row(new_cap))

    # --- windows --------------------------------------------------------------------------------------------
    def _original_order(self, columns: slice) -> np.ndarray:
        out = np.empty((self.n, columns.stop - columns.start))
        out[self.state.perm] = self.state.st[:, columns]
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
        v = self.state.st[:, 3:6]
        return 0.5 * float(np.sum(v * v))

    def thermalise(self) -> None:
        """Rescale velocities to exactly E = (3/2) N T."""
        e = self.kinetic_energy()
        if not e > 0:
            raise SimulationError(f"kinetic energy {e!r}: cannot rescale to T = {self.temperature}")
        self.state.st[:, 3:6] *= math.sqrt(1.5 * self.n * self.temperature / e)

    def _events(self, target: int, count_collisions: bool, rho_target: float | None,
                counters: np.ndarray, acc: np.ndarray) -> tuple[float, bool, bool]:
        """The event loop of a window: kernel calls, list enlargements and rebuilds until ``target`` events (or
        collisions), ``rho_target`` or the self-contact limit. Returns ``(t, reached, self_contact)``."""
        t = 0.0
        need_init = True
        while True:
            s = self.state
            g = s.gamma
            t_list = (s.rho_list - s.rho0) / g if g > 0 else math.inf
            t_target = (rho_target - s.rho0) / g if (rho_target is not None and g > 0) else math.inf
            t_limit = max((self.rho_limit - s.rho0) / g, 0.0) if g > 0 else math.inf
            horizon = min(t_list, t_target, t_limit)
            if need_init:
                ed.init_events(s, t)
            status, t = ed.run_events(s, t, target, count_collisions, horizon, counters, acc)
            if status == ed.WINDOW_DONE:
                return t, False, False
            if status == ed.OVERFLOW:
                self._enlarge_lists()
                need_init = False
            elif status == ed.HORIZON:
                if t >= t_limit:
                    return t, False, True
                if t >= t_target:
                    return t, True, False
                self.rebuild_lists(t)
                need_init = True
            else:
                raise SimulationError(f"event queue inconsistent at t={t!r} (an event time went backwards or NaN)")

    def window(self, target: int, count_collisions: bool = False, rho_target: float | None = None) -> WindowStats:
        """Run one window of ``target`` events (or collisions), then pressure, thermostat and clock reset.

        If ``rho_target`` is reached first, the window ends there (``reached_target``).
        """
        counters = np.zeros(ed.N_COUNTERS, dtype=np.int64)
        acc = np.zeros(1)
        rebuilds0 = self.state.list_rebuilds
        if not np.all(self.state.st[:, 6] == 0.0):
            raise SimulationError("window started with unsynchronised particles")
        t, reached, self_contact = self._events(target, count_collisions, rho_target, counters, acc)
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
        s = self.state
        rho0 = min(s.rho0 + s.gamma * t, self.rho_limit) if self_contact else s.rho0 + s.gamma * t
        self.state = s = s._replace(rho0=rho0)
        s.st[:, 6] = 0.0
        h = ed.min_listed_ratio(s.st, s.nbr, s.nnb, s.box, s.rho0)
        if h < 1.0 - AUDIT_TOLERANCE:
            raise SimulationError(f"overlap {1.0 - h:.3e} (relative) after a window: an event was lost")
        return WindowStats(
            duration=t, pressure=pressure, temperature=temperature, collisions=int(counters[ed.C_COLLISIONS]),
            events=int(counters[ed.C_EVENTS]), skin_events=int(counters[ed.C_SKIN]),
            moves=int(counters[ed.C_MOVES]), null_collisions=int(counters[ed.C_NULL]),
            list_rebuilds=s.list_rebuilds - rebuilds0, reached_target=reached, self_contact=self_contact,
        )


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


@dataclass
class RateState:
    """What a :class:`Controller` changes window by window (a checkpoint saves it whole): the rate gamma."""

    rate: float


def restore_dataclass(cls, saved: dict[str, Any]):
    """``cls`` from a checkpoint's dict, each field cast to its type; a field the checkpoint lacks (written before
    the field existed) takes its default."""
    return cls(**{name: kind(saved[name]) for name, kind in get_type_hints(cls).items() if name in saved})


class Controller:
    """Decides the compression rate window by window (plain LS: constant rate, stop at p >= p_max); its
    changing part is ``state`` (a :class:`RateState`)."""

    kind = CHECKPOINT_KIND_LS

    def __init__(self, rate: float, p_max: float):
        self.state = RateState(float(rate))
        self.p_max = float(p_max)

    @property
    def rate(self) -> float:
        return self.state.rate

    def restore(self, saved: dict[str, Any]) -> None:
        """Continue from a checkpoint's ``dataclasses.asdict(state)``."""
        self.state = restore_dataclass(type(self.state), saved)

    def after_window(self, stats: WindowStats) -> str | None:
        """Update the rate after a window; return a stop reason or None."""
        return "p_max" if stats.pressure >= self.p_max else None

    def extra_row(self) -> dict[str, Any]:
        """Columns the controller adds to the history row of a window."""
        return {}

    def progress_fields(self) -> dict[str, Any]:
        """What the live status line shows of the controller (the driver adds p, phi, collisions/s)."""
        return {"γ": self.rate}

    def extras(self, counts: LSCounts) -> LSCounts | MLSCounts:
        """The extras of the run's :class:`RunStats`, from the event totals."""
        return counts


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
        self.engine = LSEngine.start(self.input.positions, self.nominal, self.input.box, rho, velocities,
                                     self.controller.rate, self.temperature, **(self.engine_options or {}))
        self._phi_initial = self.phi_nominal * rho**3

    def load(self, arrays, attrs, history) -> None:
        saved = {k[len(_ENGINE):]: v for k, v in arrays.items() if k.startswith(_ENGINE)}
        state = restore_state(saved, attrs["engine"], self.input.box)
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
