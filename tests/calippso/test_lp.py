"""One LP solved by HiGHS (calippso/lp.py): infeasible LPs, warm starts, HiPO, IPX and simplex, the certified
vertex instead of crossover, the row check of a vertex."""

import math

import numpy as np
import pytest

from spherejam.calippso.constraints import pair_vectors, pairs_in_cutoff
from spherejam.calippso.lp import solve_lp
from spherejam.calippso.run import run_calippso
from spherejam.core.errors import InputError, SimulationError

from certificate import assert_jammed
from packings import fcc_packing


def test_infeasible_lp_is_reported():
    # an overlapping pair with no room to move: Gamma >= 1 cannot be reached
    rij = np.array([[0.9, 0.0, 0.0]])
    with pytest.raises(SimulationError, match="Infeasible"):
        solve_lp(rij, np.array([1.0]), np.array([0]), np.array([1]), 2, s_bound=1e-3, pinned=1,
                 inflation_bounds=(1.0, 4.0))


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


def test_hipo_is_given_the_augmented_system(tmp_path, ls_jammed_256):
    """Gamma's column has an entry in every row, so HiPO's normal equations are dense; asked to choose, its analysis
    tries them first and fails, which was 13 of 73 CPU-s of an LP at N = 1e4 (docs/calippso.md §5.1). HiGHS's log of
    one solve says the augmented system was requested, where left to choose it fails on the normal equations first,
    and the vertex is the same; a user's own hipo_system still wins. (HiPO writes its analysis to the log file only
    while it also logs to the console, which pytest captures.)"""
    rij, sigma2, i, j = force_lp(ls_jammed_256)
    solutions = {}
    for system, newton in ((None, "AS requested"), ("choose", "AS preferred (NE failed)")):
        log = tmp_path / f"{system}.log"
        extra = {} if system is None else {"hipo_system": system}
        solutions[system] = solve_lp(rij, sigma2, i, j, 256, s_bound=0.5, pinned=0,
                                     inflation_bounds=(-math.inf, math.inf), solver="hipo", crossover=False,
                                     options={"output_flag": True, "log_to_console": True, "log_file": str(log),
                                              **extra})
        lines = [line.split(":", 1)[1].strip() for line in log.read_text().splitlines()
                 if line.startswith("Newton system")]
        assert lines == [newton], lines
    assert solutions[None].method == solutions["choose"].method and solutions[None].method.startswith("vertex")
    assert solutions[None].inflation == pytest.approx(solutions["choose"].inflation, rel=1e-12)
    duals = solutions[None].duals
    np.testing.assert_allclose(duals, solutions["choose"].duals, atol=1e-9 * duals.max())


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


def test_an_uncertified_vertex_steps_from_its_interior_point_unless_the_lp_may_be_the_last(monkeypatch,
                                                                                           ls_jammed_256):
    """From N = PREDICTED_MAX_N on (set at this packing's N, so that the test takes seconds) an uncertified vertex
    (forced: the active-set solve refuses every prediction) would fall back to a second interior point with
    crossover. It steps from its own interior point instead, unless that point's sqrt(Gamma) - 1 is within
    LAST_LP_MARGIN of the convergence tolerance: only such an LP can be the run's last, and its test needs the
    crossover's vertex. So exactly the LPs that gained more are interior steps, whatever the LP before gained, and
    the run ends on a valid certificate (docs/calippso.md §5.2). The rule used to be the previous LP's gain, which
    sent LPs that could not converge to crossovers of 400-1200 CPU-s at N = 1e4."""
    import spherejam.calippso.lp as lp
    from spherejam.calippso.run import LAST_LP_MARGIN
    from spherejam.calippso.solution import METHOD_CODES

    monkeypatch.setattr(lp, "solve_active_set", lambda *args, **kwargs: None)
    monkeypatch.setattr(lp, "PREDICTED_MAX_N", ls_jammed_256.n)
    tolerance = 1e-12
    new = run_calippso(ls_jammed_256, solver="hipo", crossover=False, warm_start=False, active_set=False,
                       inflation_tolerance=tolerance)
    methods = new.history["method"]
    assert set(methods.tolist()) == {METHOD_CODES["interior"], METHOD_CODES["ipm"]}
    gained = new.history["sqrt_inflation_minus_1"]
    np.testing.assert_array_equal(methods == METHOD_CODES["interior"], gained > LAST_LP_MARGIN * tolerance)
    assert new.stop_reason == "converged" and methods[-1] == METHOD_CODES["ipm"]
    assert_jammed(new, 3)


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


