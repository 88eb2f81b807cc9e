"""The two-pass prediction of long neighbour lists (docs/algorithms.md §7.7) takes exactly the scalar loop's events:
its branch-free bound never exceeds collision_delay, and _predict_long equals _predict_pairs run over the same list,
including exclusion, pruning, availability and ties, whether it gathers the rows from st or reads a contiguous copy.
The copies (§7.8) follow every change of a row and of a list, and a run with them takes the events of a run without."""

import numpy as np
import pytest

from spherejam.core.seeding import poisson_packing
from spherejam.engines.event_driven import LSEngine
from spherejam.engines.kernels import event_driven as ed
from spherejam.engines.lubachevsky_stillinger import maxwell_velocities, run_ls


def _bits(x):
    return np.asarray(x, dtype=np.float64).view(np.int64)


def _pair_inputs(rng, k):
    """Pair geometries of every kind collision_delay tells apart: receding, approaching, touching and overlapping
    (c <= 0, both signs of the approach), grazing (disc ~ 0), shrinking (gamma = 0) and fast growth (a < 0)."""
    sig = rng.uniform(0.5, 5.5, k)
    rho = rng.uniform(0.5, 1.0, k)
    gamma = np.where(rng.random(k) < 0.2, 0.0, 10.0 ** rng.uniform(-4, 1, k))
    n = rng.normal(size=(k, 3))
    n /= np.linalg.norm(n, axis=1)[:, None]
    gap = np.where(rng.random(k) < 0.2, rng.uniform(-1e-3, 0.0, k), 10.0 ** rng.uniform(-12, 0, k))
    r = n * (sig * rho * (1.0 + gap))[:, None]
    u = rng.normal(size=(k, 3)) * 10.0 ** rng.uniform(-3, 1, k)[:, None]
    # grazing: velocity almost tangent, so disc is round-off small
    graze = rng.random(k) < 0.15
    tang = np.cross(n, rng.normal(size=(k, 3)))
    u[graze] = tang[graze] + 1e-9 * n[graze]
    return r, u, sig, rho, gamma


def test_delay_bound_is_a_lower_bound_of_collision_delay():
    rng = np.random.default_rng(1)
    r, u, sig, rho, gamma = _pair_inputs(rng, 20000)
    exact = np.array([ed.collision_delay(*r[q], *u[q], sig[q], rho[q], gamma[q]) for q in range(len(sig))])
    low = np.array([ed.delay_bound(*r[q], *u[q], sig[q], rho[q], gamma[q]) for q in range(len(sig))])
    t = 1.0
    assert 0.3 < np.isfinite(exact).mean() < 0.9 and np.sum(exact == 0.0) > 100  # every branch is exercised
    assert np.all(low <= exact) and np.all(t + low <= t + exact)  # as compared in _predict_long
    assert np.isinf(exact[np.isinf(low)]).all() and np.isinf(low).sum() > 1000  # inf only where the delay is
    # and it is tight where the pair approaches steadily: most bounds are within a factor 2 of the delay
    steady = np.isfinite(exact) & (low > 0)
    assert steady.sum() > 1000 and np.median(low[steady] / exact[steady]) > 0.5


def _shell(rng, m, box, centre, overlap):
    """A large sphere (D = 10) at ``centre`` and m small ones (D = 1) in its first shell at t = 1 (some overlapping it
    if ``overlap``), some across the periodic boundary; rows (x, y, z, vx, vy, vz, t_i, D_i)."""
    st = np.zeros((m + 1, 8))
    st[0, :3] = centre
    st[0, 3:6] = rng.normal(size=3)
    st[0, 6] = 0.9
    st[0, 7] = 10.0
    n = rng.normal(size=(m, 3))
    n /= np.linalg.norm(n, axis=1)[:, None]
    dist = 5.5 * rng.uniform(0.995 if overlap else 1.0 + 1e-9, 1.2, m)
    st[1:, :3] = centre + n * dist[:, None]
    st[1:, 3:6] = rng.normal(size=(m, 3))
    st[1:, 6] = rng.uniform(0.5, 1.0, m)
    st[1:, 7] = 1.0
    st[:, :3] = (st[:, :3] - st[:, 3:6] * (1.0 - st[:, 6:7])) % box  # those are the positions at t = 1
    return st


