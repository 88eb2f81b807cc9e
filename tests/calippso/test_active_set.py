"""The vertex predicted and certified without HiGHS (calippso/active_set.py): basis updates, rattler placement,
bound pivots, relaxed rows and promoted rattlers, the fallback to HiGHS."""

import numpy as np
import pytest

from spherejam.calippso.constraints import pair_vectors, pairs_in_cutoff
from spherejam.calippso.lp import solve_lp
from spherejam.calippso.run import run_calippso

from certificate import assert_jammed


def test_basis_inverse_tracks_row_replacements_like_a_fresh_lu():
    """The product-form updates solve, and transposed solve, as a fresh factorisation of the replaced rows does,
    across a refactorisation (more replacements than REFACTOR_EVERY)."""
    from scipy.sparse import random as sparse_random, identity, vstack

    from spherejam.calippso import active_set

    rng = np.random.default_rng(3)
    n = 40
    base = (identity(n) * 4.0 + sparse_random(n, n, density=0.1, random_state=rng)).tocsr()
    extra = (sparse_random(3 * n, n, density=0.15, random_state=rng) + 0.0).tocsr()
    matrix = vstack([base, extra + identity(n, format="csr")[rng.integers(0, n, 3 * n)] * 3.0]).tocsr()
    basis = np.arange(n)
    binv = active_set.BasisInverse(matrix, basis.copy())
    b = rng.normal(size=n)
    replaced = 0
    while replaced < active_set.REFACTOR_EVERY + 7:
        k = int(rng.integers(0, n))
        row = int(rng.integers(n, matrix.shape[0]))
        if row in binv.basis:
            continue
        trial = binv.basis.copy()
        trial[k] = row
        dense = matrix[trial].toarray()
        if abs(np.linalg.det(dense / 4.0)) < 1e-6:
            continue  # keep the test away from nearly singular bases
        binv.replace(k, row)
        replaced += 1
        assert np.array_equal(binv.basis, trial)
        np.testing.assert_allclose(dense @ binv.solve(b), b, atol=1e-9)
        np.testing.assert_allclose(dense.T @ binv.solve_transposed(b), b, atol=1e-9)
    assert len(binv.updates) == 7  # refactorised once, on the REFACTOR_EVERY-th replacement


def test_a_structurally_singular_basis_is_refused_before_its_lu(monkeypatch):
    """A predicted basis in which one sphere's columns are empty (N = 16384's LP 12: SuperLU took 83 CPU-s to
    refuse it) is refused by its structural rank, before any factorisation; a nonsingular one is factorised and
    solves."""
    from scipy.sparse import csr_matrix

    from spherejam.calippso import active_set

    rng = np.random.default_rng(11)
    n = 30
    dense = rng.normal(size=(2 * n, n)) + 10.0 * np.vstack([np.eye(n), np.eye(n)])
    dense[:n, [4, 5, 6]] = 0.0  # the basis rows leave three columns (one sphere's components) empty
    matrix = csr_matrix(dense)
    factorise, factorised = active_set.BasisInverse._factorise, []
    monkeypatch.setattr(active_set.BasisInverse, "_factorise", lambda self: factorised.append(1) or factorise(self))
    with pytest.raises(RuntimeError, match="structural rank 27 of 30"):
        active_set.BasisInverse(matrix, np.arange(n))
    assert not factorised
    basis = np.concatenate([np.arange(n)[np.r_[0:4, 7:n]], n + np.array([4, 5, 6])])
    binv = active_set.BasisInverse(matrix, basis)
    assert factorised
    b = rng.normal(size=n)
    np.testing.assert_allclose(dense[basis] @ binv.solve(b), b, atol=1e-9)


