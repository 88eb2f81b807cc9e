"""CALiPPSO: LP rows, cutoff guards, jamming from crystals and random starts, forces, failures, CLI, fits."""

from __future__ import annotations

import itertools
import json
import math

import numpy as np
import pytest

from spherejam.calippso.constraints import constraint_rows, pair_vectors, pairs_in_cutoff
from spherejam.analysis.distributions import distributions, fit_cumulative_power_law
from spherejam.calippso.lp import solve_lp
from spherejam.calippso.run import run_calippso
from spherejam.calippso.schedule import cutoff_and_bound
from spherejam.core.errors import InputError, OverlapError, PackingFileError, SimulationError
from spherejam.core.packing import Packing, ball_volume


def rsa_packing(n: int, phi: float, dim: int, seed: int = 0, size_ratio: float = 1.0) -> Packing:
    """Random sequential addition up to packing fraction ``phi`` (overlap-free by construction).

    Half the spheres have diameter 1 and half ``size_ratio`` (a bidisperse mix keeps d = 2 from crystallising).
    The low-density start of the reference's random-init examples; brute force, fine for a few hundred spheres.
    """
    rng = np.random.default_rng(seed)
    dia = np.where(np.arange(n) % 2 == 0, 1.0, size_ratio)
    box = (float(np.sum(ball_volume(dia, dim))) / phi) ** (1.0 / dim)
    pts = np.empty((n, dim))
    k = 0
    while k < n:
        p = rng.random(dim) * box
        d = pts[:k] - p
        d -= box * np.round(d / box)
        if k == 0 or np.all(np.einsum("ij,ij->i", d, d) >= (0.5 * (dia[:k] + dia[k])) ** 2):
            pts[k] = p
            k += 1
    return Packing(pts, dia, box, {"algorithm": "rsa", "seed": seed})


def fcc_packing(cells: int) -> Packing:
    """Perfect FCC at close packing: 4 cells^3 unit spheres, lattice constant sqrt(2)."""
    a = math.sqrt(2.0)
    basis = np.array([[0, 0, 0], [0.5, 0.5, 0], [0.5, 0, 0.5], [0, 0.5, 0.5]])
    cells_xyz = np.array(list(itertools.product(range(cells), repeat=3)), dtype=float)
    pos = (cells_xyz[:, None, :] + basis[None, :, :]).reshape(-1, 3) * a
    return Packing(pos, np.ones(len(pos)), cells * a)


def assert_jammed(result, dim):
    assert result.completed
    assert result.isostatic, (result.n_contacts, result.n_stable)
    assert result.n_contacts == dim * (result.n_stable - 1) + 1
    assert result.force_balance_residual <= 1e-10
    assert result.packing.check(1e-10).ok
    assert result.packing.min_gap() > -1e-12
    assert np.all(result.forces > 0)
    assert result.history["sqrt_inflation_minus_1"][-1] <= 1e-12
    assert result.history["max_displacement"][-1] <= 1e-9


# --- LP rows ----------------------------------------------------------------------------------------------------


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


@pytest.mark.parametrize("dim", [2, 3, 4, 5])
def test_cutoff_and_bound_guards(dim):
    box = 12.0
    for sg in (1.0, 1.000001, 1.0001, 1.01, 1.3, 2.0):
        for radius in (0.5, 0.7, 1.0):
            ell, sb, gmax, regime = cutoff_and_bound(sg, radius, 2.0, dim, box)
            assert sb > 0 and ell <= box and gmax > 1.0
            # a pair outside the cutoff cannot reach the inflated contact distance
            assert ell - 2 * math.sqrt(dim) * sb >= 2 * radius * math.sqrt(gmax) - 1e-12
            assert regime == (1 if sg - 1 > 5e-4 else 2 if sg - 1 > 1e-5 else 3)
    with pytest.raises(InputError, match="box"):  # a sphere as wide as the box overlaps its own image
        cutoff_and_bound(1.0, 0.5, 2.0, 3, 1.0)


# --- jamming ------------------------------------------------------------------------------------------------------


def test_fcc_is_jammed_at_once():
    fcc = fcc_packing(3)
    result = run_calippso(fcc)
    assert result.iterations == 1 and result.completed
    assert result.history["sqrt_inflation_minus_1"][0] < 1e-12
    assert result.history["max_displacement_all"][0] < 1e-9
    assert result.packing.phi == pytest.approx(math.pi / math.sqrt(18), abs=1e-12)
    assert result.packing.check(1e-10).ok
    # FCC is hyperstatic with a degenerate dual: do not test contacts or rattlers


