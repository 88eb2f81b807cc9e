"""Event-driven machinery for hard spheres with linearly growing diameters in a periodic box or a container with
walls (d = 3; core/container, docs/containers.md).

This is the inner engine of the Lubachevsky–Stillinger protocol: the windows (pressure, thermostat, audit) live in
:mod:`spherejam.engines.event_driven`, the run (stopping, checkpoints) in
:mod:`spherejam.engines.lubachevsky_stillinger`. All functions are numba ``njit(cache=True)`` kernels over plain
arrays.

State (one :class:`EventState`; particles as a structure of arrays, one cache line per particle)
    ``st[i] = (x, y, z, vx, vy, vz, t_i, D_i)``: position at the particle's own last-update time ``t_i``
    (positions are advanced lazily, x(t) = x_i + v_i (t - t_i)), velocity, and nominal diameter D_i (mean 1).
    Actual diameters are rho(t) D_i with rho(t) = rho0 + gamma t (gamma = d rho/dt, the paper's compression rate).

Events (Lubachevsky 1991: one scheduled event per particle, kept in an indexed 4-ary min-heap)
    ``MOVE``      re-predict only (an invalidated prediction, or the initial state),
    ``COLLISION`` with ``ev_partner[i]``; the partner always holds the mirror event (same time, partner i),
    ``SKIN``      the particle leaves its Verlet skin sphere: its neighbour list is rebuilt locally,
    ``WALL``      with wall ``ev_partner[i]`` (2k, 2k + 1: the planes x_k = 0 and x_k = L_k; :data:`CURVED_WALL`: the
                  cylinder or sphere), reflected in the frame of the growing surface.
    A collision with j is accepted only if it is not later than j's own event ("availability"); when j's previous
    partner k loses j, k's event is demoted to a MOVE at the same time.

Neighbour lists (exact at every density)
    j is listed with i iff |X_i - X_j| < rho_list D_ij + skin for the reference centres X. While every particle is
    within skin/2 of its reference centre and rho(t) <= rho_list, every pair that can touch is listed. Leaving the
    skin sphere is a per-particle event (a local, symmetric list update through a linked-cell grid, no global sweep);
    a wide size distribution gets a grid of several **levels** (docs/algorithms.md §7.4): each sphere is linked in
    the level sized for its own size class, and a search visits every level with a stencil as wide as its reach;
    reaching rho_list ends a kernel call (``HORIZON``) so the caller rebuilds all lists. Both the skin and rho_list
    are set from the *actual* diameters, so growth from phi ~ 1e-5 to jamming stays exact and O(N) per sweep.
    Positions are wrapped into the box only when the particle's list is rebuilt, so a single +-L fold gives the
    minimum image. A pair is listed once, by its minimum image; in a box smaller than two list cutoffs (``multi``:
    small N, or a sphere wider than ~L/2.5) the prediction also tries the images one box length away, and a
    collision is resolved on the image that was predicted (docs/algorithms.md, "Any box, any size ratio").

Frame and walls
    The box is the frame [0, L_0) x [0, L_1) x [0, L_2) of a container: differences fold (one fold, ``half`` = L_k/2)
    along periodic axes only; along a walled axis ``half`` is +inf, so nothing folds there, and the cell stencils end
    at the walls. Wall events are predicted beside the pair events of a particle, behind one loop-invariant test, so
    the periodic path runs the same operations as before walls existed.

Speed (the hot loop is a prediction over ~10 neighbours)
    Unpredictable tests are written as selects or non-short-circuit ``&``/``|`` (a mispredicted jump costs about
    as much as a whole pair test); neighbours' rows are prefetched before use, so cache misses overlap; the caller
    keeps ``st`` and ``nbr`` on 64-byte boundaries and renumbers particles in cell order at every full rebuild. A
    list longer than :data:`LONG_LIST` (a large sphere of a wide mixture) is predicted in two passes
    (:func:`_predict_long`, docs/algorithms.md §7.7), with the same events.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from llvmlite import ir
from numba import carray, njit, types
from numba.core import cgutils
from numba.extending import intrinsic

from ...core.neighbours import (axis_cell, cell_of, fold, link_levels, move_to_cell, stencil_cell, stencil_size,
                                unravel_cell)


class EventState(NamedTuple):
    """The whole state of the event-driven engine, one object (numba types a NamedTuple of arrays and scalars).

    The kernels write into its arrays in place and only read its scalars; the caller replaces the tuple
    (``_replace``) when a scalar changes or a full rebuild reallocates an array. Checkpoints save it whole
    (:meth:`persistent`), minus the :data:`WORKSPACE` that every window recomputes (docs/algorithms.md §7.3).
    """

    st: np.ndarray  #: (N, 8) float64 rows (x, y, z, vx, vy, vz, t_i, D_i), 64-byte aligned
    perm: np.ndarray  #: (N,) int64 row -> input particle index (rows are renumbered in cell order)
    refs: np.ndarray  #: (N, 3) reference centres of the Verlet lists
    nbr: np.ndarray  #: (N, cap) int32 neighbour lists, 64-byte aligned
    nnb: np.ndarray  #: (N,) int32 list lengths
    head: np.ndarray  #: linked cells of the reference centres (core.neighbours.link_levels)
    nxt: np.ndarray
    prv: np.ndarray
    cellof: np.ndarray
    ev_time: np.ndarray  #: (N,) each particle's scheduled event
    ev_type: np.ndarray  #: (N,) int8 MOVE, COLLISION or SKIN
    ev_partner: np.ndarray  #: (N,) int32 collision partner or -1
    heap: np.ndarray  #: (N,) int32 indexed 4-ary min-heap of particles by event time
    hpos: np.ndarray  #: (N,) int32 heap position of each particle
    hkey: np.ndarray  #: (N,) event times in heap order
    scratch: np.ndarray  #: (1, >= cap) int32 work row of a local list update
    lengths: np.ndarray  #: (3,) edges L_k of the frame (the side L thrice for the periodic cube)
    half: np.ndarray  #: (3,) L_k / 2 along periodic axes, +inf along walled ones (nothing folds there)
    periodic: np.ndarray  #: (3,) bool
    walls: np.ndarray  #: (9,) the container's walls (core.container.Container.wall_array)
    lvl_ms: np.ndarray  #: (levels, 3) int64 cells per axis of each level of the grid (one level: one grid)
    lvl_off: np.ndarray  #: (levels + 1,) int64 index of each level's first cell in ``head``
    lvl_dmax: np.ndarray  #: (levels,) the largest nominal diameter linked in each level
    level: np.ndarray  #: (N,) int32 the level each particle is linked in
    rho0: float  #: diameter scale factor at t = 0 of the current window
    gamma: float  #: compression rate d rho / dt
    rho_list: float  #: scale factor up to which the lists are exact
    skin: float  #: Verlet skin
    multi: bool  #: pairs may meet through several periodic images
    has_walls: bool  #: the container has walls (wall events are predicted)
    list_rebuilds: int  #: full rebuilds so far

    def persistent(self) -> tuple[dict[str, np.ndarray], dict[str, float | int | bool]]:
        """``(arrays, scalars)``: every field but the :data:`WORKSPACE` and the :data:`FRAME`, for a checkpoint."""
        arrays, scalars = {}, {}
        for name, value in self._asdict().items():
            if name not in WORKSPACE and name not in FRAME:
                (arrays if isinstance(value, np.ndarray) else scalars)[name] = value
        return arrays, scalars


#: Fields whose contents are dead between windows: a window predicts every event afresh (:func:`init_events`) and
#: the scratch row holds nothing across calls. A restored state gets them from :func:`workspace`.
WORKSPACE = ("ev_time", "ev_type", "ev_partner", "heap", "hpos", "hkey", "scratch")


#: Fields that the input's container fixes (its frame and walls): a checkpoint does not hold them, a restored state
#: gets them from the input.
FRAME = ("lengths", "half", "periodic", "walls", "has_walls")


def workspace(n: int, cap: int) -> dict[str, np.ndarray]:
    """Fresh :data:`WORKSPACE` arrays for N particles and neighbour lists of width ``cap``."""
    return {"ev_time": np.zeros(n), "ev_type": np.zeros(n, dtype=np.int8),
            "ev_partner": np.full(n, -1, dtype=np.int32), "heap": np.zeros(n, dtype=np.int32),
            "hpos": np.zeros(n, dtype=np.int32), "hkey": np.zeros(n), "scratch": scratch_row(cap)}


def scratch_row(cap: int) -> np.ndarray:
    return np.zeros((1, max(cap, 64)), dtype=np.int32)


MOVE = 0
COLLISION = 1
SKIN = 2
WALL = 3
#: ``ev_partner`` of a WALL event with the curved wall (a cylinder or a sphere); the planes are 0 .. 5.
CURVED_WALL = 6

#: Kernel return codes.
WINDOW_DONE = 0  #: the requested number of events (or collisions) was processed
HORIZON = 1  #: the next event lies beyond the time horizon; every particle is synchronised to it
OVERFLOW = 2  #: a neighbour list is full; enlarge the capacity and call again (state untouched)
INCONSISTENT = 3  #: an event time went backwards or became NaN

# The event heap is 4-ary (children of node k: 4k+1 ... 4k+4, parent (k-1) >> 2), hard-wired in the unrolled
# minimum of _sift_down.

#: Indices into the integer counter array of a window.
C_EVENTS, C_COLLISIONS, C_SKIN, C_MOVES, C_NULL, C_WALL = 0, 1, 2, 3, 4, 5
N_COUNTERS = 6
#: Indices into the float accumulator array of a window: the virial sum_c |lever| * impulse (pairs and walls), the
#: total impulse given to the walls, and the virial's diagonal components sum_c |lever| * impulse * n_k^2 along the
#: three axes (growth term excluded in all; docs/containers.md §3).
A_VIRIAL, A_WALL_IMPULSE, A_AXES = 0, 1, 2
N_ACCUMULATORS = 5

_INF = np.inf
_SLOW = 1e-200  # |v|^2 below which the skin-exit root is solved in units of |v| (a * c would underflow)
_REACH_SLACK = 1e-9  # relative: a wall test's reach covers the round-off of positions and of rho0 + gamma t


@intrinsic
def _prefetch_row(typingctx, arr, i):
    """Hint the CPU to load row i of a 2-d array (llvm.prefetch, no fault on any address): the neighbours' rows
    then arrive in parallel instead of one cache miss at a time behind the branches of the prediction loop."""
    if not (isinstance(arr, types.Array) and arr.ndim == 2 and isinstance(i, types.Integer)):
        return None

    def codegen(context, builder, signature, args):
        aryty, idxty = signature.args
        ary = context.make_array(aryty)(context, builder, args[0])
        row = context.cast(builder, args[1], idxty, types.intp)
        ptr = cgutils.get_item_pointer(context, builder, aryty, ary, [row, context.get_constant(types.intp, 0)])
        i8p = ir.IntType(8).as_pointer()
        i32 = ir.IntType(32)
        fn = cgutils.get_or_insert_function(builder.module, ir.FunctionType(ir.VoidType(), [i8p, i32, i32, i32]),
                                            "llvm.prefetch")
        builder.call(fn, [builder.bitcast(ptr, i8p), i32(0), i32(3), i32(1)])
        return context.get_dummy_value()

    return types.void(arr, i), codegen


# --- indexed 4-ary min-heap over particles, keyed by ev_time ------------------------------------------------------
# Four children per node: half the depth of a binary heap, and the four child keys share one or two cache lines.
# Parent of k: (k - 1) >> 2; children: 4 k + 1 .. 4 k + 4.


@njit(cache=True, inline="always")
def _sift_up(heap, hpos, hkey, k, i, ki):
    """Place particle i with key ki at hole k, moving it towards the root."""
    while k > 0:
        parent = (k - 1) >> 2
        if hkey[parent] <= ki:
            break
        p = heap[parent]
        heap[k] = p
        hkey[k] = hkey[parent]
        hpos[p] = k
        k = parent
    heap[k] = i
    hkey[k] = ki
    hpos[i] = k


@njit(cache=True, inline="always")
def _sift_down(heap, hpos, hkey, k, i, ki, n):
    """Place particle i with key ki at hole k, moving it towards the leaves."""
    while True:
        c = 4 * k + 1
        if c >= n:
            break
        cv = hkey[c]
        if c + 3 < n:
            # branch-free minimum of the four children (selects, not jumps: the winner is unpredictable)
            v1 = hkey[c + 1]
            v2 = hkey[c + 2]
            v3 = hkey[c + 3]
            c01 = c + 1 if v1 < cv else c
            v01 = min(cv, v1)
            c23 = c + 3 if v3 < v2 else c + 2
            v23 = min(v2, v3)
            c = c23 if v23 < v01 else c01
            cv = min(v01, v23)
        else:
            c0 = c
            for q in range(c0 + 1, n):
                v = hkey[q]
                if v < cv:
                    cv = v
                    c = q
        if ki <= cv:
            break
        p = heap[c]
        heap[k] = p
        hkey[k] = cv
        hpos[p] = k
        k = c
    heap[k] = i
    hkey[k] = ki
    hpos[i] = k


@njit(cache=True, inline="always")
def heap_update(heap, hpos, hkey, i, ki, n):
    """Give particle i the key ki and restore the heap (keys are stored in heap order: no indirection)."""
    k = hpos[i]
    if k > 0 and hkey[(k - 1) >> 2] > ki:
        _sift_up(heap, hpos, hkey, k, i, ki)
    else:
        _sift_down(heap, hpos, hkey, k, i, ki, n)


@njit(cache=True)
def heap_build(heap, hpos, hkey, key, n):
    for k in range(n):
        heap[k] = k
        hkey[k] = key[k]
        hpos[k] = k
    for k in range((n - 2) // 4, -1, -1):
        _sift_down(heap, hpos, hkey, k, heap[k], hkey[k], n)


# --- pair kinematics -------------------------------------------------------------------------------------------


@njit(cache=True, inline="always")
def collision_delay(rx, ry, rz, ux, uy, uz, sig, rho, gamma):
    """Time tau >= 0 until |r + u tau| = sig (rho + gamma tau), or inf.

    ``r`` = x_j - x_i, ``u`` = v_j - v_i, ``sig`` = nominal contact distance D_ij, ``rho`` the current scale factor.
    Solves A tau^2 + 2 B tau + C = 0 with A = u.u - sig^2 gamma^2, B = r.u - sig^2 rho gamma,
    C = r.r - sig^2 rho^2, using the cancellation-free root. Touching or (round-off) overlapping pairs collide at
    once iff they approach in the frame of the growing surfaces (d/dt (|r| - sig rho) < 0), else never.
    """
    s2 = sig * sig
    ru = rx * ux + ry * uy + rz * uz
    b = ru - s2 * rho * gamma
    a = ux * ux + uy * uy + uz * uz - s2 * gamma * gamma
    if b >= 0.0 and a >= 0.0:
        return _INF
    r2 = rx * rx + ry * ry + rz * rz
    c = r2 - s2 * rho * rho
    if c <= 0.0:
        # the gap |r| - sig rho is convex in time: if it is not shrinking now it never will
        if ru < np.sqrt(r2) * sig * gamma:
            return 0.0
        return _INF
    disc = b * b - a * c
    if disc < 0.0:
        if disc > -1e-14 * b * b:  # grazing: round-off made a double root negative
            disc = 0.0
        else:
            return _INF
    if b < 0.0:
        return c / (np.sqrt(disc) - b)
    return (b + np.sqrt(disc)) / (-a)


@njit(cache=True, inline="always")
def skin_exit_delay(dx, dy, dz, vx, vy, vz, h):
    """Time until a particle at offset d from its reference centre, moving at v, reaches distance h (or inf)."""
    a = vx * vx + vy * vy + vz * vz
    c = dx * dx + dy * dy + dz * dz - h * h
    if c >= 0.0:
        return 0.0
    if a < _SLOW:
        # a rattler the thermostat has slowed to |v| ~ 1e-160: a * c underflows and the root below would be 0, an
        # endless loop of zero-time skin events; solve along the unit vector instead (docs/algorithms.md, "Rattlers
        # the thermostat has slowed")
        big = max(abs(vx), abs(vy), abs(vz))
        if big == 0.0:
            return _INF
        s = big * np.sqrt((vx / big) ** 2 + (vy / big) ** 2 + (vz / big) ** 2)  # |v| without underflow
        bu = dx * (vx / s) + dy * (vy / s) + dz * (vz / s)
        squ = np.sqrt(bu * bu - c)
        reach = -c / (bu + squ) if bu > 0.0 else squ - bu  # distance along v to the skin sphere, > 0
        return reach / s
    b = dx * vx + dy * vy + dz * vz
    sq = np.sqrt(b * b - a * c)
    # cancellation-free root; the sign of b is random, so select instead of branching
    num = -c if b > 0.0 else sq - b
    den = b + sq if b > 0.0 else a
    return num / den


#: Image codes: the image r + (a, b, c) L of a pair is code (a + 1) + 3 (b + 1) + 9 (c + 1), a, b, c in -1..1;
#: the minimum image is MINIMUM_IMAGE, and the pair seen from its other sphere has code 26 - code.
MINIMUM_IMAGE = 13


@njit(cache=True, inline="always")
def image_collision(rx, ry, rz, ux, uy, uz, sig, rho, gamma, lengths, periodic, reach, skip, t, until):
    """``(tau, code)``: :func:`collision_delay` minimised over the periodic images r + (a L_0, b L_1, c L_2), a, b, c
    in -1..1 (0 along a walled axis), of a pair whose minimum image is r, taking only images within ``reach`` along
    every axis and not image ``skip`` (the image that has just collided; -1: none). For boxes smaller than two list
    cutoffs. An image whose collision time t + delay could only come after ``until`` is not solved for: its delay is
    at least C / (-2 B) (:func:`collision_delay`'s coefficients; :func:`delay_bound`), and where t + that bound >
    until, rounded as the caller rounds t + delay, the caller would reject the delay anyway, so it chooses as over
    every image. ``until`` = inf: every image."""
    best = _INF
    best_code = MINIMUM_IMAGE
    s2 = sig * sig
    qa = ux * ux + uy * uy + uz * uz - s2 * gamma * gamma
    px = 1 if periodic[0] else 0
    py = 1 if periodic[1] else 0
    pz = 1 if periodic[2] else 0
    for a in range(-px, px + 1):
        x = rx + a * lengths[0]
        if abs(x) >= reach:
            continue
        for b in range(-py, py + 1):
            y = ry + b * lengths[1]
            if abs(y) >= reach:
                continue
            for c in range(-pz, pz + 1):
                z = rz + c * lengths[2]
                code = (a + 1) + 3 * (b + 1) + 9 * (c + 1)
                if abs(z) >= reach or code == skip:
                    continue
                # branches, not delay_bound: its unguarded division by B = 0 needs the numpy error model, which the
                # event loop this is inlined into does not use
                if qa >= 0.0:
                    qb = x * ux + y * uy + z * uz - s2 * rho * gamma
                    if qb >= 0.0:
                        continue  # receding: collision_delay returns inf
                    qc = x * x + y * y + z * z - s2 * rho * rho
                    if qc > 0.0 and qb < -1e-150 and t + qc / (-2.0 * qb) > until:
                        continue
                tau = collision_delay(x, y, z, ux, uy, uz, sig, rho, gamma)
                if tau < best:
                    best = tau
                    best_code = code
    return best, best_code


# --- wall kinematics (docs/containers.md §2) ----------------------------------------------------------------------


@njit(cache=True, inline="always")
def plane_delay(gap, rate):
    """Time until a sphere's gap to a flat wall, ``gap`` = distance of the centre minus the radius, closes at the rate
    ``rate`` = d gap/dt (the centre's speed away from the wall minus the radius' growth), or inf. A touching (or,
    by round-off, penetrating) sphere collides at once iff it approaches."""
    if rate >= 0.0:
        return _INF
    if gap <= 0.0:
        return 0.0
    return gap / -rate


@njit(cache=True, inline="always")
def concave_delay(px, py, pz, wx, wy, wz, reach, a):
    """Time until a sphere whose centre is at offset p from the axis (cylinder) or the centre (sphere) of a concave
    wall, moving at w, touches it: |p + w tau| = reach - a tau, with ``reach`` = R - r the room of the centre and
    ``a`` = dr/dt the growth of the radius; inf if never.

    F(tau) = (reach - a tau)^2 - |p + w tau|^2 = A tau^2 + 2 B tau + C, A = a^2 - |w|^2, B = -a reach - p.w,
    C = reach^2 - |p|^2 > 0 inside. Its smallest positive root is the contact (F = g (reach - a tau + |p + w tau|)
    with g the gap, and the second factor is positive until reach - a tau = 0, where g <= 0), taken in the
    cancellation-free form. A touching sphere collides at once iff it approaches in the frame of its growing
    surface (p^.w + a > 0); one that leaves the wall inwards meets it again across the container (the root
    -2B/A of F with C = 0), unlike a pair, whose gap never closes again once it opens."""
    p2 = px * px + py * py + pz * pz
    c = reach * reach - p2
    pw = px * wx + py * wy + pz * wz
    aa = a * a - (wx * wx + wy * wy + wz * wz)
    b = -a * reach - pw
    if c <= 0.0:
        if pw + a * np.sqrt(p2) > 0.0:
            return 0.0
        if aa < 0.0 and b > 0.0:
            return 2.0 * b / -aa
        return _INF
    disc = b * b - aa * c
    if disc < 0.0:  # only a > |w| can make it negative, and then a root exists: round-off
        disc = 0.0
    if b < 0.0:
        return c / (np.sqrt(disc) - b)
    if aa < 0.0:
        return (b + np.sqrt(disc)) / (-aa)
    return _INF


@njit(cache=True)
def wall_event(xi, yi, zi, vxi, vyi, vzi, r, a, lengths, walls):
    """``(tau, wall)``: the first wall particle i meets (centre x, velocity v, radius r growing at a), or (inf, -1).
    ``walls`` is :meth:`~spherejam.core.container.Container.wall_array`. A call, not inlined: the periodic path's
    prediction stays as small as it was."""
    best = _INF
    wall = -1
    for k in range(3):
        if walls[k] != 0.0:
            x = xi if k == 0 else (yi if k == 1 else zi)
            v = vxi if k == 0 else (vyi if k == 1 else vzi)
            tau = plane_delay(x - r, v - a)
            if tau < best:
                best, wall = tau, 2 * k
            tau = plane_delay(lengths[k] - x - r, -v - a)
            if tau < best:
                best, wall = tau, 2 * k + 1
    kind = walls[3]
    if kind != 0.0:
        px = xi - walls[5]
        py = yi - walls[6]
        pz = zi - walls[7]
        wx, wy, wz = vxi, vyi, vzi
        if kind == 1.0:  # a cylinder: only the components across its axis count
            axis = walls[4]
            if axis == 0.0:
                px, wx = 0.0, 0.0
            elif axis == 1.0:
                py, wy = 0.0, 0.0
            else:
                pz, wz = 0.0, 0.0
        tau = concave_delay(px, py, pz, wx, wy, wz, walls[8] - r, a)
        if tau < best:
            best, wall = tau, CURVED_WALL
    return best, wall


@njit(cache=True, inline="always")
def walls_beyond(x, y, z, reach, lengths, walls):
    """Whether every wall lies farther than ``reach`` from the point (x, y, z): a sphere whose reference centre is that
    point, that stays within skin/2 of it and whose radius stays below r_max, cannot touch a wall while reach >
    skin/2 + r_max. The prediction then skips :func:`wall_event`, whose call at every prediction took 6.6e8 of the
    1.45e10 instructions of a tube's LS run, for spheres far from the wall too (docs/containers.md §8)."""
    for k in range(3):
        if walls[k] != 0.0:
            c = x if k == 0 else (y if k == 1 else z)
            if not ((c > reach) & (lengths[k] - c > reach)):
                return False
    if walls[3] != 0.0:
        room = walls[8] - reach
        px = x - walls[5]
        py = y - walls[6]
        pz = z - walls[7]
        if walls[3] == 1.0:  # a cylinder: only the offset across its axis counts
            axis = walls[4]
            px = 0.0 if axis == 0.0 else px
            py = 0.0 if axis == 1.0 else py
            pz = 0.0 if axis == 2.0 else pz
        return (room > 0.0) & (px * px + py * py + pz * pz < room * room)
    return True


@njit(cache=True, inline="always")
def wall_normal(st, i, wall, lengths, walls, n):
    """The outward unit normal of ``wall`` at particle i's contact with it, into ``n`` (3,)."""
    n[0] = 0.0
    n[1] = 0.0
    n[2] = 0.0
    if wall < CURVED_WALL:
        n[wall // 2] = -1.0 if wall % 2 == 0 else 1.0
        return
    for k in range(3):
        n[k] = st[i, k] - walls[5 + k]
    if walls[3] == 1.0:
        n[int(walls[4])] = 0.0
    norm = np.sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2])
    for k in range(3):
        n[k] /= norm