def test_a_basis_whose_lu_fills_in_is_refactorised_less_often_and_still_solves_exactly():
    """A fresh LU pays off only once the product-form updates hold as many numbers as the LU factors: a basis with
    much fill-in (here a dense one, as the 3D contact networks of N = 10^4 are relative to their N) waits longer
    than REFACTOR_EVERY, and its solves stay those of a fresh factorisation across the longer stretch."""
    from scipy.sparse import csr_matrix

    from spherejam.calippso import active_set

    rng = np.random.default_rng(5)
    n = 120
    base = rng.normal(size=(n, n)) + 20.0 * np.eye(n)
    matrix = csr_matrix(np.vstack([base, base + rng.normal(scale=0.5, size=(n, n))]))
    binv = active_set.BasisInverse(matrix, np.arange(n))
    nnz = binv.lu.L.nnz + binv.lu.U.nnz
    assert binv.refactor_every == nnz // (2 * n) > active_set.REFACTOR_EVERY
    b = rng.normal(size=n)
    assert binv.refactor_every <= n
    for k in range(binv.refactor_every - 1):  # row k by its perturbed twin, one short of a refactorisation
        binv.replace(k, n + k)
    assert len(binv.updates) == binv.refactor_every - 1
    dense = matrix[binv.basis].toarray()
    np.testing.assert_allclose(dense @ binv.solve(b), b, atol=1e-9)
    np.testing.assert_allclose(dense.T @ binv.solve_transposed(b), b, atol=1e-9)
    binv.replace(binv.refactor_every - 1, n + binv.refactor_every - 1)
    assert len(binv.updates) == 0  # refactorised on the refactor_every-th replacement


def test_rattlers_are_placed_by_a_feasibility_lp_when_pushing_fails():
    """A rattler between two fixed neighbours on a line: from a place that violates one row, the small LP puts it
    where both rows hold (and moves nothing else); a cage too small for it is reported, not papered over."""
    from spherejam.calippso.active_set import _place_rattlers

    # particle 1 (rattler) between 0 and 2 on a line, all diameters 1: r_ij = x_i - x_j for the pairs (0,1), (1,2)
    rij = np.array([[-1.05, 0.0, 0.0], [-1.05, 0.0, 0.0]])
    sigma2 = np.ones(2)
    pi, pj = np.array([0, 1]), np.array([1, 2])
    rattler = np.array([False, True, False])
    s = np.zeros((3, 3))
    s[1, 0] = -0.06  # too close to 0: row (0, 1) violated
    assert np.einsum("ij,ij->i", rij, rij + 2.0 * (s[pi] - s[pj]))[0] < 1.0
    assert _place_rattlers(rij, sigma2, pi, pj, s, 1.0, rattler, 0.1, 1e-12)
    slack = np.einsum("ij,ij->i", rij, rij + 2.0 * (s[pi] - s[pj])) - sigma2
    assert np.all(slack >= 1e-12) and np.all(np.abs(s) <= 0.1)
    assert np.array_equal(s[[0, 2]], np.zeros((2, 3)))  # only the rattler moved
    s = np.zeros((3, 3))
    s[0, 0], s[2, 0] = 0.06, -0.06  # the walls closed in: 2.1 - 0.12 < 2 diameters, no room
    assert not _place_rattlers(rij, sigma2, pi, pj, s, 1.0, rattler, 0.1, 1e-12)


def _main_loop_lp(packing, cutoff=1.35):
    """The rows of a main-loop LP of ``packing`` in its own units (pairs within ``cutoff`` largest diameters)."""
    x, box = packing.positions, packing.box
    i, j, _ = pairs_in_cutoff(x, box, cutoff)
    return pair_vectors(x, box, i, j), (0.5 * (packing.diameters[i] + packing.diameters[j])) ** 2, i, j


def test_active_set_pivots_a_bound_in_when_the_prediction_overshoots_it(ls_jammed_256):
    """The contact network of an LP predicts the vertex of the same LP with a tighter s bound only if the solve can
    pivot on bounds: the prediction's vertex lies beyond the bound, dual pivots bring bound rows in, and the result
    is HiGHS's optimum (same Gamma, a bound active) -- before bounds were rows, this fell back to HiGHS."""
    from spherejam.calippso.active_set import network_prediction, solve_active_set
    from spherejam.calippso.network import contact_network

    n = ls_jammed_256.n
    rij, sigma2, i, j = _main_loop_lp(ls_jammed_256)
    wide = solve_lp(rij, sigma2, i, j, n, s_bound=0.05, pinned=0, inflation_bounds=(1.0, 2.0), solver="ipx")
    contact, rattler, _, isostatic, _ = contact_network(rij, sigma2, i, j, wide.duals, n, 3, 1e-10)
    assert isostatic
    stable_s = float(np.max(np.abs(wide.s[~rattler])))
    tight = 0.5 * stable_s  # the wide LP's vertex is beyond this bound
    why: list[str] = []
    sol = solve_active_set(rij, sigma2, i, j, n, *network_prediction(contact, rattler, i, j, n), s_bound=tight,
                           pinned=0, inflation_bounds=(1.0, 2.0), max_pivots=500, why=why)
    assert sol is not None, why
    assert "bounds" in sol.method  # a bound row entered
    ref = solve_lp(rij, sigma2, i, j, n, s_bound=tight, pinned=0, inflation_bounds=(1.0, 2.0), solver="ipx")
    assert sol.inflation == pytest.approx(ref.inflation, rel=0, abs=1e-12)
    assert np.max(np.abs(sol.s)) == pytest.approx(tight, rel=1e-12) and np.all(np.abs(sol.s) <= tight)
    excess = np.einsum("ij,ij->i", rij, rij + 2.0 * (sol.s[i] - sol.s[j])) - sol.inflation * sigma2
    assert excess.min() >= -1e-12 and np.all(sol.duals >= 0)


