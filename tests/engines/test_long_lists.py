"""The two-pass prediction of long neighbour lists (docs/algorithms.md §7.7) takes exactly the scalar loop's events:
its branch-free bound never exceeds collision_delay, and _predict_long equals _predict_pairs run over the same list,
including exclusion, pruning, availability and ties."""

import numpy as np
import pytest

from spherejam.engines.kernels import event_driven as ed


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
                                st, ev_time, nbr, nnb, *geom)
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
