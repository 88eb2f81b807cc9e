"""The cell-list neighbour search against brute force, including polydisperse and d != 3 cases."""

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from spherejam.core import neighbours
from spherejam.core.packing import Packing


def _as_set(i, j):
    return set(zip(i.tolist(), j.tolist()))


@settings(max_examples=60, deadline=None)
@given(
    n=st.integers(2, 120),
    dim=st.integers(2, 4),
    ratio=st.floats(1.0, 10.0),
    scale=st.floats(0.2, 3.0),
    seed=st.integers(0, 2**31),
)
def test_pairs_within_matches_brute_force(n, dim, ratio, scale, seed):
    rng = np.random.default_rng(seed)
    box = float(rng.uniform(3.0, 12.0))
    pos = rng.random((n, dim)) * box
    dia = rng.uniform(1.0 / ratio, 1.0, n)
    ci, cj, cr = neighbours.pairs_within(pos, dia, box, scale)
    bi, bj, br = neighbours.brute_force_pairs(pos, dia, box, scale)
    assert _as_set(ci, cj) == _as_set(bi, bj)
    order = np.lexsort((bj, bi))
    np.testing.assert_allclose(cr, br[order], rtol=1e-14)


def test_closest_pair_matches_brute_force(rng):
    for dim in (2, 3, 5):
        pos = rng.random((300, dim)) * 7.0
        dia = rng.uniform(0.1, 1.0, 300)
        i, j, h = neighbours.closest_pair(pos, dia, 7.0)
        bi, bj, br = neighbours.brute_force_pairs(pos, dia, 7.0, scale=1e9)
        hb = br / (0.5 * (dia[bi] + dia[bj]))
        k = np.argmin(hb)
        assert (i, j) == (bi[k], bj[k])
        assert h == hb[k]


def test_pairs_across_periodic_boundary():
    pos = np.array([[0.05, 5.0, 5.0], [9.97, 5.0, 5.0], [5.0, 5.0, 5.0]])
    i, j, r = neighbours.pairs_within(pos, np.ones(3), 10.0, 1.0)
    assert _as_set(i, j) == {(0, 1)}
    assert np.isclose(r[0], 0.08)


def test_check_finds_worst_overlap():
    pos = np.array([[1.0, 1.0, 1.0], [1.999, 1.0, 1.0], [5.0, 5.0, 5.0], [6.0 - 1e-12, 5.0, 5.0]])
    p = Packing(pos, np.ones(4), 10.0)
    rep = p.check(1e-10)
    assert not rep.ok and rep.n_overlaps == 1 and rep.pair == (0, 1)
    assert np.isclose(rep.worst_overlap, 1e-3)
    ok = Packing(pos[2:], np.ones(2), 10.0).check(1e-10)
    assert ok.ok and ok.n_overlaps == 0 and 0 < ok.worst_overlap < 1e-10