@njit(cache=True)
def min_wall_ratio(st, lengths, walls, rho):
    """min over spheres of (distance of the centre to its nearest wall) / radius (synchronised state; inf without
    walls): < 1 means a sphere penetrates a wall."""
    best = _INF
    for i in range(st.shape[0]):
        r = 0.5 * rho * st[i, 7]
        d = _INF
        for k in range(3):
            if walls[k] != 0.0:
                d = min(d, st[i, k], lengths[k] - st[i, k])
        if walls[3] != 0.0:
            p2 = 0.0
            for k in range(3):
                if not (walls[3] == 1.0 and k == int(walls[4])):
                    p2 += (st[i, k] - walls[5 + k]) ** 2
            d = min(d, walls[8] - np.sqrt(p2))
        best = min(best, d / r)
    return best


@njit(cache=True)
def sync_all(st, t):
    """Advance every particle to time t (positions only)."""
    n = st.shape[0]
    for i in range(n):
        dt = t - st[i, 6]
        st[i, 0] += st[i, 3] * dt
        st[i, 1] += st[i, 4] * dt
        st[i, 2] += st[i, 5] * dt
        st[i, 6] = t


@njit(cache=True, inline="always")
def _sync(st, i, t):
    dt = t - st[i, 6]
    st[i, 0] += st[i, 3] * dt
    st[i, 1] += st[i, 4] * dt
    st[i, 2] += st[i, 5] * dt
    st[i, 6] = t