def test_a_vertex_held_at_its_bound_predicts_the_lp_with_a_wider_bound(ls_jammed_256):
    """An LP whose vertex holds stable components at a tight s bound is not isostatic by its contacts, yet its
    contacts and held components are one square system: the next LP, with a wider bound (docs/calippso.md §1.5),
    starts from it, and pivots release the held components' bound rows that no longer bind. Here the bound is
    wide enough for the unbounded optimum, so every one must be released; the result is HiGHS's optimum. (With held
    components as dropped unknowns, as before, this failed: their bound multipliers came out negative.)"""
    from spherejam.calippso.active_set import solve_active_set, vertex_prediction
    from spherejam.calippso.network import contact_network

    n = ls_jammed_256.n
    rij, sigma2, i, j = _main_loop_lp(ls_jammed_256)
    wide = solve_lp(rij, sigma2, i, j, n, s_bound=0.05, pinned=0, inflation_bounds=(1.0, 2.0), solver="ipx")
    wide_rattler = contact_network(rij, sigma2, i, j, wide.duals, n, 3, 1e-10)[1]
    tight = 0.25 * float(np.max(np.abs(wide.s[~wide_rattler])))
    bounded = solve_lp(rij, sigma2, i, j, n, s_bound=tight, pinned=0, inflation_bounds=(1.0, 2.0), solver="ipx")
    contact, _, _, isostatic, _ = contact_network(rij, sigma2, i, j, bounded.duals, n, 3, 1e-10)
    assert not isostatic  # a network short of its held components
    predicted = vertex_prediction(contact, bounded.duals, bounded.s, tight, rij, i, j, n, 0)
    assert predicted is not None and np.count_nonzero(predicted[2]) > 0
    why: list[str] = []
    sol = solve_active_set(rij, sigma2, i, j, n, predicted[0], predicted[1], s_bound=8.0 * tight, pinned=0,
                           inflation_bounds=(1.0, 2.0), max_pivots=500, fixed=predicted[2], why=why)
    assert sol is not None, why
    assert not np.any(sol.held)  # every held component released
    ref = solve_lp(rij, sigma2, i, j, n, s_bound=8.0 * tight, pinned=0, inflation_bounds=(1.0, 2.0), solver="ipx")
    assert sol.inflation == pytest.approx(ref.inflation, rel=0, abs=1e-12)
    assert sol.inflation == pytest.approx(wide.inflation, rel=0, abs=1e-12)
    excess = np.einsum("ij,ij->i", rij, rij + 2.0 * (sol.s[i] - sol.s[j])) - sol.inflation * sigma2
    assert excess.min() >= -1e-12 and np.all(sol.duals >= 0)
    # the same prediction with the bound kept: the bound rows stay, and the vertex is that LP's optimum
    same = solve_active_set(rij, sigma2, i, j, n, predicted[0], predicted[1], s_bound=tight, pinned=0,
                            inflation_bounds=(1.0, 2.0), max_pivots=500, fixed=predicted[2], why=why)
    assert same is not None, why
    assert same.inflation == pytest.approx(bounded.inflation, rel=0, abs=1e-12) and np.any(same.held)


@pytest.fixture(scope="module")
def ls_fast_256():
    """A fast LS packing (rate 1e-2) at p = 1e12: its LPs creep, their contact networks change from LP to LP."""
    from spherejam.core.seeding import poisson_packing
    from spherejam.engines.lubachevsky_stillinger import run_ls

    return run_ls(poisson_packing(256, 0.0, 3), 1e-2, p_max=1e12, seed=3, progress_interval=1e9).packing


