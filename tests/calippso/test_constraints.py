"""The LP rows (calippso/constraints.py): linearised rows inside the exact constraint, pairs and vectors against
brute force."""

import numpy as np
import pytest

from spherejam.calippso.constraints import constraint_rows, pair_vectors, pairs_in_cutoff


def test_linearised_rows_are_inside_the_exact_constraint():
    rng = np.random.default_rng(1)
    m, dim = 2000, 3
    rij = rng.normal(size=(m, dim))
    sigma2 = rng.uniform(0.5, 1.5, m)
    pi, pj = np.zeros(m, dtype=np.int64), np.ones(m, dtype=np.int64)
    start, index, value, rhs = constraint_rows(rij, sigma2, pi, pj, 2)
    assert np.all(np.diff(start) == 2 * dim + 1)
    s = rng.uniform(-0.3, 0.3, size=(m, 2, dim))
    inflation = rng.uniform(0.5, 2.0, m)
    for k in range(m):
        x = np.concatenate([s[k].ravel(), [inflation[k]]])
        lhs = value[start[k]:start[k + 1]] @ x[index[start[k]:start[k + 1]]]
        exact = np.sum((rij[k] + s[k, 0] - s[k, 1]) ** 2) - inflation[k] * sigma2[k]
        if lhs <= rhs[k]:
            assert exact >= -1e-12
        # the linear row misses exactly |s_i - s_j|^2
        assert exact == pytest.approx(rhs[k] - lhs + np.sum((s[k, 0] - s[k, 1]) ** 2), abs=1e-12)


def test_pairs_in_cutoff_and_vectors_match_brute_force():
    rng = np.random.default_rng(2)
    pos = rng.random((200, 3)) * 6.0
    i, j, _ = pairs_in_cutoff(pos, 6.0, 1.7)
    d = pos[:, None, :] - pos[None, :, :]
    d -= 6.0 * np.round(d / 6.0)
    dist = np.linalg.norm(d, axis=2)
    ii, jj = np.nonzero(np.triu(dist < 1.7, 1))
    assert set(zip(i.tolist(), j.tolist())) == set(zip(ii.tolist(), jj.tolist()))
    np.testing.assert_allclose(pair_vectors(pos, 6.0, i, j), d[i, j], atol=1e-12)