# --- Verlet lists over the linked cells of :mod:`spherejam.core.neighbours` ---------------------------------------


@njit(cache=True, inline="always")
def _wrap(x, box):
    if x < 0.0:
        x += box
        if x >= box:  # -tiny + box rounds to box
            x = 0.0
    elif x >= box:
        x -= box
    return x


@njit(cache=True, inline="always")
def _axis_cells(c, m, periodic):
    """The cell coordinates of the 3x3x3 stencil along one axis, in the order of
    :func:`~spherejam.core.neighbours.stencil_cell`: ``(count, c0, c1, c2)``, the neighbours c - 1, c, c + 1
    (wrapped; -1 beyond a wall), or the m < 3 cells of a short axis once."""
    if m < 3:
        return m, 0, 1, 2
    lo = c - 1
    hi = c + 1
    if lo < 0:
        lo = m - 1 if periodic else -1
    if hi >= m:
        hi = 0 if periodic else -1
    return 3, lo, c, hi


@njit(cache=True, inline="always")
def _stencil_of(coords, periodic, ms, cells):
    """The cells of the 3x3x3 stencil around the cell at ``coords`` into ``cells`` (those beyond a wall left out),
    in the order of :func:`~spherejam.core.neighbours.stencil_cell` (first axis fastest); returns their number.

    Three cell coordinates per axis first, then their 27 combinations: a skin event's stencil costs a tenth of 27
    calls of the general d-dimensional stencil. Gathered once per cell, not per sphere, by a full rebuild, which
    visits the spheres in cell order.
    """
    mx = ms[0]
    my = ms[1]
    nx, x0, x1, x2 = _axis_cells(coords[0], mx, periodic[0])
    ny, y0, y1, y2 = _axis_cells(coords[1], my, periodic[1])
    nz, z0, z1, z2 = _axis_cells(coords[2], ms[2], periodic[2])
    count = 0
    for c in range(nz):
        zc = z0 if c == 0 else (z1 if c == 1 else z2)
        if zc < 0:
            continue
        for b in range(ny):
            yb = y0 if b == 0 else (y1 if b == 1 else y2)
            if yb < 0:
                continue
            row = mx * (yb + my * zc)
            for a in range(nx):
                xa = x0 if a == 0 else (x1 if a == 1 else x2)
                if xa >= 0:
                    cells[count] = xa + row
                    count += 1
    return count