@pytest.mark.parametrize("solver", ["hipo", "ipx"])
def test_interior_step_keeps_every_row(ls_jammed_256, solver):
    """An intermediate step taken from the interior point (docs §10): no vertex, but every row and bound holds (to
    the solver tolerance), Gamma is the LP's optimum to 1e-9, and the step it gives, applied to the packing, leaves
    no overlap beyond round-off. A regime-3 LP with a loose bound, so the step moves particles."""
    from spherejam.calippso.constraints import row_excess
    from spherejam.core.packing import Packing

    p = ls_jammed_256
    x, box, dia = p.positions, p.box, p.diameters
    i, j, _ = pairs_in_cutoff(x, box, 1.35 * dia.max())
    rij, sigma2 = pair_vectors(x, box, i, j), (0.5 * (dia[i] + dia[j])) ** 2
    kw = dict(s_bound=0.05 * dia.max(), pinned=0, inflation_bounds=(1.0, 1.1), solver=solver)
    step = solve_lp(rij, sigma2, i, j, 256, **kw, interior=True)
    vertex = solve_lp(rij, sigma2, i, j, 256, **kw)
    assert step.method == "interior" and step.basis is None and step.solver == solver
    assert row_excess(rij, sigma2, i, j, step.s, step.inflation) <= 1e-8
    assert np.max(np.abs(step.s)) <= kw["s_bound"] * (1 + 1e-9) and step.inflation >= 1.0
    assert step.inflation == pytest.approx(vertex.inflation, rel=1e-9)
    assert np.max(np.abs(step.s)) > 1e-6  # it moved
    moved = Packing(np.mod(x + step.s, box), dia * math.sqrt(step.inflation), box)
    assert moved.check(1e-8).ok


def test_interior_steps_end_on_a_vertex_and_certify(ls_jammed_256):
    """With interior steps the run still converges on vertices under the unchanged criteria, with a valid
    certificate; intermediate LPs are interior points."""
    from spherejam.calippso.solution import METHOD_CODES

    result = run_calippso(ls_jammed_256, interior_steps=True)
    assert_jammed(result, 3)
    methods = result.history["method"]
    assert np.any(methods == METHOD_CODES["interior"]) and methods[-1] != METHOD_CODES["interior"]
    assert result.packing.metadata["parameters"]["interior_steps"] is True


def test_the_default_takes_interior_steps_from_its_n_on_and_certifies(ls_jammed_256, monkeypatch):
    """The one rule by N (core.calippso_path): with the threshold set at this packing's N (256, so that the test
    takes seconds), the default run takes interior steps and ends on a valid certificate; just above it, every LP is a
    vertex; an explicit choice wins either way; the parameters record the path that ran (docs §10.11)."""
    from spherejam.calippso.solution import METHOD_CODES
    from spherejam.core import calippso_path

    monkeypatch.setattr(calippso_path, "INTERIOR_STEPS_MIN_N", None)  # unset: never by default, only when asked
    assert not calippso_path.interior_steps_at(10**6) and calippso_path.interior_steps_at(2, True)
    monkeypatch.setattr(calippso_path, "INTERIOR_STEPS_MIN_N", 4096)
    assert calippso_path.interior_steps_at(4096) and not calippso_path.interior_steps_at(4095)
    assert not calippso_path.interior_steps_at(10**6, False) and calippso_path.interior_steps_at(2, True)
    interior = METHOD_CODES["interior"]
    monkeypatch.setattr(calippso_path, "INTERIOR_STEPS_MIN_N", ls_jammed_256.n)
    at = run_calippso(ls_jammed_256)
    assert_jammed(at, 3)
    assert np.any(at.history["method"] == interior) and at.history["method"][-1] != interior
    assert at.packing.metadata["parameters"]["interior_steps"] is True
    # the LPs up to the first interior step: the vertices before it are the vertex path's own, so the vertex path
    # reaches the same LP with the same sqrt(Gamma_prev) - 1 above the interior-step threshold
    k = int(np.argmax(at.history["method"] == interior)) + 1
    monkeypatch.setattr(calippso_path, "INTERIOR_STEPS_MIN_N", ls_jammed_256.n + 1)
    below = run_calippso(ls_jammed_256, max_iterations=k)
    assert below.iterations == k and not np.any(below.history["method"] == interior)
    assert below.packing.metadata["parameters"]["interior_steps"] is False
    forced = run_calippso(ls_jammed_256, max_iterations=k, interior_steps=True)
    assert forced.history["method"][k - 1] == interior