def test_active_set_relaxes_and_promotes_on_a_creeping_input(monkeypatch, ls_fast_256):
    """Where the previous contact network is beyond other rows with negative duals, or leaves a rattler no place,
    the active-set solve relaxes those rows / makes the rattler a member, and certifies the LP instead of falling
    back to HiGHS (every LP from N = 4096 on goes this way; forced here at N = 256 by warm_start=False). The
    certificate is the one of a run where every LP is solved by HiGHS."""
    import spherejam.calippso.run as run_module

    methods: list[str] = []
    solve = run_module.solve_active_set

    def recorded(*args, **kwargs):
        sol = solve(*args, **kwargs)
        methods.append("failed" if sol is None else sol.method)
        return sol

    monkeypatch.setattr(run_module, "solve_active_set", recorded)
    new = run_calippso(ls_fast_256, solver="hipo", warm_start=False)
    monkeypatch.setattr(run_module, "solve_active_set", solve)
    every = run_calippso(ls_fast_256, solver="hipo", warm_start=False, active_set=False)
    assert any("relaxed" in m for m in methods), methods
    assert any("promoted" in m for m in methods), methods
    assert_jammed(new, 3)
    assert_jammed(every, 3)
    assert new.counters["lp_methods"].get("active-set", 0) > len(methods) // 2
    assert {tuple(p) for p in new.pairs.tolist()} == {tuple(p) for p in every.pairs.tolist()}
    np.testing.assert_array_equal(new.rattlers, every.rattlers)
    assert new.phi == pytest.approx(every.phi, abs=1e-9)


def test_forced_active_set_failure_falls_back_to_highs(monkeypatch, ls_fast_256):
    """Every active-set attempt forced to fail: each LP falls back to HiGHS (interior point + certified vertex) and
    the run reaches the same certificate as with the shortcut."""
    import spherejam.calippso.lp as lp
    import spherejam.calippso.run as run_module
    from spherejam.calippso.solution import METHOD_CODES

    ref = run_calippso(ls_fast_256, solver="hipo", warm_start=False)
    monkeypatch.setattr(run_module, "solve_active_set", lambda *args, **kwargs: None)
    calls = []
    certify = lp.solve_active_set
    monkeypatch.setattr(lp, "solve_active_set", lambda *a, **k: calls.append(1) or certify(*a, **k))
    forced = run_calippso(ls_fast_256, solver="hipo", warm_start=False)
    assert not np.any(forced.history["method"] == METHOD_CODES["active-set"])
    assert len(calls) >= forced.iterations  # every LP went to HiGHS and had its interior point certified
    assert_jammed(forced, 3)
    assert {tuple(p) for p in forced.pairs.tolist()} == {tuple(p) for p in ref.pairs.tolist()}
    assert forced.phi == pytest.approx(ref.phi, abs=1e-9)


def test_the_previous_network_is_not_tried_after_an_lp_that_changed_more_contacts_than_its_pivots(monkeypatch,
                                                                                                    ls_fast_256):
    """Each contact that changes between two LPs takes pivots of the shortcut (up to 5.4 each where it succeeded at
    N = 10^4), and a creeping flow goes on changing as many: there every one of 42 attempts after an LP that changed
    70-200 contacts failed (200 pivots, ~20 CPU-s each, docs/calippso.md §5.4). So after an LP that changed more
    contacts than a PIVOTS_PER_CHANGE-th of the shortcut's pivots, the next goes straight to HiGHS. Here the pivots
    are capped at 20 PIVOTS_PER_CHANGE on the creeping N = 256 input, whose LPs change 15-41 contacts: the shortcut
    is tried exactly after the LPs that changed at most 20, and the run reaches the certificate of the default
    one."""
    import spherejam.calippso.run as run_module
    from spherejam.calippso.active_set import PIVOTS_PER_CHANGE

    ref = run_calippso(ls_fast_256, solver="hipo", warm_start=False)
    checked: list[int] = []  # LPs checked so far, at each shortcut attempt
    tried: list[int] = []
    check, solve = run_module._check, run_module.solve_active_set

    def counted_check(*args, **kwargs):
        checked.append(1)
        return check(*args, **kwargs)

    def recorded(*args, **kwargs):
        tried.append(len(checked) + 1)  # the LP this attempt solves
        return solve(*args, **kwargs)

    monkeypatch.setattr(run_module, "network_pivot_limit", lambda n: 20 * PIVOTS_PER_CHANGE)
    monkeypatch.setattr(run_module, "_check", counted_check)
    monkeypatch.setattr(run_module, "solve_active_set", recorded)
    res = run_calippso(ls_fast_256, solver="hipo", warm_start=False)
    changes = res.history["contact_changes"]
    main_loop = [k for k in tried if k <= res.iterations]
    assert main_loop and any(changes[k - 2] > 20 for k in range(2, res.iterations + 1)), changes
    assert all(changes[k - 2] <= 20 for k in main_loop), (main_loop, changes)
    isostatic = res.history["isostatic"]
    assert all(k in main_loop for k in range(2, res.iterations + 1) if 0 <= changes[k - 2] <= 20
               and isostatic[k - 2]), (main_loop, changes)
    assert_jammed(res, 3)
    assert {tuple(p) for p in res.pairs.tolist()} == {tuple(p) for p in ref.pairs.tolist()}
    assert res.phi == pytest.approx(ref.phi, abs=1e-9)