@njit(cache=True, inline="always")
def _gather_cell_block(st, refs, i, x, y, z, lengths, half, rho_list, skin, head, nxt, cells, ncells, out, row):
    """Write every j != i with |X_j - (x, y, z)| < rho_list D_ij + skin in the cells ``cells[:ncells]`` (the
    stencil of the point's cell) to ``out[row, :]``; returns the count (entries beyond the row's capacity are
    counted, not written)."""
    lx, ly, lz, hx, hy, hz, cube = _geometry(lengths, half)
    if cube:  # one length and one half-length, in two registers instead of six (as in _predict)
        return _gather_cells(st, refs, i, x, y, z, lx, lx, lx, hx, hx, hx, rho_list, skin, head, nxt, cells, ncells,
                             out, row)
    return _gather_cells(st, refs, i, x, y, z, lx, ly, lz, hx, hy, hz, rho_list, skin, head, nxt, cells, ncells, out,
                         row)


@njit(cache=True, inline="always")
def _gather_cells(st, refs, i, x, y, z, lx, ly, lz, hx, hy, hz, rho_list, skin, head, nxt, cells, ncells, out, row):
    """The loop of :func:`_gather_cell_block`, the frame's lengths as scalars."""
    cap = out.shape[1]
    di = st[i, 7]
    count = 0
    for o in range(ncells):
        j = head[cells[o]]
        while j >= 0:
            if j != i:
                dx = fold(refs[j, 0] - x, lx, hx)
                dy = fold(refs[j, 1] - y, ly, hy)
                dz = fold(refs[j, 2] - z, lz, hz)
                cut = rho_list * 0.5 * (di + st[j, 7]) + skin
                if dx * dx + dy * dy + dz * dz < cut * cut:
                    if count < cap:
                        out[row, count] = j
                    count += 1
            j = nxt[j]
    return count


@njit(cache=True, inline="always")
def _gather_levels(st, refs, i, x, y, z, lengths, half, periodic, rho_list, skin, head, nxt, lvl_ms, lvl_off,
                   lvl_dmax, coords, shift, out, row):
    """:func:`_gather_cell_block` over every level of a levelled grid: in level l, the stencil whose half-width
    covers i's reach rho_list (D_i + D_max,l)/2 + skin. Returns the count (entries beyond the row's capacity are
    counted, not written)."""
    lx, ly, lz = lengths[0], lengths[1], lengths[2]
    hx, hy, hz = half[0], half[1], half[2]
    cap = out.shape[1]
    di = st[i, 7]
    count = 0
    for lv in range(lvl_ms.shape[0]):
        ms = lvl_ms[lv]
        reach = rho_list * 0.5 * (di + lvl_dmax[lv]) + skin
        w = 1
        for k in range(3):
            w = max(w, int(np.ceil(reach / (lengths[k] / ms[k]))))
        coords[0] = axis_cell(x, lx, ms[0])
        coords[1] = axis_cell(y, ly, ms[1])
        coords[2] = axis_cell(z, lz, ms[2])
        base = lvl_off[lv]
        for o in range(stencil_size(w, ms)):
            c = stencil_cell(coords, o, w, ms, lengths, periodic, shift)
            if c < 0:
                continue
            j = head[base + c]
            while j >= 0:
                if j != i:
                    dx = fold(refs[j, 0] - x, lx, hx)
                    dy = fold(refs[j, 1] - y, ly, hy)
                    dz = fold(refs[j, 2] - z, lz, hz)
                    cut = rho_list * 0.5 * (di + st[j, 7]) + skin
                    if dx * dx + dy * dy + dz * dz < cut * cut:
                        if count < cap:
                            out[row, count] = j
                        count += 1
                j = nxt[j]
    return count


@njit(cache=True)
def build_lists(st, lengths, half, periodic, rho_list, skin, lvl_ms, lvl_off, lvl_dmax, level, nbr):
    """All neighbour lists from scratch into ``nbr`` (N x cap); every particle must be synchronised.

    Wraps positions into [0, L_k) (a no-op along walled axes, where they stay inside), sets the reference centres
    to them and links the cells. Returns ``(refs, nnb, head, nxt, prv, cellof, max_count)``; if
    ``max_count > cap`` the lists are incomplete and the caller must call again with a larger ``nbr``.
    """
    n = st.shape[0]
    refs = np.empty((n, 3))
    for i in range(n):
        for k in range(3):
            st[i, k] = _wrap(st[i, k], lengths[k])
            refs[i, k] = st[i, k]
    head, nxt, prv, cellof = link_levels(refs, level, lengths, lvl_ms, lvl_off)
    nnb = np.zeros(n, dtype=np.int32)
    cap = nbr.shape[1]
    max_count = 0
    coords = np.empty(3, dtype=np.int64)
    shift = np.empty(3)
    if lvl_ms.shape[0] > 1:
        for i in range(n):
            count = _gather_levels(st, refs, i, refs[i, 0], refs[i, 1], refs[i, 2], lengths, half, periodic,
                                   rho_list, skin, head, nxt, lvl_ms, lvl_off, lvl_dmax, coords, shift, nbr, i)
            nnb[i] = min(count, cap)
            max_count = max(max_count, count)
        return refs, nnb, head, nxt, prv, cellof, max_count
    # one level: the 3x3x3 stencil of each cell, gathered once per cell (the spheres come in cell order)
    ms = lvl_ms[0]
    cells = np.empty(27, dtype=np.int64)
    ncells = 0
    last = -1
    for i in range(n):
        if cellof[i] != last:
            last = cellof[i]
            unravel_cell(last, ms, coords)
            ncells = _stencil_of(coords, periodic, ms, cells)
        count = _gather_cell_block(st, refs, i, refs[i, 0], refs[i, 1], refs[i, 2], lengths, half, rho_list, skin,
                                   head, nxt, cells, ncells, nbr, i)
        nnb[i] = min(count, cap)
        max_count = max(max_count, count)
    return refs, nnb, head, nxt, prv, cellof, max_count


@njit(cache=True, inline="always")
def _remove_from_list(nbr, nnb, j, i):
    cnt = nnb[j]
    for k in range(cnt):
        if nbr[j, k] == i:
            nbr[j, k] = nbr[j, cnt - 1]
            nnb[j] = cnt - 1
            return True
    return False


@njit(cache=True)
def _rebuild_one(st, refs, i, lengths, half, periodic, lvl_ms, lvl_off, lvl_dmax, level, rho_list, skin, nbr, nnb,
                 head, nxt, prv, cellof, scratch, coords, shift, cells):
    """Local Verlet update of particle i (synchronised): new reference centre = its wrapped position.

    Returns False (and changes nothing) if a list would overflow.
    """
    cap = nbr.shape[1]
    x = _wrap(st[i, 0], lengths[0])
    y = _wrap(st[i, 1], lengths[1])
    z = _wrap(st[i, 2], lengths[2])
    lv = level[i]
    ms = lvl_ms[lv]
    if lvl_ms.shape[0] > 1:
        count = _gather_levels(st, refs, i, x, y, z, lengths, half, periodic, rho_list, skin, head, nxt, lvl_ms,
                               lvl_off, lvl_dmax, coords, shift, scratch, 0)
    else:
        coords[0] = axis_cell(x, lengths[0], ms[0])
        coords[1] = axis_cell(y, lengths[1], ms[1])
        coords[2] = axis_cell(z, lengths[2], ms[2])
        ncells = _stencil_of(coords, periodic, ms, cells)
        count = _gather_cell_block(st, refs, i, x, y, z, lengths, half, rho_list, skin, head, nxt, cells, ncells,
                                   scratch, 0)
    if count > cap or count > scratch.shape[1]:
        return False
    for k in range(count):
        if nnb[scratch[0, k]] >= cap:  # conservative: i may already be listed there
            return False
    # drop i from its old neighbours' lists
    for k in range(nnb[i]):
        _remove_from_list(nbr, nnb, nbr[i, k], i)
    # move i's reference centre and cell
    st[i, 0] = x
    st[i, 1] = y
    st[i, 2] = z
    refs[i, 0] = x
    refs[i, 1] = y
    refs[i, 2] = z
    move_to_cell(i, lvl_off[lv] + cell_of(refs[i], lengths, ms), head, nxt, prv, cellof)
    for k in range(count):
        j = scratch[0, k]
        nbr[i, k] = j
        nbr[j, nnb[j]] = i
        nnb[j] += 1
    nnb[i] = count
    return True


