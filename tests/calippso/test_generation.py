"""Constraint generation (calippso/generation.py, docs/calippso.md §5.7): the near set's premise, and rows added
until none is violated, with the certificate of the run with every row."""

import numpy as np
import pytest

from spherejam.calippso.constraints import pair_vectors, pairs_in_cutoff
from spherejam.calippso.run import run_calippso

from certificate import assert_jammed
from packings import rsa_packing


def test_rows_outside_the_near_set_hold_at_every_step_within_the_guess():
    """The premise of near_rows: a pair beyond sigma sqrt(Gamma_guess) + 2 sqrt(d) s_bound cannot be violated by any
    step with |s| <= s_bound and sqrt(Gamma) <= sqrt(Gamma_guess); with a larger Gamma some of them are."""
    from spherejam.calippso.constraints import row_excesses
    from spherejam.calippso.generation import near_rows

    rng = np.random.default_rng(3)
    packing = rsa_packing(200, 0.3, 3, seed=3, size_ratio=1.4)
    x, box, dia = packing.positions, packing.box, packing.diameters
    i, j, _ = pairs_in_cutoff(x, box, 2.0)
    rij = pair_vectors(x, box, i, j)
    sigma2 = (0.5 * (dia[i] + dia[j])) ** 2
    s_bound, guess = 0.02, 1.05
    far = ~near_rows(rij, sigma2, s_bound, guess)
    assert 0 < np.count_nonzero(far) < len(i)
    for _ in range(50):
        s = rng.choice([-s_bound, s_bound], size=x.shape)  # the corners of the box of steps reach furthest
        assert np.max(row_excesses(rij[far], sigma2[far], i[far], j[far], s, guess**2)) <= 1e-12
    assert np.max(row_excesses(rij[far], sigma2[far], i[far], j[far], s, 1.3**2)) > 0


@pytest.mark.parametrize("path, resolved_by", [
    ({}, "warm"),
    ({"solver_options": {"simplex_iteration_limit": 0}}, "ipm"),
    ({"solver": "hipo", "warm_start": False, "active_set": False}, "warm"),
], ids=["dual-simplex-resolve", "forced-fallback", "hipo-vertex-resolve"])
def test_constraint_generation_adds_the_violated_rows_and_certifies(monkeypatch, ls_jammed_256, path, resolved_by):
    """Constraint generation forced to leave out rows that the LP does close (near set cut to 2 % of its reach): the
    first solve violates some of them, they are added and the LP re-solved (dual simplex from its basis; with the
    simplex starved of pivots, the forced fallback to a cold solve; on the path of N >= 4096, from the basis of a
    certified HiPO vertex), and the run reaches the certificate of the run with every row: isostatic, balanced, no
    overlap, the same contacts, rattlers and phi."""
    import spherejam.calippso.run as run_module
    from spherejam.calippso.constraints import row_excesses

    full = run_calippso(ls_jammed_256)
    near_rows = run_module.near_rows
    monkeypatch.setattr(run_module, "near_rows", lambda rij, sigma2, s_bound, guess:
                        near_rows(rij, sigma2, 0.02 * s_bound, 1.0))
    calls = []  # (keys of the LP's rows, its solution, how it was started)
    solve = run_module.solve_lp

    def recorded(rij, sigma2, pi, pj, n, **kw):
        sol = solve(rij, sigma2, pi, pj, n, **kw)
        calls.append((pi * n + pj, rij, sigma2, pi, pj, sol, kw.get("cuts", False)))  # the force LP: no cuts
        return sol

    monkeypatch.setattr(run_module, "solve_lp", recorded)
    cg = run_calippso(ls_jammed_256, constraint_generation=True, **path)
    resolves = [k for k in range(1, len(calls)) if calls[k][6]]
    assert resolves and np.any(cg.history["rows_added"] > 0)
    for k in resolves:
        keys, rij, sigma2, pi, pj, sol, _ = calls[k - 1]
        added = np.setdiff1d(calls[k][0], keys)
        assert added.size and np.all(np.isin(keys, calls[k][0]))  # rows are only ever added
        # every added row was violated by the solution of the round before
        new = np.isin(calls[k][0], added)
        r_new, s2_new, i_new, j_new = (a[new] for a in calls[k][1:5])
        assert np.all(row_excesses(r_new, s2_new, i_new, j_new, sol.s, sol.inflation) > 0)
        assert calls[k][5].method_name == resolved_by
    assert np.all(cg.history["lp_rows"] < cg.history["n_constraints"])
    assert_jammed(cg, 3)
    assert {tuple(p) for p in cg.pairs.tolist()} == {tuple(p) for p in full.pairs.tolist()}
    np.testing.assert_array_equal(cg.rattlers, full.rattlers)
    assert cg.phi == pytest.approx(full.phi, abs=1e-9)