def test_lps_after_a_bound_held_lp_are_shortcuts_with_the_same_certificate(ls_jammed_256):
    """A bound a fifth of the first LP's step (fixed, so it never widens): LPs 1-7 end with stable components held
    at it and are not isostatic by their contacts (as the first LPs of N = 10^4 LS outputs, docs/calippso.md §9).
    Each such LP predicts the next, and the active-set solve certifies it; before, every one went to HiGHS. The LPs,
    the jammed state and its network are those of a run where HiGHS solves every LP."""
    from spherejam.calippso.solution import METHOD_CODES

    bound = 0.2 * 5.79e-4  # the first LP's largest step is 5.79e-4 diameters
    new = run_calippso(ls_jammed_256, s_bound=bound, warm_start=False, solver="ipx")
    every = run_calippso(ls_jammed_256, s_bound=bound, warm_start=False, solver="ipx", active_set=False)
    h = new.history
    held = (h["isostatic"][:-1] == 0) & (h["bound_active"][:-1] > 0)
    assert np.count_nonzero(held) >= 3
    assert np.all(h["method"][1:][held] == METHOD_CODES["active-set"])
    assert new.iterations == every.iterations
    assert_jammed(new, 3)
    assert {tuple(p) for p in new.pairs.tolist()} == {tuple(p) for p in every.pairs.tolist()}
    np.testing.assert_array_equal(new.rattlers, every.rattlers)
    assert new.phi == pytest.approx(every.phi, abs=1e-9)


def test_an_active_set_solve_too_slow_for_its_pivots_is_given_up_early(monkeypatch, ls_fast_256):
    """The third LP of a creeping N = 256 input, predicted from the second: ~110 pivots certify it within the budget
    of 500 (110 or 112 on two machines: the count follows the floating point of the solves before it). With a
    budget of 40 and the pace checked every 20 pivots instead of PROGRESS_EVERY, its negative duals have risen
    after the first 20 (duals move together) and outnumber the 20 pivots left, so the solve gives up then instead
    of after 40 -- the fallback to HiGHS that spares N = 10^4 minutes of pivots (docs/calippso.md
    §5.4). With 480 pivots left the same count and pace are no reason to give up."""
    active_set, args, kwargs = _third_lp_attempt(monkeypatch, ls_fast_256)
    sol = active_set.solve_active_set(*args, **{**kwargs, "max_pivots": 500})
    assert sol is not None and sol.method.startswith("active-set+")
    assert 40 < int(sol.method.split("+")[1]) <= 500  # more pivots than the small budget below allows
    why: list[str] = []
    assert active_set.solve_active_set(*args, **{**kwargs, "max_pivots": 40, "why": why}) is None
    assert len(why) == 1 and "after 20 pivots" in why[0] and "too slow for the 20 left" in why[0], why


def test_an_active_set_solve_many_duals_short_pivots_before_its_pace_is_judged(monkeypatch, ls_fast_256):
    """The attempt of the test above starts with more negative duals than ten per pivot it is given here. Such an
    attempt used to be given up before its first pivot; it now pivots, and is judged by its pace after PROBE_PIVOTS
    (the test above) or by its budget, because a nearly singular basis has nearly every dual wrong until a few pivots
    put them right (at N = 1e4 10 667 in 6 pivots, docs/calippso.md §5.4)."""
    import re

    active_set, args, kwargs = _third_lp_attempt(monkeypatch, ls_fast_256)
    why: list[str] = []
    assert active_set.solve_active_set(*args, **{**kwargs, "max_pivots": 40, "why": why}) is None
    start = int(re.search(r"\((\d+) after 0\)", why[0]).group(1))  # negative duals before the first pivot
    few = (start - 1) // 10  # start > 10 few: the old rule gave this budget up before its first pivot
    assert few >= 1, why
    why.clear()
    assert active_set.solve_active_set(*args, **{**kwargs, "max_pivots": few, "why": why}) is None
    assert len(why) == 1 and f"after {few} pivots" in why[0] and "after 0 pivots" not in why[0], why