# --- event prediction ---------------------------------------------------------------------------------------------


@njit(cache=True, inline="always")
def _predict_images(i, exclude, exclude_image, t, xi, yi, zi, vxi, vyi, vzi, rho, best, best_type, best_j, st,
                    ev_time, nbr, nnb, lengths, half, periodic, gamma, skin, rho_list):
    """The neighbour loop of :func:`_predict` when pairs may meet through several images: each listed pair's images
    within reach (a collision before the next list event starts within rho_list D_ij + 2 skin, both spheres staying
    within skin/2 of their reference centres); ``exclude`` loses only its image ``exclude_image``."""
    di = st[i, 7]
    for kk in range(nnb[i]):
        j = nbr[i, kk]
        dtj = t - st[j, 6]
        rx = fold(st[j, 0] + st[j, 3] * dtj - xi, lengths[0], half[0])
        ry = fold(st[j, 1] + st[j, 4] * dtj - yi, lengths[1], half[1])
        rz = fold(st[j, 2] + st[j, 5] * dtj - zi, lengths[2], half[2])
        sig = 0.5 * (di + st[j, 7])
        tau, _ = image_collision(rx, ry, rz, st[j, 3] - vxi, st[j, 4] - vyi, st[j, 5] - vzi, sig, rho, gamma,
                                 lengths, periodic, rho_list * sig + 2.0 * skin, exclude_image if j == exclude else -1,
                                 t, min(best, ev_time[j]))
        tc = t + tau
        if tc < best and tc <= ev_time[j]:
            best = tc
            best_type = COLLISION
            best_j = j
    return best, best_type, best_j


@njit(cache=True, inline="always")
def _geometry(lengths, half):
    """``(L_x, L_y, L_z, h_x, h_y, h_z, cube)``: the frame's lengths and half-lengths as scalars, and whether it is
    the periodic cube (every length and half-length equal)."""
    lx, ly, lz = lengths[0], lengths[1], lengths[2]
    hx, hy, hz = half[0], half[1], half[2]
    return lx, ly, lz, hx, hy, hz, (lx == ly) and (ly == lz) and (hx == hy) and (hy == hz)


@njit(cache=True, inline="always")
def _frame_tuples(lengths, half, periodic, walls):
    """The frame's and the walls' arrays as tuples of scalars, for the event loop: each array handed to the inlined
    :func:`_predict` costs a reference increment and decrement (two calls) per prediction, which numba's refcount
    pruning leaves in its branches, and a tuple nothing (docs/containers.md §8: the periodic path's +4 %)."""
    return ((lengths[0], lengths[1], lengths[2]), (half[0], half[1], half[2]),
            (periodic[0], periodic[1], periodic[2]),
            (walls[0], walls[1], walls[2], walls[3], walls[4], walls[5], walls[6], walls[7], walls[8]))


@njit(cache=True, inline="always")
def _predict_pairs(i, exclude, t, xi, yi, zi, vxi, vyi, vzi, di, rho, gamma, best, best_type, best_j, st, ev_time,
                   nbr, nnb, lx, ly, lz, hx, hy, hz):
    """The neighbour loop of :func:`_predict` when every pair meets through its minimum image only: the earliest
    collision of particle i (at xi, moving at vi, at time t) that beats ``best`` and is available. Lists longer
    than :data:`LONG_LIST` go to :func:`_predict_long` (:func:`_predict` tests it once, outside the inlined copies)."""
    for kk in range(nnb[i]):
        j = nbr[i, kk]
        if j == exclude:
            continue
        dtj = t - st[j, 6]
        ux = st[j, 3] - vxi
        uy = st[j, 4] - vyi
        uz = st[j, 5] - vzi
        rx = fold(st[j, 0] + st[j, 3] * dtj - xi, lx, hx)
        ry = fold(st[j, 1] + st[j, 4] * dtj - yi, ly, hy)
        rz = fold(st[j, 2] + st[j, 5] * dtj - zi, lz, hz)
        sig = 0.5 * (di + st[j, 7])
        s2 = sig * sig
        b = rx * ux + ry * uy + rz * uz - s2 * rho * gamma
        a = ux * ux + uy * uy + uz * uz - s2 * gamma * gamma
        # skip pairs receding in the frame of the growing surfaces (b >= 0, a >= 0) and, for a >= 0 and b < 0,
        # pairs whose root (>= c / (-2 b)) cannot win; non-short-circuit & and | leave one well-predicted branch
        c = rx * rx + ry * ry + rz * rz - s2 * rho * rho
        lim = min(best, ev_time[j]) - t
        if (a >= 0.0) & ((b >= 0.0) | ((c > 0.0) & (c > -2.0 * b * lim))):
            continue
        tau = collision_delay(rx, ry, rz, ux, uy, uz, sig, rho, gamma)
        if tau < _INF:
            tc = t + tau
            if tc < best and tc <= ev_time[j]:
                best = tc
                best_type = COLLISION
                best_j = j
    return best, best_type, best_j


#: Lists longer than this are predicted in two passes (:func:`_predict_long`): the first shell of small spheres
#: around a large one (docs/algorithms.md §7.7).
LONG_LIST = 64
#: Neighbours per block of :func:`_predict_long` (its work rows live on the stack).
_BLOCK = 256


@intrinsic
def _stack_block(typingctx):
    """A pointer to 8 x :data:`_BLOCK` float64 on the stack of the calling function (an alloca at its entry: no heap
    allocation per call, and memory the compiler knows no array argument aliases, so the loop over it is
    vectorised without run-time overlap checks)."""
    def codegen(context, builder, signature, args):
        return cgutils.alloca_once(builder, ir.DoubleType(), size=8 * _BLOCK)

    return types.CPointer(types.float64)(), codegen


@njit(cache=True, inline="always")
def delay_bound(rx, ry, rz, ux, uy, uz, sig, rho, gamma):
    """A lower bound of :func:`collision_delay` (same arguments), in floating point as computed, without a branch,
    a square root or a test of the best time so far (a loop of these is vectorised).

    Receding pairs (b >= 0, a >= 0): inf, as collision_delay. Approaching with a >= 0 and c > 0: c / (-2 b), which
    the root c / (sqrt(disc) - b) is not below: disc = b^2 - a c <= fl(b^2), and sqrt(fl(b^2)) = |b| exactly for
    normal b^2 (hence |b| > 1e-150), so the computed denominator is at most -2 b and rounding is monotone. Any other
    pair (touching, or growing faster than it approaches): 0."""
    s2 = sig * sig
    b = rx * ux + ry * uy + rz * uz - s2 * rho * gamma
    a = ux * ux + uy * uy + uz * uz - s2 * gamma * gamma
    c = rx * rx + ry * ry + rz * rz - s2 * rho * rho
    bound = c / (-2.0 * b)  # inf or nan where b = 0: not kept there
    kept = bound if (a >= 0.0) & (c > 0.0) & (b < -1e-150) else 0.0
    return _INF if (b >= 0.0) & (a >= 0.0) else kept