def test_random_d3_n256_from_phi_03_jams_isostatic():
    start = rsa_packing(256, 0.3, 3, seed=1)
    result = run_calippso(start)
    assert_jammed(result, 3)
    assert 0.62 < result.phi < 0.645
    assert result.n_rattlers / 256 < 0.05
    s = result.summary()
    assert s["is_isostatic"] == 1.0 and s["delta_phi"] == pytest.approx(result.phi - 0.3)
    assert result.packing.metadata["algorithm"] == "calippso"
    # contact forces balance on every stable particle and sum_ij f_ij n_ij = 0 overall
    f = result.forces[:, None] * result.contact_vectors
    net = np.zeros((256, 3))
    np.add.at(net, result.pairs[:, 0], f)
    np.add.at(net, result.pairs[:, 1], -f)
    assert np.max(np.abs(net)) < 1e-9
    # gaps are of non-contacts, positive, and the fit helpers return finite numbers
    assert np.all(result.gaps > 0)
    assert math.isfinite(distributions(result)["gap_gamma"])
    # without the active-set shortcut (HiGHS only) the same packing comes out
    again = run_calippso(start, active_set=False, max_iterations=result.iterations + 20)
    assert again.phi == pytest.approx(result.phi, abs=1e-9)


@pytest.mark.parametrize("dim,n,phi0,ratio", [(2, 128, 0.5, 1.4), (4, 128, 0.2, 1.0)])
def test_other_dimensions_converge(dim, n, phi0, ratio):
    result = run_calippso(rsa_packing(n, phi0, dim, seed=3, size_ratio=ratio))
    assert result.completed
    assert result.packing.check(1e-10).ok
    assert result.force_balance_residual <= 1e-10
    if dim >= 3:
        assert result.isostatic
    assert result.phi > phi0


# --- failures -----------------------------------------------------------------------------------------------------


def test_overlapping_start_is_rejected():
    p = rsa_packing(64, 0.3, 3, seed=0)
    bad = p.replace(diameters=p.diameters * 1.5)
    with pytest.raises(OverlapError, match="CALiPPSO input"):
        run_calippso(bad)


def test_failed_lp_raises_clear_error():
    start = rsa_packing(64, 0.3, 3, seed=0)
    with pytest.raises(SimulationError, match="LP failed at iteration 0"):
        run_calippso(start, solver_options={"ipm_iteration_limit": 1, "simplex_iteration_limit": 1})


def test_infeasible_lp_is_reported():
    # an overlapping pair with no room to move: Gamma >= 1 cannot be reached
    rij = np.array([[0.9, 0.0, 0.0]])
    with pytest.raises(SimulationError, match="Infeasible"):
        solve_lp(rij, np.array([1.0]), np.array([0]), np.array([1]), 2, s_bound=1e-3, pinned=1,
                 inflation_bounds=(1.0, 4.0))


def test_bad_parameters_name_the_field():
    p = fcc_packing(3)
    with pytest.raises(InputError, match="inflation_tolerance"):
        run_calippso(p, inflation_tolerance=-1.0)
    with pytest.raises(InputError, match="s_bound"):
        run_calippso(p, s_bound=2.0)


# --- resume, CLI, fits --------------------------------------------------------------------------------------------


def test_checkpoint_resume_reaches_the_same_packing(tmp_path):
    """A run stopped at max_iterations and resumed from its checkpoint takes the uninterrupted run's path: the same
    positions, diameters, contacts, forces and per-LP history, bit for bit; another input or parameters are refused."""
    start = rsa_packing(96, 0.35, 3, seed=5)
    ref = run_calippso(start)
    ckpt = tmp_path / "c.h5"
    # stopped in regime 2 (warm starts, bound escalation): all of the loop state must come back
    part = run_calippso(start, max_iterations=20, checkpoint=ckpt, checkpoint_interval=0)
    assert part.stop_reason == "max_iterations" and not part.completed and ckpt.exists()
    assert part.summary()["converged"] == 0.0 and part.counters["converged"] is False
    with pytest.raises(PackingFileError, match="different input or parameters"):
        run_calippso(start, checkpoint=ckpt, zero_force=1e-9)
    done = run_calippso(start, checkpoint=ckpt, threads=1)
    assert done.stop_reason == "converged" and done.completed and not ckpt.exists()
    assert done.summary()["converged"] == 1.0 and done.counters["stop_reason"] == "converged"
    assert done.iterations == ref.iterations > 20
    for name in ("positions", "diameters"):
        np.testing.assert_array_equal(getattr(done.packing, name), getattr(ref.packing, name))
    np.testing.assert_array_equal(done.pairs, ref.pairs)
    np.testing.assert_array_equal(done.forces, ref.forces)
    assert set(done.history) == set(ref.history)
    for key in set(ref.history) - {"solve_time", "cpu_time"}:
        np.testing.assert_array_equal(done.history[key], ref.history[key], err_msg=key)