def test_a_stable_sphere_whose_rows_rank_below_the_vertex_is_covered_by_the_prediction(monkeypatch, ls_jammed_256):
    """The prediction takes the highest-scoring rows among stable spheres. Where rows off the vertex outscore every
    row of one stable sphere, the top rows leave its d columns empty and the basis is structurally singular: most
    uncertified predictions near convergence at N = 1e4 and 16384, each followed by a crossover of 400-1200 CPU-s
    or more (docs/calippso.md §5.2). Here the rows with the smallest gaps off the vertex outscore one sphere's
    contacts, which stay near (score > 1): the prediction still covers every unknown, with rows of that sphere."""
    from scipy.sparse.csgraph import structural_rank

    import spherejam.calippso.active_set as active_set
    from spherejam.calippso.constraints import pair_keys, pair_vectors, pairs_in_cutoff

    packing, n = ls_jammed_256, ls_jammed_256.n
    i, j, _ = pairs_in_cutoff(packing.positions, packing.box, 1.35)
    rij = pair_vectors(packing.positions, packing.box, i, j)
    sigma2 = (0.5 * (packing.diameters[i] + packing.diameters[j])) ** 2
    kw = dict(s_bound=0.005 * packing.diameters.max(), pinned=0, inflation_bounds=(1.0, 1.2))
    active = solve_lp(rij, sigma2, i, j, n, **kw, solver="ipx").duals > 0
    degree = np.bincount(np.concatenate([i[active], j[active]]), minlength=n)
    sphere = int(np.flatnonzero(degree >= 5)[1])  # stable, not the pinned sphere 0
    its = (i == sphere) | (j == sphere)
    gap = np.einsum("ij,ij->i", rij, rij) - sigma2
    off = np.flatnonzero(~active & ~its & (degree[i] >= 4) & (degree[j] >= 4))
    decoys = off[np.argsort(gap[off])][: int(np.count_nonzero(its & active)) + 2]
    score = np.where(active, 1e6, 1e-6)
    score[its & active], score[decoys] = 10.0, 100.0
    slack = np.ones(len(i))
    duals = score * (slack / sigma2) / (sigma2 * len(i))  # the prediction's score, inverted

    def prediction():
        keys, rattler, fixed = active_set.interior_point_prediction(i, j, n, 3, sigma2, duals, slack, pinned=0)
        system = active_set._contact_system(rij, sigma2, i, j, n, keys, rattler, kw["s_bound"], 0,
                                            kw["inflation_bounds"], fixed)
        return np.isin(pair_keys(i, j, n), keys), system.a[system.basis], system.basis.size

    rows, basis, size = prediction()
    assert structural_rank(basis.tocsr()) == size
    assert np.count_nonzero(rows & its) >= 3 and np.count_nonzero(rows & np.isin(np.arange(len(i)), decoys)) > 0
    monkeypatch.setattr(active_set, "covering_rows", lambda order, nu, *rest: order[:nu])  # the top rows alone
    rows, basis, size = prediction()
    assert not np.any(rows & its) and structural_rank(basis.tocsr()) == size - 3


def _third_lp_attempt(monkeypatch, packing):
    """The active-set module with its pace checked every 20 pivots, and the arguments of the third LP's attempt of a
    CALiPPSO run on ``packing`` (predicted from the second LP's network)."""
    import spherejam.calippso.active_set as active_set
    import spherejam.calippso.run as run_module

    calls = []
    solve = run_module.solve_active_set
    monkeypatch.setattr(run_module, "solve_active_set", lambda *a, **k: calls.append((a, k)) or solve(*a, **k))
    run_calippso(packing, solver="hipo", warm_start=False, max_iterations=3)
    monkeypatch.setattr(active_set, "PROGRESS_EVERY", 20)
    return active_set, *calls[1]


