"""The LP rows (calippso/constraints.py): linearised rows inside the exact constraint, pairs and vectors against
brute force."""

import numpy as np
import pytest

from spherejam.calippso.constraints import (closable_reach, constraint_rows, cutoff_rows, pair_vectors,
                                            pairs_in_cutoff, row_excess)
from spherejam.calippso.lp import solve_lp
from spherejam.calippso.schedule import cutoff_and_bound, nearest_gap_median
from spherejam.core.seeding import poisson_packing
from spherejam.engines.lubachevsky_stillinger import run_ls


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


def test_closable_rows_are_the_pairs_within_their_own_reach():
    rng = np.random.default_rng(3)
    box, n, dim = 8.0, 300, 3
    pos = rng.random((n, dim)) * box
    dia = np.exp(rng.normal(0.0, 0.5, n)) * 0.6  # wide: D_max / D_min ~ 20
    k, s_bound = 1.2, 0.01
    pi, pj, rij = cutoff_rows(pos, box, closable_reach(dia, k, s_bound, dim))
    d = pos[:, None, :] - pos[None, :, :]
    d -= box * np.round(d / box)
    r = np.linalg.norm(d, axis=2)
    sigma = 0.5 * (dia[:, None] + dia[None, :])
    ii, jj = np.nonzero(np.triu(r < k * sigma + 2.0 * np.sqrt(dim) * s_bound, 1))
    assert set(zip(pi.tolist(), pj.tolist())) == set(zip(ii.tolist(), jj.tolist()))
    # one cutoff for all, set by the largest sphere, lists several times as many rows
    assert len(cutoff_rows(pos, box, k * dia.max() + 2.0 * np.sqrt(dim) * s_bound)[0]) > 3 * len(pi)


@pytest.mark.parametrize("p_max", [20.0, 1e4])  # regime 1 (large steps) and regime 2
def test_an_lp_over_the_closable_rows_is_an_optimum_of_the_lp_over_the_whole_cutoff(p_max):
    # the rows a step cannot close are left out of every LP (docs/calippso.md §1.4): its optimum must satisfy them all
    start = run_ls(poisson_packing(150, 0.5, seed=4), 0.1, p_max=p_max, seed=2, progress_interval=1e9).packing
    x, dia, box = start.positions, start.diameters, start.box
    R = 0.5 * dia.max()
    gap = nearest_gap_median(x, dia, box)
    ell, s_bound, inflation_max, regime = cutoff_and_bound(1.0 + gap, R, 4.0 * R, 3, box)
    assert regime == (1 if p_max < 100 else 2)
    kw = dict(s_bound=s_bound, pinned=0, inflation_bounds=(0.0, inflation_max), solver="ipx")
    whole = cutoff_rows(x, box, ell)
    closable = cutoff_rows(x, box, closable_reach(dia, np.sqrt(inflation_max), s_bound, 3))
    sols = []
    for pi, pj, rij in (whole, closable):
        sigma2 = (0.5 * (dia[pi] + dia[pj])) ** 2
        sols.append(solve_lp(rij, sigma2, pi, pj, len(dia), **kw))
    assert len(closable[0]) < 0.5 * len(whole[0])
    assert sols[1].inflation == pytest.approx(sols[0].inflation, rel=1e-9)
    assert sols[1].inflation > 1.0 + 1e-4  # the step moves: the rows left out had a chance to be crossed
    pi, pj, rij = whole
    sigma2 = (0.5 * (dia[pi] + dia[pj])) ** 2
    assert row_excess(rij, sigma2, pi, pj, sols[1].s, sols[1].inflation) <= 1e-9