@pytest.mark.parametrize("seed", range(6))
def test_predict_long_is_the_scalar_loop(seed):
    rng = np.random.default_rng(seed)
    box = 40.0
    m = int(rng.integers(ed.LONG_LIST + 1, 3 * ed._BLOCK))  # more than one block
    st = _shell(rng, m, box, np.array([1.0, 39.5, 20.0]), overlap=seed % 2 == 1)
    t, rho, gamma = 1.0, 1.0, 10.0 ** rng.uniform(-3, 0)
    order = rng.permutation(np.arange(1, m + 1)).astype(np.int32)
    nbr = np.zeros((1, m), dtype=np.int32)
    nbr[0] = order
    nnb = np.array([m], dtype=np.int32)
    dt0 = t - st[0, 6]
    xi, yi, zi = st[0, :3] + st[0, 3:6] * dt0
    vxi, vyi, vzi = st[0, 3:6]
    geom = (box, box, box, box / 2, box / 2, box / 2)
    accepted = 0
    for trial in range(40):
        # partners' own events: some before, some after i's candidates (the availability rule), some ties
        taus = np.array([ed.collision_delay(*(st[j, :3] + st[j, 3:6] * (t - st[j, 6]) - (xi, yi, zi)),
                                            *(st[j, 3:6] - st[0, 3:6]), 0.5 * (st[0, 7] + st[j, 7]), rho, gamma)
                         for j in range(1, m + 1)])
        ev_time = np.concatenate([[t], t + np.where(rng.random(m) < 0.5, taus, rng.exponential(0.01, m))])
        ev_time[1:][rng.random(m) < 0.05] = np.inf
        exclude = int(order[rng.integers(m)]) if trial % 2 else -1
        best0 = t + (np.inf if trial % 3 == 0 else 1e-12 if trial % 4 == 1 else 10.0 ** rng.uniform(-6, -1))
        long = ed._predict_long(0, exclude, t, xi, yi, zi, vxi, vyi, vzi, st[0, 7], rho, gamma, best0, ed.SKIN, -1,
                                st, ev_time, nbr, nnb, *geom, np.empty((8, 0)), -1)
        # the same list read from a copy of its rows (by field, in list order, at some offset of a larger array)
        base = int(rng.integers(0, 5)) * m + int(rng.integers(0, 7))
        cols = rng.random((8, base + m + 3))
        cols[:, base:base + m] = st[order].T
        copied = ed._predict_long(0, exclude, t, xi, yi, zi, vxi, vyi, vzi, st[0, 7], rho, gamma, best0, ed.SKIN, -1,
                                  st, ev_time, nbr, nnb, *geom, cols, base)
        assert copied[1:] == long[1:] and _bits(copied[0]) == _bits(long[0])
        # the scalar loop over the same list, in pieces short enough for it, carrying the running best
        best = (best0, ed.SKIN, -1)
        for k0 in range(0, m, ed.LONG_LIST):
            piece = order[k0:k0 + ed.LONG_LIST]
            rows = np.zeros((1, ed.LONG_LIST), dtype=np.int32)
            rows[0, :len(piece)] = piece
            best = ed._predict_pairs(0, exclude, t, xi, yi, zi, vxi, vyi, vzi, st[0, 7], rho, gamma, *best, st,
                                     ev_time, rows, np.array([len(piece)], dtype=np.int32), *geom)
        assert long[1:] == best[1:] and _bits(long[0]) == _bits(best[0])
        accepted += best[1] == ed.COLLISION
    assert accepted > 5 and (seed % 2 == 1 or accepted < 40)  # both outcomes occur (overlaps: always accepted)


def _wide_state(n, ratio, seed=0):
    """An LS state of a bidisperse mixture 1 : ratio (30 % of the volume small) at phi ~ 0.45, its lists built:
    large spheres with lists longer than LONG_LIST, single image."""
    start = poisson_packing(n, seed=seed, psd=f"bidisperse:ratio={ratio},small=0.3,by=volume")
    start = run_ls(start, 1.0, seed=seed, target_phi=0.45, progress_interval=1e9).packing
    rng = np.random.default_rng(seed)
    nominal = start.diameters / start.diameters.mean()
    v = maxwell_velocities(n, 0.2, rng)
    rho = start.diameters.mean() * 0.999
    return LSEngine.start(start.positions, nominal, start.box, rho, v, 1e-2, 0.2)


