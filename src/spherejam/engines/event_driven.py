"""The event-driven engine of Lubachevsky–Stillinger (LS) compression: MD of hard spheres whose diameters grow
linearly in time, stepped by windows.

Physics (paper §III.B; docs/algorithms.md §2). Mass m = 1, k_B = 1, temperature T = 0.2 (rms speed sqrt(3 T)).
Diameters are D_i(t) = D_i0 (rho0 + gamma t): D_i0 are the nominal diameters (the input's actual diameters divided
by their mean, so mean 1 in the box's length unit), rho0 starts at the input's closest-pair ratio (the closest pair
touches) and gamma = d rho/dt is the compression rate (per unit time). Collisions are elastic in the frame of the
growing surfaces: the normal relative speed w becomes 2 g - w, g = gamma D_ij.

Windows. A window is ``target`` events (all event kinds, as in the paper's C++ code; or collisions only). After
each window:

* reduced pressure p = PV/(N k_B T) = 1 + |X| / (2 E dt) from the collision virial X = sum |r_ij| (v_i - v_j).n_ij
  (pre-collision velocities, growth term excluded), E = kinetic energy at the end of the window, dt its duration;
  in a container a wall collision adds r_i times the impulse the wall gives, with V the container's volume
  (docs/containers.md §3);
* thermostat: velocities are rescaled to exactly E = (3/2) N T;
* clock reset: rho0 += gamma dt, t = 0 (keeps times small near jamming; every event is re-predicted, none lost);
* audit: every listed pair is checked for overlap (relative tolerance 1e-10), else :class:`SimulationError`.

The numba code (events, heap, neighbour lists) is :mod:`spherejam.engines.kernels.event_driven`; the runs built on
windows are :mod:`spherejam.engines.lubachevsky_stillinger` (LS) and :mod:`spherejam.engines.closest_jamming` (MLS).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, get_type_hints

import numpy as np

from ..core.container import Container
from ..core.errors import SimulationError
from ..core.neighbours import Frame, cell_sort, cells_per_axis
from .kernels import event_driven as ed

DEFAULT_TEMPERATURE = 0.2
#: Relative overlap that makes a window audit (or the final audit) fail.
AUDIT_TOLERANCE = 1e-10
#: Largest Verlet skin, in box lengths, when pairs meet through several images: a pair then reaches at most the
#: images one box length from its minimum image (list cutoff <= L + 2 skin < 1.5 L).
MULTI_IMAGE_MAX_SKIN = 0.2
#: The cell grid gets levels once the largest sphere is this many times the median one (docs/algorithms.md §7.4):
#: below it one grid sized by the largest sphere costs little (sigma <= 0.3, 1:3), above it that grid's cells hold
#: hundreds of small spheres, or the whole box is one cell.
LEVEL_RATIO = 4.0


def grid_levels(nominal: np.ndarray, rho_list: float, skin: float, frame: Frame) -> tuple[np.ndarray, ...]:
    """The levels of the cell grid for spheres of nominal diameters D_i: ``(level, lvl_ms, lvl_off, lvl_dmax)``
    (the :class:`~.kernels.event_driven.EventState` fields).

    One level (today's one grid, sized by the largest sphere) unless D_max >= LEVEL_RATIO x the median; then level
    0 holds the spheres up to twice the median and each further level those up to twice the previous bound (empty
    levels dropped), each grid sized by its own largest sphere and its own count (docs/algorithms.md §7.4)."""
    n = len(nominal)
    dmax = float(nominal.max())
    typical = float(np.median(nominal))
    if not dmax >= LEVEL_RATIO * typical:
        ms = cells_per_axis(frame, rho_list * dmax + skin, n)
        return (np.zeros(n, dtype=np.int32), ms[None, :], np.array([0, int(np.prod(ms))], dtype=np.int64),
                np.array([dmax]))
    bounds = [2.0 * typical]
    while bounds[-1] < dmax:
        bounds.append(2.0 * bounds[-1])
    raw = np.searchsorted(np.array(bounds), nominal, side="left")
    used, level = np.unique(raw, return_inverse=True)
    lvl_ms, lvl_dmax, offsets = [], [], [0]
    for lv in range(len(used)):
        members = nominal[level == lv]
        d = float(members.max())
        ms = cells_per_axis(frame, rho_list * d + skin, len(members))
        lvl_ms.append(ms)
        lvl_dmax.append(d)
        offsets.append(offsets[-1] + int(np.prod(ms)))
    return (level.astype(np.int32), np.array(lvl_ms, dtype=np.int64), np.array(offsets, dtype=np.int64),
            np.array(lvl_dmax))


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
    wall_collisions: int = 0
    wall_impulse: float = 0.0  #: total impulse the walls gave the spheres (growth term excluded), m = 1
    #: the diagonal of the reduced pressure tensor, P_kk V / (N k_B T) along x, y, z (their mean is ``pressure``);
    #: measured in a container with walls only
    pressure_axes: tuple = (math.nan, math.nan, math.nan)


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


def _frame_fields(box) -> dict:
    """The :class:`~.kernels.event_driven.EventState` fields of a cube side L or a container."""
    container = box if isinstance(box, Container) else Container.cube(float(box))
    if container.dim != 3:
        raise SimulationError(f"the event-driven engine runs in d = 3 (container {container.spec})")
    frame = Frame.of(container)
    return {"lengths": frame.lengths, "half": frame.half, "periodic": frame.periodic,
            "walls": container.wall_array(), "has_walls": container.has_walls}


def fresh_state(positions, nominal, box, rho, velocities, gamma) -> ed.EventState:
    """An :class:`~.kernels.event_driven.EventState` of N spheres at time 0 whose lists are still to be built
    (:meth:`LSEngine.rebuild_lists`): positions (N, 3), nominal diameters D_i0 (N,), box side L or a
    :class:`~spherejam.core.container.Container`, scale factor rho0 (no pair may overlap, and no sphere cross a wall,
    at it), velocities (N, 3) and compression rate gamma = d rho / dt >= 0."""
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
                         **ed.workspace(n, cap), **_frame_fields(box), lvl_ms=np.ones((1, 3), dtype=np.int64),
                         lvl_off=np.array([0, 1], dtype=np.int64), lvl_dmax=np.array([float(np.max(nominal))]),
                         level=np.zeros(n, dtype=np.int32), rho0=float(rho), gamma=float(gamma), rho_list=float(rho),
                         skin=0.0, multi=False, list_rebuilds=0)


def restore_state(arrays: dict[str, np.ndarray], scalars: dict[str, Any], box) -> ed.EventState:
    """The state a checkpoint saved (:meth:`~.kernels.event_driven.EventState.persistent`), work space fresh.

    The frame and walls come from ``box`` (the input's cube side or container), not from the checkpoint. Checkpoints
    written before containers hold one grid's cells per side as ``m``; before multi-image lists they lack ``multi``
    (they are single-image); their fields are otherwise the same."""
    arrays = dict(arrays)
    if "lvl_ms" not in arrays and "m" in scalars:
        m = int(scalars["m"])
        arrays.update(lvl_ms=np.full((1, 3), m, dtype=np.int64), lvl_off=np.array([0, m**3], dtype=np.int64),
                      lvl_dmax=np.array([float(arrays["st"][:, 7].max())]),
                      level=np.zeros(len(arrays["st"]), dtype=np.int32))
    scalars = {"multi": False, **scalars}
    frame = _frame_fields(box)
    fields = {}
    for name, kind in get_type_hints(ed.EventState).items():
        if name in ed.WORKSPACE:
            continue
        if name in frame:
            fields[name] = frame[name]
        else:
            fields[name] = _aligned_copy(arrays[name]) if kind is np.ndarray else kind(scalars[name])
    return ed.EventState(**fields, **ed.workspace(len(fields["st"]), fields["nbr"].shape[1]))


class LSEngine:
    """Event-driven MD of N growing hard spheres in a periodic box or a container (d = 3): an
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
    def period(self) -> float:
        """The shortest periodic length of the frame (inf if no axis is periodic)."""
        s = self.state
        return float(min((L for L, p in zip(s.lengths, s.periodic) if p), default=math.inf))

    @property
    def volume(self) -> float:
        """The frame's volume prod L_k (the spheres' space in a periodic box or a slab)."""
        return float(np.prod(self.state.lengths))

    @property
    def rho_limit(self) -> float:
        """The scale factor at which the largest sphere touches its own periodic image (diameter L_k along a
        periodic axis): no sphere can grow beyond it."""
        return self.period / float(self.state.st[:, 7].max())

    # --- neighbour lists ------------------------------------------------------------------------------------

    def rebuild_lists(self, t: float) -> None:
        """Rebuild all Verlet lists at time t (every particle must be synchronised to t)."""
        s, opt = self.state, self.options
        n, frame = self.n, Frame(s.lengths, s.periodic)
        nominal = s.st[:, 7]
        rho = s.rho0 + s.gamma * t
        dmean, dmax = float(nominal.mean()), float(nominal.max())
        margin = opt.list_margin if s.gamma > 0 else 0.0
        volume = frame.lengths[0] ** 3 if frame.is_periodic_cube else self.volume
        spacing = (volume / n) ** (1.0 / 3.0)
        r_dilute = spacing * (3.0 * opt.dilute_neighbours / (4.0 * math.pi)) ** (1.0 / 3.0)
        period = self.period
        limit = 0.45 * period  # single image: every list cutoff stays below L_k/2 along periodic axes
        multi = opt.all_images or not rho * dmax < 0.9 * limit
        if not multi:
            rho_list = min(rho * (1.0 + margin), 0.95 * limit / dmax)
            max_skin = limit - rho_list * dmax
        else:  # pairs may meet through several images (docs/algorithms.md, "Any box, any size ratio")
            rho_list = min(rho * (1.0 + margin), self.rho_limit)
            max_skin = MULTI_IMAGE_MAX_SKIN * period  # images one period away suffice (ed.image_collision)
        skin = min(max(opt.skin_fraction * rho_list * dmean, r_dilute - rho_list * dmean), max_skin)
        level, lvl_ms, lvl_off, lvl_dmax = grid_levels(nominal, rho_list, skin, frame)
        st, perm, order = self._sorted_by_cell(lvl_ms[0])
        level = level[order]  # each particle keeps its level through the renumbering
        cap = s.nbr.shape[1]
        while True:
            nbr = _aligned_zeros((n, cap), np.int32)
            refs, nnb, head, nxt, prv, cellof, max_count = ed.build_lists(
                st, s.lengths, s.half, s.periodic, rho_list, skin, lvl_ms, lvl_off, lvl_dmax, level, nbr)
            if max_count + 4 <= cap:
                break
            cap = _round_cap(1.5 * max_count + 16)
        self.state = s._replace(st=st, perm=perm, refs=refs, nbr=nbr, nnb=nnb, head=head, nxt=nxt, prv=prv,
                                cellof=cellof, scratch=ed.scratch_row(cap), lvl_ms=lvl_ms, lvl_off=lvl_off,
                                lvl_dmax=lvl_dmax, level=level, rho_list=rho_list, skin=skin, multi=multi,
                                list_rebuilds=s.list_rebuilds + 1)

    def _sorted_by_cell(self, ms: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``(st, perm, order)``: the rows renumbered in the order of the cells of the grid of ``ms`` cells per axis
        (the finest level), so that neighbours sit close in memory (all particles synchronised); new row k is old
        row order[k]."""
        s = self.state
        order = cell_sort(np.mod(s.st[:, 0:3], s.lengths), s.lengths, ms)[2]
        if np.any(order != np.arange(self.n)):
            return _aligned_copy(s.st[order]), s.perm[order], order
        return s.st, s.perm, order

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
            # copies of the long lists serve the single-image prediction only (docs/algorithms.md §7.8)
            status, t = ed.run_events(s, t, target, count_collisions, horizon, counters, acc, not s.multi)
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
        acc = np.zeros(ed.N_ACCUMULATORS)
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
        pressure = 1.0 + abs(acc[ed.A_VIRIAL]) / (2.0 * e * t) if t > 0 else math.inf
        axes = tuple(1.0 + 3.0 * abs(acc[ed.A_AXES + k]) / (2.0 * e * t) if t > 0 else math.inf for k in range(3)) \
            if self.state.has_walls else (math.nan,) * 3
        temperature = 2.0 * e / (3.0 * self.n)
        self.thermalise()
        s = self.state
        rho0 = min(s.rho0 + s.gamma * t, self.rho_limit) if self_contact else s.rho0 + s.gamma * t
        self.state = s = s._replace(rho0=rho0)
        s.st[:, 6] = 0.0
        h = ed.min_listed_ratio(s.st, s.nbr, s.nnb, s.lengths, s.half, s.rho0)
        if h < 1.0 - AUDIT_TOLERANCE:
            raise SimulationError(f"overlap {1.0 - h:.3e} (relative) after a window: an event was lost")
        if s.has_walls:
            h = ed.min_wall_ratio(s.st, s.lengths, s.walls, s.rho0)
            if h < 1.0 - AUDIT_TOLERANCE:
                raise SimulationError(f"wall penetration {1.0 - h:.3e} (relative) after a window: an event was lost")
        return WindowStats(
            duration=t, pressure=pressure, temperature=temperature, collisions=int(counters[ed.C_COLLISIONS]),
            events=int(counters[ed.C_EVENTS]), skin_events=int(counters[ed.C_SKIN]),
            moves=int(counters[ed.C_MOVES]), null_collisions=int(counters[ed.C_NULL]),
            list_rebuilds=s.list_rebuilds - rebuilds0, reached_target=reached, self_contact=self_contact,
            wall_collisions=int(counters[ed.C_WALL]), wall_impulse=float(acc[ed.A_WALL_IMPULSE]), pressure_axes=axes,
        )