@njit(cache=True, error_model="numpy")  # numpy: delay_bound divides by b = 0 in lanes it does not keep
def _predict_long(i, exclude, t, xi, yi, zi, vxi, vyi, vzi, di, rho, gamma, best, best_type, best_j, st, ev_time,
                  nbr, nnb, lx, ly, lz, hx, hy, hz, cols, base):
    """:func:`_predict_pairs` for a long list, with the same result bit for bit, in two passes per block of
    :data:`_BLOCK` neighbours. The first computes a lower bound of every collision delay (:func:`delay_bound`: no
    branch, vectorised); the second walks the block in list order with the running best and runs
    :func:`_predict_pairs`' own test only on the few neighbours whose bound beats it. A neighbour whose bound does not
    beat the running best cannot be accepted by the scalar loop (its time is not below the bound, and that loop
    accepts only times below the running best), so both take the same events.

    The neighbours' state is read from ``cols[:, base + k]`` for the list's k-th entry when ``base`` >= 0 (i's
    :class:`LongCopies` block, laid out by field: the first pass reads eight contiguous streams,
    docs/algorithms.md §7.8), else gathered from ``st[nbr[i, k]]`` into work rows on the stack first; the copy holds
    the same numbers, so the same events follow."""
    work = carray(_stack_block(), (8, _BLOCK))
    low = work[7]
    m = nnb[i]
    for k0 in range(0, m, _BLOCK):
        k1 = min(m, k0 + _BLOCK)
        if base >= 0:
            # views from the block's first entry: an index from range() is known to be >= 0, so numba's test for a
            # negative index, which stops the loop from vectorising (3x the time), is not needed
            o = base + k0
            x0, x1, x2, x3, x4, x5, x6, x7 = (cols[0, o:], cols[1, o:], cols[2, o:], cols[3, o:], cols[4, o:],
                                              cols[5, o:], cols[6, o:], cols[7, o:])
            for q in range(k1 - k0):
                dtj = t - x6[q]
                low[q] = delay_bound(fold(x0[q] + x3[q] * dtj - xi, lx, hx), fold(x1[q] + x4[q] * dtj - yi, ly, hy),
                                     fold(x2[q] + x5[q] * dtj - zi, lz, hz), x3[q] - vxi, x4[q] - vyi, x5[q] - vzi,
                                     0.5 * (di + x7[q]), rho, gamma)
        else:
            for kk in range(k0, k1):  # gather: the rows are scattered, the arithmetic below runs on contiguous ones
                j = nbr[i, kk]
                dtj = t - st[j, 6]
                q = kk - k0
                work[0, q] = st[j, 0] + st[j, 3] * dtj - xi
                work[1, q] = st[j, 1] + st[j, 4] * dtj - yi
                work[2, q] = st[j, 2] + st[j, 5] * dtj - zi
                work[3, q] = st[j, 3] - vxi
                work[4, q] = st[j, 4] - vyi
                work[5, q] = st[j, 5] - vzi
                work[6, q] = 0.5 * (di + st[j, 7])
            for q in range(k1 - k0):
                low[q] = delay_bound(fold(work[0, q], lx, hx), fold(work[1, q], ly, hy), fold(work[2, q], lz, hz),
                                     work[3, q], work[4, q], work[5, q], work[6, q], rho, gamma)
        for kk in range(k0, k1):
            # rare: the scalar loop's body, as it is in _predict_pairs. Written twice on purpose: one inlined helper
            # for both, taking j's row as numbers, cost +2.7 % instructions in a monodisperse LS run (docs §7.7)
            if t + low[kk - k0] < best:
                j = nbr[i, kk]
                if j == exclude:
                    continue
                if base >= 0:
                    r = base + kk
                    xj, yj, zj, vxj, vyj, vzj, tj, dj = (cols[0, r], cols[1, r], cols[2, r], cols[3, r], cols[4, r],
                                                         cols[5, r], cols[6, r], cols[7, r])
                else:
                    xj, yj, zj, vxj, vyj, vzj, tj, dj = (st[j, 0], st[j, 1], st[j, 2], st[j, 3], st[j, 4], st[j, 5],
                                                         st[j, 6], st[j, 7])
                dtj = t - tj
                ux = vxj - vxi
                uy = vyj - vyi
                uz = vzj - vzi
                rx = fold(xj + vxj * dtj - xi, lx, hx)
                ry = fold(yj + vyj * dtj - yi, ly, hy)
                rz = fold(zj + vzj * dtj - zi, lz, hz)
                sig = 0.5 * (di + dj)
                s2 = sig * sig
                b = rx * ux + ry * uy + rz * uz - s2 * rho * gamma
                a = ux * ux + uy * uy + uz * uz - s2 * gamma * gamma
                c = rx * rx + ry * ry + rz * rz - s2 * rho * rho
                lim = min(best, ev_time[j]) - t
                if (a >= 0.0) & ((b >= 0.0) | ((c > 0.0) & (c > -2.0 * b * lim))):
                    continue
                tau = collision_delay(rx, ry, rz, ux, uy, uz, sig, rho, gamma)
                if tau < _INF:
                    tc = t + tau
                    if tc < best and tc <= ev_time[j]:
                        best = tc
                        best_type = COLLISION
                        best_j = j
    return best, best_type, best_j


# --- contiguous copies of the long lists' neighbour rows (docs/algorithms.md §7.8) ---------------------------------
# A list longer than LONG_LIST owns a slot s: cols[:, s * cap + k] is a copy of st[nbr[L, k]], in list order, kept
# equal to it bit for bit, laid out by field (the bound pass of _predict_long reads eight contiguous streams). Each
# copied row is an entry e = s * cap + k; the entries holding sphere j form a doubly linked list (rhead[j],
# rnext[e], rprev[e]; rown[e] = j), the reverse index through which a change of j's row reaches
# every copy of it (a small sphere is listed by one to three large ones). The structure lives for one run_events
# call: the caller's work between calls (thermostat, full rebuilds) changes rows and lists wholesale.


class LongCopies(NamedTuple):
    """The copies of one :func:`run_events` call; see the comment above. ``slot``: (N,) int32 slot of each sphere's
    list or -1; ``owner``, ``slen``: (S,) the sphere owning each slot (-1: free) and the entries it holds; ``cols``:
    (8, S cap) float64, the copied rows by field; ``rown``, ``rnext``, ``rprev``: (S cap,) int32; ``rhead``: (N,)
    int32."""

    slot: np.ndarray
    owner: np.ndarray
    slen: np.ndarray
    cols: np.ndarray
    rown: np.ndarray
    rnext: np.ndarray
    rprev: np.ndarray
    rhead: np.ndarray


@njit(cache=True, inline="always")
def _link(e, j, rhead, rnext, rprev, rown):
    h = rhead[j]
    rnext[e] = h
    rprev[e] = -1
    if h >= 0:
        rprev[h] = e
    rhead[j] = e
    rown[e] = j


@njit(cache=True, inline="always")
def _unlink(e, rhead, rnext, rprev, rown):
    p = rprev[e]
    q = rnext[e]
    if p >= 0:
        rnext[p] = q
    else:
        rhead[rown[e]] = q
    if q >= 0:
        rprev[q] = p


@njit(cache=True, inline="always")
def _refresh_copies(st, j, cols, rnext, rhead):
    """Rewrite every copy of j's row (after a collision or a wall changed it). Nothing to do for a sphere no long
    list holds: one load of rhead[j] (monodisperse runs never get further)."""
    e = rhead[j]
    while e >= 0:
        for k in range(8):
            cols[k, e] = st[j, k]
        e = rnext[e]


@njit(cache=True)
def _fill_slot(s, L, st, nbr, nnb, lc):
    """Copy L's whole list into slot s (empty) and link its entries."""
    cap = nbr.shape[1]
    base = s * cap
    for k in range(nnb[L]):
        e = base + k
        j = nbr[L, k]
        for c in range(8):
            lc.cols[c, e] = st[j, c]
        _link(e, j, lc.rhead, lc.rnext, lc.rprev, lc.rown)
    lc.slen[s] = nnb[L]
    lc.owner[s] = L
    lc.slot[L] = s


@njit(cache=True)
def _take_slot(L, st, nbr, nnb, lc):
    """Give L's list a free slot, if one is left (else its predictions gather from st, with the same events)."""
    for s in range(lc.owner.shape[0]):
        if lc.owner[s] < 0:
            _fill_slot(s, L, st, nbr, nnb, lc)
            return


@njit(cache=True)
def long_copies(st, nbr, nnb, enabled):
    """The :class:`LongCopies` of the current lists: a slot for every list longer than :data:`LONG_LIST`, and half as
    many again spare for lists that grow past it during the call (``enabled`` false: no slots, every long list is
    gathered from st)."""
    n = st.shape[0]
    cap = nbr.shape[1]
    count = 0
    for i in range(n):
        if nnb[i] > LONG_LIST:
            count += 1
    slots = count + count // 2 + (8 if count > 0 else 0) if enabled else 0
    lc = LongCopies(np.full(n, -1, dtype=np.int32), np.full(slots, -1, dtype=np.int32),
                    np.zeros(slots, dtype=np.int32), np.empty((8, slots * cap)), np.empty(slots * cap, dtype=np.int32),
                    np.empty(slots * cap, dtype=np.int32), np.empty(slots * cap, dtype=np.int32),
                    np.full(n, -1, dtype=np.int32))
    if slots > 0:
        for i in range(n):
            if nnb[i] > LONG_LIST:
                _take_slot(i, st, nbr, nnb, lc)
    return lc