def test_cli_calippso(tmp_path, capsys):
    from spherejam.cli import main
    from spherejam.core.packing_io import read_packing, write_packing

    src, out = tmp_path / "in.h5", tmp_path / "out.h5"
    write_packing(src, rsa_packing(96, 0.35, 3, seed=5))
    assert main(["calippso", str(src), "-o", str(out), "--json"]) == 0
    summary = json.loads(capsys.readouterr().out)
    assert summary["is_isostatic"] == 1.0
    jammed = read_packing(out)
    assert jammed.metadata["algorithm"] == "calippso"
    assert jammed.phi == pytest.approx(summary["phi"])
    assert jammed.metadata["parameters"]["constraint_generation"] is False
    out2 = tmp_path / "out2.h5"
    assert main(["calippso", str(src), "-o", str(out2), "--json", "--constraint-generation"]) == 0
    assert json.loads(capsys.readouterr().out)["is_isostatic"] == 1.0
    assert read_packing(out2).metadata["parameters"]["constraint_generation"] is True


def test_power_law_fit_recovers_exponent():
    rng = np.random.default_rng(0)
    a_true = 0.6  # cumulative ~ x^0.6, i.e. gap exponent gamma = 0.4
    x = rng.random(20000) ** (1 / a_true) * 1e-2
    a, se, k = fit_cumulative_power_law(x, 1e-6, 1e-2)
    assert abs(a - a_true) < 4 * se and se < 0.02
    assert k == np.count_nonzero(x >= 1e-6)


def test_mls_output_is_certified():
    """An MLS output (closest jammed state) is already jammed: CALiPPSO moves phi by <= 1e-4, isostatic."""
    cj = pytest.importorskip("spherejam.engines.closest_jamming")
    from spherejam.core.seeding import poisson_packing

    mls = cj.find_closest_jamming(poisson_packing(64, 0.0, 2, dim=3), progress_interval=1e9)
    result = run_calippso(mls.packing)
    assert result.completed and result.isostatic
    assert abs(result.phi - mls.packing.phi) <= 1e-4
    assert result.force_balance_residual <= 1e-10


def test_warm_started_lp_matches_cold_solve():
    """Primal simplex from the previous LP's basis reaches the same optimum as interior point from scratch, also
    when an active row of the previous LP is missing (the alien basis is repaired) and rows are new."""
    rng = np.random.default_rng(7)
    fcc = fcc_packing(3)
    x = np.mod(fcc.positions + rng.uniform(-0.01, 0.01, fcc.positions.shape), fcc.box)
    n, box = fcc.n, fcc.box
    kw = dict(s_bound=0.05, pinned=0, inflation_bounds=(1.0, 1.2))

    def rows(pos, drop=None):
        i, j, _ = pairs_in_cutoff(pos, box, 1.35)
        if drop is not None:
            keep = (i * n + j) != drop
            i, j = i[keep], j[keep]
        return pair_vectors(pos, box, i, j), np.full(len(i), 0.97**2), i, j

    first = solve_lp(*rows(x), n, **kw)
    assert first.method == "ipm" and first.basis is not None
    x2 = np.mod(x + 0.5 * first.s, box)
    active = np.flatnonzero(first.duals > 0)
    i, j = rows(x)[2:]
    dropped = int(i[active[0]] * n + j[active[0]])
    for drop in (None, dropped):
        r2, s2, i2, j2 = rows(x2, drop)
        cold = solve_lp(r2, s2, i2, j2, n, **kw)
        warm = solve_lp(r2, s2, i2, j2, n, **kw, warm=first.basis)
        assert cold.method == "ipm" and warm.method == "warm"
        assert warm.inflation == pytest.approx(cold.inflation, abs=1e-12)
        # KKT of the warm vertex (to the 1e-9 solver tolerance): sum lambda sigma^2 = 1, force balance where no s
        # bound is active
        assert np.sum(warm.duals * s2) == pytest.approx(1.0, abs=1e-8)
        net = np.zeros((n, 3))
        np.add.at(net, i2, warm.duals[:, None] * r2)
        np.add.at(net, j2, -warm.duals[:, None] * r2)
        free = np.all(np.abs(warm.s) < 0.05 * (1 - 1e-9), axis=1)
        free[0] = False
        mean_force = np.mean(warm.duals[warm.duals > 0] * np.linalg.norm(r2[warm.duals > 0], axis=1))
        assert np.max(np.abs(net[free])) < 1e-6 * mean_force