def first_promoting_solve(monkeypatch, packing):
    """``(args, kwargs, solution)`` of the first active-set solve of a run on ``packing`` (warm starts off, so that
    every LP tries the shortcut) that made stuck rattlers members of the network."""
    import spherejam.calippso.run as run_module

    calls = []
    solve = run_module.solve_active_set

    def recorded(*args, **kwargs):
        sol = solve(*args, **kwargs)
        calls.append((args, kwargs, sol))
        return sol

    monkeypatch.setattr(run_module, "solve_active_set", recorded)
    run_calippso(packing, solver="hipo", warm_start=False, max_iterations=3)
    monkeypatch.setattr(run_module, "solve_active_set", solve)
    promoting = [call for call in calls if call[2] is not None and "promoted" in call[2].method]
    assert promoting, [sol and sol.method for _, _, sol in calls]
    return promoting[0]


def pivots_of_each_attempt(monkeypatch) -> list[int]:
    """The list the active-set module appends each attempt's pivots to (the attempts that reach a vertex)."""
    import spherejam.calippso.active_set as active_set

    pivots: list[int] = []
    pivot = active_set._pivot

    def counted(system, feasibility, max_pivots):
        out = pivot(system, feasibility, max_pivots)
        pivots.append(out[2])
        return out

    monkeypatch.setattr(active_set, "_pivot", counted)
    return pivots


def test_the_attempts_of_one_active_set_solve_share_its_pivots(monkeypatch, ls_fast_256):
    """An attempt after rattlers joined the network pivots on from the vertex the one before reached; its pivots
    come out of the same budget as those before (at N = 10^4 three attempts of the whole budget kept one LP pivoting for
    over 20 CPU-minutes, docs/calippso.md §5.4). A solve of the creeping N = 256 input that promotes is certified
    within 500 pivots; given one pivot fewer than all its attempts took, though each attempt alone took fewer than
    that, it gives up, and its attempts together never pivot more than it was given."""
    import spherejam.calippso.active_set as active_set

    args, kwargs, _ = first_promoting_solve(monkeypatch, ls_fast_256)

    pivots = pivots_of_each_attempt(monkeypatch)
    whole = active_set.solve_active_set(*args, **{**kwargs, "max_pivots": 500})
    assert whole is not None and "promoted" in whole.method
    assert len(pivots) >= 2 and min(pivots) >= 1 and sum(pivots) <= 500, pivots
    short = sum(pivots) - 1
    assert max(pivots) <= short  # each attempt alone would fit in the smaller budget
    pivots.clear()
    why: list[str] = []
    assert active_set.solve_active_set(*args, **{**kwargs, "max_pivots": short, "why": why}) is None
    assert sum(pivots) <= short, (pivots, why)


def test_an_active_set_solve_promotes_stuck_rattlers_for_as_many_rounds_as_its_pivots_last(monkeypatch, ls_fast_256):
    """A vertex that leaves predicted rattlers no place makes them members and starts again, and each new vertex can
    leave other rattlers stuck: at N = 1e4, sigma = 0.3 one took four rounds (20, 5, 4, 2 rattlers), and the cap of
    two sent the LP to a crossover fallback of 3.3 times the cost (docs/calippso.md §5.4). Here the creeping N = 256
    input's first promoting solve, whose vertex leaves 3 rattlers stuck, promotes one per round: it needs three
    rounds, and it is certified, at the vertex of the one-round solve."""
    import spherejam.calippso.active_set as active_set

    args, kwargs, once = first_promoting_solve(monkeypatch, ls_fast_256)
    assert "+1promoted" in once.method
    promote = active_set._promote
    stuck_sizes = []

    def one_per_round(rij, sigma2, pi, pj, n, rattler, stuck):
        stuck_sizes.append(stuck["rattlers"].size)
        return promote(rij, sigma2, pi, pj, n, rattler, {**stuck, "rattlers": stuck["rattlers"][:1]})

    monkeypatch.setattr(active_set, "_promote", one_per_round)
    why: list[str] = []
    sol = active_set.solve_active_set(*args, **{**kwargs, "max_pivots": 2000, "why": why})
    assert sol is not None and "+3promoted" in sol.method, why
    assert stuck_sizes == [3, 2, 1], stuck_sizes
    assert sol.inflation == pytest.approx(once.inflation, rel=1e-14, abs=0.0)
    assert np.min(sol.duals) >= 0.0 and np.count_nonzero(sol.duals) == np.count_nonzero(once.duals)