@njit(cache=True)
def _relist_copies(i, st, nbr, nnb, lc):
    """Mirror in the copies the local list update :func:`_rebuild_one` just made for particle i (its row and its
    list changed; it left its old neighbours' lists, each by :func:`_remove_from_list`'s swap with the last entry,
    and was appended to its new neighbours'). Runs on the copies' own bookkeeping (slen, the reverse index), which
    still describe the lists before the update."""
    cap = nbr.shape[1]
    cols, rown, rnext, rprev, rhead, slen = lc.cols, lc.rown, lc.rnext, lc.rprev, lc.rhead, lc.slen
    # i leaves every copied list it was in: the same swap with the last entry as in nbr
    e = rhead[i]
    while e >= 0:
        after = rnext[e]
        s = e // cap
        _unlink(e, rhead, rnext, rprev, rown)
        last = s * cap + slen[s] - 1
        if e != last:
            for c in range(8):
                cols[c, e] = cols[c, last]
            j = rown[last]
            _unlink(last, rhead, rnext, rprev, rown)
            _link(e, j, rhead, rnext, rprev, rown)
        slen[s] -= 1
        e = after
    # i's own list is new
    s = lc.slot[i]
    if s >= 0:
        for k in range(slen[s]):
            _unlink(s * cap + k, rhead, rnext, rprev, rown)
        _fill_slot(s, i, st, nbr, nnb, lc)
    elif nnb[i] > LONG_LIST:
        _take_slot(i, st, nbr, nnb, lc)
    # i joins its new neighbours' lists at their end
    for k in range(nnb[i]):
        L = nbr[i, k]
        s = lc.slot[L]
        if s >= 0:
            e = s * cap + slen[s]
            for c in range(8):
                cols[c, e] = st[i, c]
            _link(e, i, rhead, rnext, rprev, rown)
            slen[s] += 1
        elif nnb[L] > LONG_LIST:
            _take_slot(L, st, nbr, nnb, lc)