def test_failed_warm_starts_back_off_and_fall_back_to_interior_point():
    """A warm start that runs out of pivots falls back to interior point (same optimum); after k failures in a
    row the next 2^k - 1 LPs skip it, so an LP that never warm-starts well costs O(log) wasted attempts."""
    from spherejam.core.seeding import poisson_packing
    from spherejam.engines.lubachevsky_stillinger import run_ls

    start = run_ls(poisson_packing(128, 0.0, 3), 1e-2, p_max=1e5, seed=3, progress_interval=1e9).packing
    normal = run_calippso(start)
    starved = run_calippso(start, solver_options={"simplex_iteration_limit": 1})
    for result in (normal, starved):
        assert result.completed and result.isostatic
        assert result.force_balance_residual <= 1e-10
    later = starved.iterations - 1  # LPs after the first, all in regime 2-3 from this start
    assert np.all(starved.history["regime"][1:] > 1)
    assert 1 <= starved.counters["warm_attempts"] <= 1 + math.log2(later)
    assert normal.counters["warm_attempts"] >= normal.iterations // 2
    assert abs(starved.phi - normal.phi) < 1e-6


# --- HiGHS solvers: HiPO, IPX, simplex; vertex certification instead of crossover -----------------------------------


@pytest.fixture(scope="module")
def ls_jammed_256():
    """An LS packing compressed to p = 1e12 (jammed at that pressure): CALiPPSO certifies it in a few LPs."""
    from spherejam.core.seeding import poisson_packing
    from spherejam.engines.lubachevsky_stillinger import run_ls

    # rate 1e-3: glassy (phi 0.6487, 12 rattlers); faster LS starts creep, and degenerate LPs let paths diverge
    return run_ls(poisson_packing(256, 0.0, 1), 1e-3, p_max=1e12, seed=1, progress_interval=1e9).packing


def force_lp(packing):
    """The final (force) LP of a packing: rows within 2.7 radii, s bounded by R only, Gamma free."""
    x, box = packing.positions, packing.box
    i, j, _ = pairs_in_cutoff(x, box, 1.35)
    return pair_vectors(x, box, i, j), (0.5 * (packing.diameters[i] + packing.diameters[j])) ** 2, i, j


def test_hipo_is_available_and_really_runs(tmp_path, ls_jammed_256):
    """HiPO needs highspy-extras; without it HiGHS rejects solver='hipo' (while 'ipm' silently stays IPX). The
    HiGHS log proves which interior point ran."""
    import highspy

    assert highspy.Highs().setOptionValue("solver", "hipo") == highspy.HighsStatus.kOk
    rij, sigma2, i, j = force_lp(ls_jammed_256)
    for solver, mark in (("hipo", "Hipo: "), ("ipx", "Ipx: IPM")):
        log = tmp_path / f"{solver}.log"
        sol = solve_lp(rij, sigma2, i, j, 256, s_bound=0.5, pinned=0, inflation_bounds=(-math.inf, math.inf),
                       solver=solver, options={"output_flag": True, "log_to_console": False, "log_file": str(log)})
        assert sol.solver == solver and sol.method == "ipm"
        text = log.read_text()
        assert mark in text and ("Ipx: IPM" not in text if solver == "hipo" else "Hipo: " not in text)
    with pytest.raises(InputError, match="solver"):
        run_calippso(ls_jammed_256, solver="gurobi")