def test_copies_follow_every_change_of_a_row_and_a_list():
    """long_copies, _refresh_copies and _relist_copies keep every copy equal to its row and in list order (checked by
    copies_current, which a stale row or a missed list edit fails) through local list updates that move spheres
    anywhere: lists shrink, grow past LONG_LIST and take a spare slot, and large spheres get new lists."""
    engine = _wide_state(1500, 5.0)
    s = engine.state
    st, nbr, nnb = s.st, s.nbr, s.nnb
    large = np.flatnonzero(st[:, 7] > 1.5 * st[:, 7].min())
    assert not s.multi and 3 < np.sum(nnb > ed.LONG_LIST) < len(large)  # long lists, and lists just short of them
    small = np.flatnonzero(st[:, 7] <= 1.5 * st[:, 7].min())
    lc = ed.long_copies(st, nbr, nnb, True)
    assert ed.copies_current(st, nbr, nnb, lc)
    slotted0 = lc.slot >= 0
    assert np.array_equal(slotted0, nnb > ed.LONG_LIST)
    rng = np.random.default_rng(3)
    n = len(st)
    coords, shift, cells = np.empty(3, dtype=np.int64), np.empty(3), np.empty(27, dtype=np.int64)
    moves = 0
    for step in range(600):
        # a row changes (a collision): stale until refreshed
        j = int(nbr[large[rng.integers(len(large))], 0]) if step % 2 else int(rng.integers(n))
        st[j, 3:6] = rng.normal(size=3)
        st[j, 6] += 1e-3
        if lc.rhead[j] >= 0:
            assert not ed.copies_current(st, nbr, nnb, lc)  # the check sees a stale row
        ed._refresh_copies(st, j, lc.cols, lc.rnext, lc.rhead)
        assert ed.copies_current(st, nbr, nnb, lc)
        # a local list update: a sphere (small, or now and then large) moves anywhere, or next to a large one
        i = int(large[rng.integers(len(large))]) if step % 7 == 0 else int(small[rng.integers(len(small))])
        if step % 3 == 0:
            target = large[rng.integers(len(large))]
            st[i, :3] = s.refs[target] + rng.normal(size=3) * st[target, 7] * 0.6
        else:
            st[i, :3] = rng.random(3) * s.lengths
        if ed._rebuild_one(st, s.refs, i, s.lengths, s.half, s.periodic, s.lvl_ms, s.lvl_off, s.lvl_dmax, s.level,
                           s.rho_list, s.skin, nbr, nnb, s.head, s.nxt, s.prv, s.cellof, s.scratch, coords, shift,
                           cells):
            ed._relist_copies(i, st, nbr, nnb, lc)
            moves += 1
        assert ed.copies_current(st, nbr, nnb, lc), step
    grown = (lc.slot >= 0) & ~slotted0
    assert moves > 500 and grown.any()  # lists crossed LONG_LIST and took spare slots
    assert (nnb[lc.slot >= 0] <= ed.LONG_LIST).any()  # and some slotted lists shrank below it


@pytest.mark.parametrize("container", [None, "slab:height=22"])
def test_a_run_with_copies_takes_the_events_of_a_run_without(container, monkeypatch):
    """LS with the copies and without (run_events' ``copies``): bitwise the same run. A missed update of a copy (a
    collision's, a wall's or a local list update's) makes the long lists predict from stale rows, and the runs part."""
    n = 1500
    start = poisson_packing(n, seed=1, psd="bidisperse:ratio=5,small=0.3,by=volume", container=container)
    start = run_ls(start, 1.0, seed=2, target_phi=0.5, progress_interval=1e9).packing
    original = ed.run_events
    seen, mode = [], {}

    def run_events(s, t, target, count_collisions, t_horizon, counters, acc, copies):  # as the driver calls it
        seen.append((s.multi, int(np.sum(s.nnb > ed.LONG_LIST))))
        return original(s, t, target, count_collisions, t_horizon, counters, acc, mode["copies"])

    monkeypatch.setattr(ed, "run_events", run_events)
    runs = []
    for mode["copies"] in (True, False):
        r = run_ls(start, 1e-2, seed=3, max_collisions=300 * n, progress_interval=1e9)
        runs.append(r)
    assert sum(not multi and long > 0 for multi, long in seen) >= len(seen) // 4  # the copies were used
    a, b = runs
    assert a.stats.collisions == b.stats.collisions and a.stats.collisions >= 300 * n
    assert np.array_equal(a.packing.positions, b.packing.positions) and _bits(a.packing.phi) == _bits(b.packing.phi)