def test_a_promotion_round_starts_from_the_vertex_the_round_before_reached(monkeypatch, ls_fast_256):
    """Promoted rattlers' rows leave every other unknown and dual of the vertex that stranded them as they were, so
    the next round starts there and pivots only for what the newcomers change. Started from the first prediction
    again, a round paid the pivots before it a second time: at N = 1e4, sigma = 0.3 three rounds overran the solve's
    budget and the LP fell back to crossover (472 CPU-s; 183 CPU-s certified from the vertex, docs/calippso.md §5.4).
    The creeping N = 256 input's first promoting solve: the round after the promotion takes under a third of the
    first round's pivots (on the old code about as many), and its vertex is the LP's optimum, HiGHS's Gamma."""
    import spherejam.calippso.active_set as active_set

    args, kwargs, _ = first_promoting_solve(monkeypatch, ls_fast_256)
    pivots = pivots_of_each_attempt(monkeypatch)
    sol = active_set.solve_active_set(*args, **{**kwargs, "max_pivots": 500})
    assert sol is not None and "+1promoted" in sol.method
    assert len(pivots) == 2 and pivots[0] >= 30 and pivots[1] < pivots[0] / 3, pivots
    rij, sigma2, pi, pj, n = args[:5]
    ref = solve_lp(rij, sigma2, pi, pj, n, s_bound=kwargs["s_bound"], pinned=kwargs["pinned"],
                   inflation_bounds=kwargs["inflation_bounds"], solver="ipx")
    assert sol.inflation == pytest.approx(ref.inflation, rel=1e-12, abs=0.0)
    assert np.min(sol.duals) >= 0.0


def test_a_particle_held_against_its_bound_by_d_contacts_is_stable_in_a_periodic_box():
    """The s bound is a wall in the rattler analysis of a prediction (docs/calippso.md §5.4). In a periodic box it
    used to be peeled like a particle once fewer than d + 1 held components remained, and with it every particle
    the bound holds against d contacts: at N = 10^4, sigma = 0.3, one such sphere took five more with it, the
    prediction was one contact short, and every LP fell back to a second HiPO solve with crossover. A rattler resting
    at its bound with a round-off multiplier holds nothing."""
    from spherejam.calippso.active_set import interior_point_prediction

    n, dim, s_bound = 10, 3, 1e-3
    core = [(a, b) for a in range(1, 9) for b in range(a + 1, 9)]  # particles 1-8: 7 contacts each
    pairs = np.array(core + [(0, 1), (0, 2), (0, 3), (4, 9), (5, 9), (6, 9)])  # 0 and 9: d contacts
    pi, pj = pairs[:, 0], pairs[:, 1]
    duals = np.ones(len(pairs))
    slack = np.full(len(pairs), 1e-12)
    sigma2 = np.ones(len(pairs))
    s = np.zeros((n, dim))
    col_dual = np.zeros((n, dim))
    s[0, 2], col_dual[0, 2] = s_bound, -1e-3  # pressed against its upper bound
    s[9, 0], col_dual[9, 0] = s_bound, 1e-19  # resting there with no force: a rattler
    keys, rattler, fixed = interior_point_prediction(pi, pj, n, dim, sigma2, duals, slack, s, col_dual, s_bound,
                                                     pinned=1)
    assert not rattler[0] and fixed[0, 2] == 1
    assert np.count_nonzero(fixed) == 1  # not the rattler
    assert rattler[9] and not np.any(rattler[:9])
    # the square system: d (N_s - 1) + 1 unknowns, of which the held component's bound row is one
    assert keys.size == dim * (9 - 1) + 1 - 1


def test_a_dual_pivot_at_a_degenerate_vertex_takes_the_largest_alpha_of_the_zero_duals():
    """Dual simplex at a degenerate vertex: rows whose duals are 0 can all leave at a step of 0. One whose dual
    round-off made -1e-18 used to come first whatever its alpha, and a tiny alpha made the new basis singular (LP 23
    of the N = 10^4 sigma = 0.3 LS output, docs/calippso.md §5.4). Harris's ratio test takes the largest alpha
    among them."""
    from scipy.sparse import csr_matrix

    from spherejam.calippso.active_set import BasisInverse, _dual_pivot

    violated = [1.0, 2e-9, 1.0]  # alpha = B^-T a_r = a_r with B = I
    binv = BasisInverse(csr_matrix(np.vstack([np.eye(3), violated])), np.arange(3))
    lam = np.array([0.5, -1e-18, 0.0])  # the second and third duals are 0, the second to round-off
    _dual_pivot(binv, binv.matrix, 3, lam, 0, 3)
    assert binv.basis.tolist() == [0, 1, 3]  # the third row left (alpha 1), not the second (alpha 2e-9)