@pytest.mark.parametrize("solver", ["hipo", "ipx"])
def test_certified_vertex_equals_crossover(ls_jammed_256, solver):
    """The interior point's near-active rows, certified by the active-set solve, give the vertex crossover gives:
    the same active rows, Gamma and duals (the vertex of a jammed packing's force LP is unique)."""
    rij, sigma2, i, j = force_lp(ls_jammed_256)
    kw = dict(s_bound=0.5, pinned=0, inflation_bounds=(-math.inf, math.inf), solver=solver)
    crossed = solve_lp(rij, sigma2, i, j, 256, **kw)
    vertex = solve_lp(rij, sigma2, i, j, 256, **kw, crossover=False)
    assert crossed.method == "ipm" and vertex.method.startswith("vertex") and vertex.solver == solver
    np.testing.assert_array_equal(vertex.duals > 0, crossed.duals > 0)
    assert vertex.inflation == pytest.approx(crossed.inflation, abs=1e-12)
    np.testing.assert_allclose(vertex.duals, crossed.duals, rtol=1e-6, atol=1e-12)
    # the certified vertex carries a HiGHS basis: the next LP can warm-start from it
    assert vertex.basis is not None and np.count_nonzero(vertex.basis.rows != 1) == np.count_nonzero(vertex.duals)


def test_new_path_agrees_with_ipx_crossover(ls_jammed_256):
    """HiPO + certified vertices (the default from N = 4096 on) and IPX + crossover (the default below) certify the
    same jammed state: the same contact network and rattlers, force balance <= 1e-10; every LP's solver is recorded."""
    from spherejam.calippso.solution import SOLVER_CODES

    old = run_calippso(ls_jammed_256)  # solver="auto" at N = 256: IPX + crossover
    assert old.packing.metadata["parameters"]["solver"] == "ipx"
    new = run_calippso(ls_jammed_256, solver="hipo")
    cold = run_calippso(ls_jammed_256, solver="hipo", warm_start=False, active_set=False)  # every LP: HiPO + vertex
    assert old.packing.metadata["parameters"]["crossover"] is True
    assert "vertex" not in old.counters["lp_methods"] and SOLVER_CODES["hipo"] not in old.history["solver"]
    assert cold.counters["lp_methods"].get("vertex", 0) >= cold.iterations
    for result in (old, new, cold):
        assert_jammed(result, 3)
        assert {tuple(p) for p in result.pairs.tolist()} == {tuple(p) for p in old.pairs.tolist()}
        np.testing.assert_array_equal(result.rattlers, old.rattlers)
        assert result.phi == pytest.approx(old.phi, abs=1e-10)
        np.testing.assert_allclose(np.sort(result.forces), np.sort(old.forces), rtol=1e-5)
    for result in (new, cold):
        assert result.packing.metadata["parameters"]["solver"] == "hipo"
        assert SOLVER_CODES["hipo"] in result.history["solver"]
        assert sum(result.counters["lp_solvers"].values()) == result.iterations + 1  # incl. the force LP
        assert np.all(result.history["cpu_time"] >= 0)


def test_uncertified_vertex_falls_back_to_simplex_from_its_basis(monkeypatch, ls_jammed_256):
    """When the interior point's vertex is not certified (forced here: the active-set solve refuses every
    prediction), primal simplex from the predicted basis solves the LP instead of a second interior point, and the
    run certifies the same jammed state as IPX + crossover: same contacts and rattlers, force balance <= 1e-10."""
    import spherejam.calippso.lp as lp
    from spherejam.calippso.solution import METHOD_CODES

    old = run_calippso(ls_jammed_256, solver="ipx", crossover=True)
    monkeypatch.setattr(lp, "solve_active_set", lambda *args, **kwargs: None)
    starts, warm_basis = [], lp._warm_basis
    monkeypatch.setattr(lp, "_warm_basis", lambda start, *args: starts.append(start) or warm_basis(start, *args))
    new = run_calippso(ls_jammed_256, solver="hipo", crossover=False, warm_start=False, active_set=False)
    methods = new.history["method"]
    assert np.all(methods == METHOD_CODES["predicted"]) and new.counters["lp_methods"] == {
        "predicted": new.iterations + 1}
    assert len(starts) == new.iterations + 1  # every LP started from its predicted basis, none re-solved
    assert_jammed(new, 3)
    assert {tuple(p) for p in new.pairs.tolist()} == {tuple(p) for p in old.pairs.tolist()}
    np.testing.assert_array_equal(new.rattlers, old.rattlers)
    assert max(new.force_balance_residual, old.force_balance_residual) <= 1e-10
    assert new.phi == pytest.approx(old.phi, abs=1e-10)
    np.testing.assert_allclose(np.sort(new.forces), np.sort(old.forces), rtol=1e-5)