def test_a_checkpoint_resumes_with_other_trajectory_settings(ls_jammed_256, tmp_path):
    """A run checkpointed on the default path resumes with interior steps (a trajectory setting, docs §10.6): the
    change is recorded with the LP it starts at, the later LPs take the new path, and the certificate is valid; a
    change of a convergence criterion is still refused."""
    from spherejam.calippso.solution import METHOD_CODES
    from spherejam.core.errors import PackingFileError

    ckpt = tmp_path / "c.h5"
    part = run_calippso(ls_jammed_256, max_iterations=1, checkpoint=ckpt, checkpoint_interval=0)
    assert part.stop_reason == "max_iterations" and ckpt.exists()
    with pytest.raises(PackingFileError, match="different input or parameters"):
        run_calippso(ls_jammed_256, checkpoint=ckpt, interior_steps=True, inflation_tolerance=1e-11)
    done = run_calippso(ls_jammed_256, checkpoint=ckpt, interior_steps=True)
    assert_jammed(done, 3)
    methods = done.history["method"]
    assert methods[0] != METHOD_CODES["interior"] and methods[1] == METHOD_CODES["interior"]
    params = done.packing.metadata["parameters"]
    assert params["interior_steps"] is True
    assert params["trajectory_changes"] == [{"from_lp": 2, "interior_steps": True}]


@pytest.mark.parametrize("solver", ["ipx", "hipo"])
def test_an_lp_in_scaled_units_is_the_same_lp(ls_jammed_256, solver):
    """HiGHS gets a near-converged LP in Gamma - 1 and units of NEAR_CONVERGED_SCALE (docs/calippso.md §5.8): the
    solution mapped back is the unscaled LP's (Gamma to 1e-12, the same active rows, the same forces), and the
    certified vertex's check passes in the LP's own units."""
    from spherejam.calippso.lp import NEAR_CONVERGED_SCALE

    x, box = ls_jammed_256.positions, ls_jammed_256.box
    i, j, _ = pairs_in_cutoff(x, box, 1.35)
    rij, sigma2 = pair_vectors(x, box, i, j), (0.5 * (ls_jammed_256.diameters[i] + ls_jammed_256.diameters[j])) ** 2
    kw = dict(s_bound=5e-3, pinned=0, inflation_bounds=(1.0, 1.7), solver=solver, crossover=solver == "ipx")
    plain = solve_lp(rij, sigma2, i, j, 256, **kw)
    scaled = solve_lp(rij, sigma2, i, j, 256, **kw, scale=NEAR_CONVERGED_SCALE)
    assert scaled.method.startswith("vertex" if solver == "hipo" else "ipm")
    assert scaled.inflation == pytest.approx(plain.inflation, rel=0, abs=1e-12) and scaled.inflation > 1.0
    np.testing.assert_array_equal(scaled.duals > 0, plain.duals > 0)
    np.testing.assert_allclose(scaled.duals, plain.duals, rtol=1e-6, atol=1e-12)
    slack = np.einsum("ij,ij->i", rij, rij + 2.0 * (scaled.s[i] - scaled.s[j])) - scaled.inflation * sigma2
    assert slack.min() >= -1e-12


def test_near_converged_cold_lps_are_solved_scaled_and_certify(ls_jammed_256, monkeypatch):
    """With the scaled solves' threshold at this packing's N (4096 by default, where every LP is a cold solve), the
    LPs after one whose sqrt(Gamma) - 1 fell below SCALED_BELOW go to HiGHS scaled, the others unscaled, and the run
    ends on a valid certificate."""
    import spherejam.calippso.run as run_module
    from spherejam.calippso.lp import NEAR_CONVERGED_SCALE

    scales = []
    solve = run_module.solve_lp

    def recorded(*args, **kwargs):
        scales.append(kwargs.get("scale", 1.0))
        return solve(*args, **kwargs)

    monkeypatch.setattr(run_module, "solve_lp", recorded)
    monkeypatch.setattr(run_module, "SCALED_MIN_N", ls_jammed_256.n)
    result = run_calippso(ls_jammed_256, solver="hipo", warm_start=False, active_set=False)
    assert_jammed(result, 3)
    assert NEAR_CONVERGED_SCALE in scales and 1.0 in scales, scales
    previous = result.history["sqrt_inflation_minus_1"][:-1]  # before LPs 2 on
    expected = [NEAR_CONVERGED_SCALE if g < run_module.SCALED_BELOW else 1.0 for g in previous]
    assert scales[1:result.iterations] == expected