@njit(cache=True)
def copies_current(st, nbr, nnb, lc):
    """Whether every copy equals its row of st bit for bit and follows its list (for tests)."""
    cap = nbr.shape[1]
    for L in range(st.shape[0]):
        s = lc.slot[L]
        if s < 0:
            continue
        if lc.owner[s] != L or lc.slen[s] != nnb[L]:
            return False
        for k in range(nnb[L]):
            e = s * cap + k
            if lc.rown[e] != nbr[L, k]:
                return False
            for c in range(8):
                if lc.cols[c, e] != st[nbr[L, k], c]:
                    return False
    # the reverse index holds exactly the slots' entries
    entries = 0
    for j in range(st.shape[0]):
        e = lc.rhead[j]
        while e >= 0:
            if lc.rown[e] != j or e % cap >= lc.slen[e // cap]:
                return False
            entries += 1
            e = lc.rnext[e]
    total = 0
    for s in range(lc.owner.shape[0]):
        total += lc.slen[s] if lc.owner[s] >= 0 else 0
    return entries == total


@njit(cache=True, inline="always")
def _predict(i, exclude, exclude_image, t, st, refs, ev_time, ev_type, ev_partner, heap, hpos, hkey, nbr, nnb,
             geom, lengths, half, periodic, walls, has_walls, rho0, gamma, skin, rho_list, multi, update_heap, lslot,
             lcols):
    """Schedule particle i's next event at time t (its own current event is released first); the arrays and scalars
    are :class:`EventState`'s fields.

    ``geom`` is :func:`_geometry` of the frame: its lengths as scalars, read once per kernel call (an array read here
    would be re-read at every prediction: the compiler cannot tell that the event loop's stores leave it alone).
    ``exclude`` is the partner of a collision just processed. ``multi``: a pair may meet through several periodic
    images (a list cutoff >= L/2); every image within reach is predicted, and ``exclude`` loses only the image that
    collided (``exclude_image``, a code of :func:`image_collision`). Inlined into its callers: a call would pass
    some 100 words of array descriptors per prediction. Its callers unpack the state once, outside their loops: each
    field read from the tuple takes a reference to its array (an atomic increment and decrement), too slow for the
    event loop (docs/algorithms.md §7.3). ``lslot``, ``lcols``: :class:`LongCopies`' slot and copies (a list longer
    than :data:`LONG_LIST` with a slot is read from its copy).
    """
    n = st.shape[0]
    lx, ly, lz, hx, hy, hz, cube = geom
    # release: a partner that expected to collide with i falls back to a re-prediction at the same time
    if ev_type[i] == COLLISION:
        k = ev_partner[i]
        if ev_type[k] == COLLISION and ev_partner[k] == i:
            ev_type[k] = MOVE
            ev_partner[k] = -1
    dti = t - st[i, 6]
    xi = st[i, 0] + st[i, 3] * dti
    yi = st[i, 1] + st[i, 4] * dti
    zi = st[i, 2] + st[i, 5] * dti
    vxi = st[i, 3]
    vyi = st[i, 4]
    vzi = st[i, 5]
    di = st[i, 7]
    rho = rho0 + gamma * t
    best = skin_exit_delay(xi - refs[i, 0], yi - refs[i, 1], zi - refs[i, 2], vxi, vyi, vzi, 0.5 * skin) + t
    best_type = SKIN
    best_j = -1
    # the list length is tested once here, not in each inlined copy of _predict_pairs' loop; -2: a short list, -1: a
    # long one gathered from st, >= 0: a long one read from its contiguous copy (nothing to prefetch)
    long_base = -2
    if nnb[i] > LONG_LIST:
        long_base = lslot[i] * nbr.shape[1] if lslot[i] >= 0 else -1
    if long_base < 0:
        for kk in range(nnb[i]):
            _prefetch_row(st, nbr[i, kk])
    # before the pairs (an early wall event prunes them); not for a sphere whose walls are beyond its reach until
    # its skin event or the lists' horizon (radius <= rho_list D_i / 2): that wall event could never come first
    if has_walls and not walls_beyond(refs[i, 0], refs[i, 1], refs[i, 2],
                                      (0.5 * skin + 0.5 * rho_list * di) * (1.0 + _REACH_SLACK), lengths, walls):
        tw, wall = wall_event(xi, yi, zi, vxi, vyi, vzi, 0.5 * rho * di, 0.5 * gamma * di, lengths, walls)
        if t + tw < best:
            best = t + tw
            best_type = WALL
            best_j = wall
    if multi:  # outside the loop: the single-image loop stays as tight as it was
        best, best_type, best_j = _predict_images(i, exclude, exclude_image, t, xi, yi, zi, vxi, vyi, vzi, rho, best,
                                                  best_type, best_j, st, ev_time, nbr, nnb, lengths, half, periodic,
                                                  gamma, skin, rho_list)
    elif long_base >= -1:
        best, best_type, best_j = _predict_long(i, exclude, t, xi, yi, zi, vxi, vyi, vzi, di, rho, gamma, best,
                                                best_type, best_j, st, ev_time, nbr, nnb, lx, ly, lz, hx, hy, hz,
                                                lcols, long_base)
    elif cube:
        # the periodic cube: one length and one half-length, in two registers instead of six
        best, best_type, best_j = _predict_pairs(i, exclude, t, xi, yi, zi, vxi, vyi, vzi, di, rho, gamma, best,
                                                 best_type, best_j, st, ev_time, nbr, nnb, lx, lx, lx, hx, hx, hx)
    else:
        best, best_type, best_j = _predict_pairs(i, exclude, t, xi, yi, zi, vxi, vyi, vzi, di, rho, gamma, best,
                                                 best_type, best_j, st, ev_time, nbr, nnb, lx, ly, lz, hx, hy, hz)
    ev_time[i] = best
    ev_type[i] = best_type
    ev_partner[i] = best_j
    if update_heap:
        heap_update(heap, hpos, hkey, i, best, n)
    if best_type == COLLISION:
        j = best_j
        if ev_type[j] == COLLISION:
            k = ev_partner[j]
            if k != i and ev_type[k] == COLLISION and ev_partner[k] == j:
                ev_type[k] = MOVE
                ev_partner[k] = -1
        ev_time[j] = best
        ev_type[j] = COLLISION
        ev_partner[j] = i
        if update_heap:
            _sift_up(heap, hpos, hkey, hpos[j], j, best)


@njit(cache=True)
def init_events(s, t):
    """Predict every particle's event in state ``s`` from scratch (all synchronised at t) and build the heap."""
    st, refs, nbr, nnb = s.st, s.refs, s.nbr, s.nnb
    ev_time, ev_type, ev_partner, heap, hpos, hkey = s.ev_time, s.ev_type, s.ev_partner, s.heap, s.hpos, s.hkey
    lengths, half, periodic, walls, has_walls = s.lengths, s.half, s.periodic, s.walls, s.has_walls
    lengths, half, periodic, walls = _frame_tuples(lengths, half, periodic, walls)  # see _frame_tuples
    rho0, gamma, skin, rho_list, multi = s.rho0, s.gamma, s.skin, s.rho_list, s.multi
    geom = _geometry(lengths, half)
    n = st.shape[0]
    for i in range(n):
        ev_time[i] = t
        ev_type[i] = MOVE
        ev_partner[i] = -1
    lslot = np.full(n, -1, dtype=np.int32)  # no copies: one prediction per sphere, a copy would cost what it saves
    lcols = np.empty((8, 0))
    for i in range(n):
        _predict(i, -1, -1, t, st, refs, ev_time, ev_type, ev_partner, heap, hpos, hkey,
                 nbr, nnb, geom, lengths, half, periodic, walls, has_walls, rho0, gamma, skin, rho_list, multi, False,
                 lslot, lcols)
    heap_build(heap, hpos, hkey, ev_time, n)


@njit(cache=True)
def run_events(s, t, target, count_collisions, t_horizon, counters, acc, copies=True):
    """Process the events of state ``s`` from time t until ``target`` events (or collisions) are counted in
    ``counters``.

    ``acc[A_VIRIAL]`` accumulates the collision virial sum_c |r_ij| (v_i - v_j).n_ij (pre-collision, growth
    excluded) and, for a wall collision, r_i times the impulse 2 v_n the wall gives (v_n the centre's speed towards
    it); ``acc[A_WALL_IMPULSE]`` the walls' impulses alone. Returns ``(status, t)``. On ``WINDOW_DONE`` and
    ``HORIZON`` every particle is synchronised to the returned t. ``copies``: keep contiguous copies of the long
    lists' rows (:func:`long_copies`; false only to compare against, in tests: the same events either way).
    """
    # every field unpacked once, outside the loop (see _predict)
    st, refs, nbr, nnb, head, nxt, prv, cellof = s.st, s.refs, s.nbr, s.nnb, s.head, s.nxt, s.prv, s.cellof
    ev_time, ev_type, ev_partner, heap, hpos, hkey = s.ev_time, s.ev_type, s.ev_partner, s.heap, s.hpos, s.hkey
    scratch, rho0, gamma, rho_list, skin, multi = s.scratch, s.rho0, s.gamma, s.rho_list, s.skin, s.multi
    lvl_ms, lvl_off, lvl_dmax, level = s.lvl_ms, s.lvl_off, s.lvl_dmax, s.level
    lengths, half, periodic, walls, has_walls = s.lengths, s.half, s.periodic, s.walls, s.has_walls
    lengths, half, periodic, walls = _frame_tuples(lengths, half, periodic, walls)  # see _frame_tuples
    geom = _geometry(lengths, half)
    lx, ly, lz, hx, hy, hz, _ = geom
    coords = np.empty(3, dtype=np.int64)  # cell-stencil work space of the local list updates
    shift = np.empty(3)
    cells = np.empty(27, dtype=np.int64)
    normal = np.empty(3)
    lc = long_copies(st, nbr, nnb, copies)
    lslot, lcols, lnext, lhead = lc.slot, lc.cols, lc.rnext, lc.rhead
    while True:
        i = heap[0]
        te = hkey[0]
        if te > t_horizon:
            sync_all(st, t_horizon)
            return HORIZON, t_horizon
        if not te >= t:  # also catches NaN
            return INCONSISTENT, t
        kind = ev_type[i]
        if kind == SKIN:
            _sync(st, i, te)
            if not _rebuild_one(st, refs, i, lengths, half, periodic, lvl_ms, lvl_off, lvl_dmax, level, rho_list, skin,
                                nbr, nnb, head, nxt, prv, cellof, scratch, coords, shift, cells):
                return OVERFLOW, t
            if lc.owner.shape[0] > 0:
                _relist_copies(i, st, nbr, nnb, lc)
            t = te
            _predict(i, -1, -1, t, st, refs, ev_time, ev_type, ev_partner, heap, hpos, hkey,
                     nbr, nnb, geom, lengths, half, periodic, walls, has_walls,
                     rho0, gamma, skin, rho_list, multi, True, lslot, lcols)
            counters[C_SKIN] += 1
        elif kind == COLLISION:
            t = te
            j = ev_partner[i]
            if nnb[j] <= LONG_LIST or lslot[j] < 0:  # j's neighbours load while i's prediction runs
                for kk in range(nnb[j]):
                    _prefetch_row(st, nbr[j, kk])
            _sync(st, i, t)
            _sync(st, j, t)
            rx = fold(st[j, 0] - st[i, 0], lx, hx)
            ry = fold(st[j, 1] - st[i, 1], ly, hy)
            rz = fold(st[j, 2] - st[i, 2], lz, hz)
            image = MINIMUM_IMAGE
            if multi:
                # the image that collides now (delay ~0); near jamming several images touch to round-off, so the
                # minimum image may be another one
                sig = 0.5 * (st[i, 7] + st[j, 7])
                _, image = image_collision(rx, ry, rz, st[j, 3] - st[i, 3], st[j, 4] - st[i, 4], st[j, 5] - st[i, 5],
                                           sig, rho0 + gamma * t, gamma, lengths, periodic,
                                           2.0 * sig * (rho0 + gamma * t), -1, 0.0, _INF)
                rx += (image % 3 - 1) * lx
                ry += (image // 3 % 3 - 1) * ly
                rz += (image // 9 - 1) * lz
            r = np.sqrt(rx * rx + ry * ry + rz * rz)
            nx = rx / r
            ny = ry / r
            nz = rz / r
            g = gamma * 0.5 * (st[i, 7] + st[j, 7])
            vin = st[i, 3] * nx + st[i, 4] * ny + st[i, 5] * nz
            vjn = st[j, 3] * nx + st[j, 4] * ny + st[j, 5] * nz
            w = vjn - vin  # rate of change of |r|; the contact distance grows at g
            if w < g:
                # elastic reflection in the frame of the growing surfaces: w' - g = -(w - g)
                dv = vjn - vin - g
                st[i, 3] += dv * nx
                st[i, 4] += dv * ny
                st[i, 5] += dv * nz
                st[j, 3] -= dv * nx
                st[j, 4] -= dv * ny
                st[j, 5] -= dv * nz
                w = (vin - vjn) * r
                acc[A_VIRIAL] += w
                if has_walls:  # the normal pressure at a wall (docs/containers.md §3); a bulk box needs the mean only
                    acc[A_AXES] += w * nx * nx
                    acc[A_AXES + 1] += w * ny * ny
                    acc[A_AXES + 2] += w * nz * nz
                counters[C_COLLISIONS] += 1
            else:  # round-off made a predicted contact separate already: nothing to reflect
                counters[C_NULL] += 1
            _refresh_copies(st, i, lcols, lnext, lhead)  # both were synchronised and maybe reflected
            _refresh_copies(st, j, lcols, lnext, lhead)
            _predict(i, j, image, t, st, refs, ev_time, ev_type, ev_partner, heap, hpos, hkey,
                     nbr, nnb, geom, lengths, half, periodic, walls, has_walls,
                     rho0, gamma, skin, rho_list, multi, True, lslot, lcols)
            _predict(j, i, 26 - image, t, st, refs, ev_time, ev_type, ev_partner, heap, hpos, hkey,
                     nbr, nnb, geom, lengths, half, periodic, walls, has_walls,
                     rho0, gamma, skin, rho_list, multi, True, lslot, lcols)
        elif kind == WALL:
            t = te
            _sync(st, i, t)
            wall_normal(st, i, ev_partner[i], lengths, walls, normal)
            vn = st[i, 3] * normal[0] + st[i, 4] * normal[1] + st[i, 5] * normal[2]  # the centre, towards the wall
            u = vn + 0.5 * gamma * st[i, 7]  # the surface, towards the wall
            if u > 0.0:
                # elastic reflection in the frame of the growing surface: u' = -u
                for k in range(3):
                    st[i, 3 + k] -= 2.0 * u * normal[k]
                w = 2.0 * vn * 0.5 * (rho0 + gamma * t) * st[i, 7]
                acc[A_VIRIAL] += w
                for k in range(3):
                    acc[A_AXES + k] += w * normal[k] * normal[k]
                acc[A_WALL_IMPULSE] += 2.0 * vn
                counters[C_WALL] += 1
            else:
                counters[C_NULL] += 1
            _refresh_copies(st, i, lcols, lnext, lhead)
            _predict(i, -1, -1, t, st, refs, ev_time, ev_type, ev_partner, heap, hpos, hkey,
                     nbr, nnb, geom, lengths, half, periodic, walls, has_walls,
                     rho0, gamma, skin, rho_list, multi, True, lslot, lcols)
        else:
            t = te
            _predict(i, -1, -1, t, st, refs, ev_time, ev_type, ev_partner, heap, hpos, hkey,
                     nbr, nnb, geom, lengths, half, periodic, walls, has_walls,
                     rho0, gamma, skin, rho_list, multi, True, lslot, lcols)
            counters[C_MOVES] += 1
        counters[C_EVENTS] += 1
        _prefetch_row(nbr, heap[0])  # the next event's neighbour list
        done = counters[C_COLLISIONS] if count_collisions else counters[C_EVENTS]
        if done >= target:
            sync_all(st, t)
            return WINDOW_DONE, t


@njit(cache=True)
def min_listed_ratio(st, nbr, nnb, lengths, half, rho):
    """min over listed pairs of |r_ij| / (rho D_ij) (synchronised state): < 1 means an overlap."""
    n = st.shape[0]
    best = _INF
    for i in range(n):
        for k in range(nnb[i]):
            j = nbr[i, k]
            if j <= i:
                continue
            rx = fold(st[j, 0] - st[i, 0], lengths[0], half[0])
            ry = fold(st[j, 1] - st[i, 1], lengths[1], half[1])
            rz = fold(st[j, 2] - st[i, 2], lengths[2], half[2])
            h = np.sqrt(rx * rx + ry * ry + rz * rz) / (rho * 0.5 * (st[i, 7] + st[j, 7]))
            best = min(best, h)
    return best