def test_cli_solver_choice_is_recorded(tmp_path, capsys, ls_jammed_256):
    from spherejam.calippso.lp import SOLVERS
    from spherejam.calippso.solution import SOLVER_CODES
    from spherejam.cli import build_parser, main
    from spherejam.core.packing_io import read_packing, write_packing

    src, out = tmp_path / "in.h5", tmp_path / "out.h5"
    write_packing(src, ls_jammed_256)
    assert main(["calippso", str(src), "-o", str(out), "--solver", "ipx", "--crossover", "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["is_isostatic"] == 1.0
    parameters = read_packing(out).metadata["parameters"]
    assert parameters["solver"] == "ipx" and parameters["crossover"] is True and parameters["threads"] == 1
    assert main(["calippso", str(src), "-o", str(out), "--solver", "gurobi"]) == 2
    assert "--solver" in capsys.readouterr().err
    # the CLI's choices (not imported from calippso, to keep --help fast) are the solver list
    action = next(a for a in build_parser()._subparsers._group_actions[0].choices["calippso"]._actions
                  if a.dest == "solver")
    assert tuple(action.choices) == ("auto", *SOLVERS)
    assert set(SOLVER_CODES) == {"none", *SOLVERS}


@pytest.mark.parametrize("bad", [0, 2.5, 257, "two"])
def test_threads_config_key_is_validated(bad):
    """calippso.threads reaches the rule (``--threads``, the rule's cores, cpus_per_task); a bad value is one line
    naming calippso.threads, from the schema and from check_config alike."""
    from pathlib import Path

    import yaml

    from spherejam.workflow.config import check_config, validate_config
    from spherejam.workflow.cost_model import cpus_per_task, job_resources
    from spherejam.workflow.experiment import Experiment

    root = Path(__file__).resolve().parents[1]
    config = yaml.safe_load((root / "config" / "tiny.yaml").read_text())
    config["calippso"]["threads"] = 2
    exp = Experiment(validate_config(config, root / "config" / "schema.yaml"))
    assert exp.calippso_threads == 2
    assert job_resources("calippso", exp.largest_n, threads=exp.calippso_threads)["cpus_per_task"] == 2
    assert cpus_per_task("mls") == 1 and cpus_per_task("calippso") == 1
    config["calippso"]["threads"] = bad
    for check in (lambda c: validate_config(c, root / "config" / "schema.yaml"), check_config):
        with pytest.raises(InputError, match=r"calippso\.threads=") as info:
            check(config)
        assert "\n" not in str(info.value)
    with pytest.raises(InputError, match=r"calippso\.threads="):
        cpus_per_task("calippso", bad)


def test_row_check_is_relative_to_the_pairs_sigma2():
    # Two pairs, each exceeding its row by the same absolute e = 6.5e-9 (the reproduction run's case): for the pair of
    # small spheres (sigma^2 = 0.13) that overlaps the step by ~2.5e-8, beyond the step's overlap guard, so the check
    # must reject it; the pair of large spheres (sigma^2 = 1) overlaps by ~3e-9 and passes.
    from spherejam.calippso.constraints import row_excess
    from spherejam.calippso.lp import _vertex_problem

    e = 6.5e-9
    n = 2
    for sigma2, rejected in ((0.13, True), (1.0, False)):
        rij = np.array([[math.sqrt(sigma2), 0.0, 0.0]])  # touching pair at s = 0, Gamma = 1: the row holds exactly
        pi, pj = np.array([0]), np.array([1])
        s = np.zeros((n, 3))
        inflation = 1.0 + e / sigma2  # sigma2 * Gamma exceeds |r|^2 by e
        assert row_excess(rij, sigma2 * np.ones(1), pi, pj, s, inflation) == pytest.approx(e / sigma2, rel=1e-6)
        problem = _vertex_problem(rij, sigma2 * np.ones(1), pi, pj, s, inflation, np.zeros(1), -np.ones((n, 3)),
                                  np.ones((n, 3)), 1e-9)
        assert (problem is not None and "row" in problem) is rejected
        h = math.sqrt(1.0 / inflation) - 1.0  # the step's relative overlap of that pair
        assert (-h > 1e-8) is rejected


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


# --- constraint generation (docs/calippso.md §5.7) -------------------------------------------------------------------


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
