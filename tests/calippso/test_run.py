"""The CALiPPSO driver (calippso/run.py): jamming from crystals and random starts, failures, bad parameters,
checkpoints, MLS outputs certified, warm starts that back off."""

import math

import numpy as np
import pytest

from spherejam.analysis.distributions import distributions
from spherejam.calippso.run import run_calippso
from spherejam.core.errors import InputError, OverlapError, PackingFileError, SimulationError

from certificate import assert_jammed
from packings import fcc_packing, rsa_packing


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


def test_overlapping_start_is_rejected():
    p = rsa_packing(64, 0.3, 3, seed=0)
    bad = p.replace(diameters=p.diameters * 1.5)
    with pytest.raises(OverlapError, match="CALiPPSO input"):
        run_calippso(bad)


def test_failed_lp_raises_clear_error():
    start = rsa_packing(64, 0.3, 3, seed=0)
    with pytest.raises(SimulationError, match="LP failed at iteration 0"):
        run_calippso(start, solver_options={"ipm_iteration_limit": 1, "simplex_iteration_limit": 1})


def test_bad_parameters_name_the_field():
    p = fcc_packing(3)
    with pytest.raises(InputError, match="inflation_tolerance"):
        run_calippso(p, inflation_tolerance=-1.0)
    with pytest.raises(InputError, match="s_bound"):
        run_calippso(p, s_bound=2.0)


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
    for key in set(ref.history) - {"solve_time", "cpu_time", "iteration_cpu_time", "iteration_wall_time"}:
        np.testing.assert_array_equal(done.history[key], ref.history[key], err_msg=key)


def test_mls_output_is_certified():
    """An MLS output (closest jammed state) is already jammed: CALiPPSO moves phi by <= 1e-4, isostatic."""
    cj = pytest.importorskip("spherejam.engines.closest_jamming")
    from spherejam.core.seeding import poisson_packing

    mls = cj.find_closest_jamming(poisson_packing(64, 0.0, 2, dim=3), progress_interval=1e9)
    result = run_calippso(mls.packing)
    assert result.completed and result.isostatic
    assert abs(result.phi - mls.packing.phi) <= 1e-4
    assert result.force_balance_residual <= 1e-10


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


def test_reference_schedule_takes_a_loose_first_lp_and_certifies(tmp_path):
    """The reference's schedule (docs §10): from an LS start at p = 1e5, where the adaptive schedule starts in regime 3
    (gaps ~1e-5), the first LP is regime 1 with the loose bound (l0/2 - 1.5 R)/sqrt(d) and its step moves stable
    particles farther than any regime-3 LP may; later bounds are the regimes' own (no widening); the certificate is
    valid under the unchanged criteria. The per-LP CSV has one row per LP with the history's values."""
    import csv

    from spherejam.core.seeding import poisson_packing
    from spherejam.engines.lubachevsky_stillinger import run_ls

    start = run_ls(poisson_packing(128, 0.0, 3), 1e-2, p_max=1e5, seed=3, progress_interval=1e9).packing
    adaptive = run_calippso(start)
    assert adaptive.history["regime"][0] == 3
    log = tmp_path / "lps.csv"
    ref = run_calippso(start, schedule="reference", lp_log=log)
    assert_jammed(ref, 3)
    h = ref.history
    assert h["regime"][0] == 1 and ref.packing.metadata["parameters"]["initial_sqrt_inflation"] == 1.01
    # s_bound in units of the largest diameter after the step: (2R - 1.5R)/sqrt(3) = 0.144 D, shrunk by sqrt(Gamma)
    assert h["s_bound"][0] == pytest.approx(0.25 / math.sqrt(3), rel=1e-3)
    assert h["max_displacement"][0] > 2 * 0.005  # beyond the regime-3 bound of 0.005 D: the loose step was taken
    later = h["regime"][1:]
    own = np.where(later == 2, 0.05, 0.005)
    np.testing.assert_allclose(h["s_bound"][1:], own, rtol=1e-4)  # never widened (D grew by sqrt(Gamma))
    with open(log, newline="") as fh:
        rows = list(csv.DictReader(fh))
    assert [int(r["lp"]) for r in rows] == list(range(1, ref.iterations + 1))
    assert [float(r["sqrt_gamma_minus_1"]) for r in rows] == h["sqrt_inflation_minus_1"].tolist()
    assert [int(r["contacts_gained"]) + int(r["contacts_lost"]) for r in rows[1:]] == h["contact_changes"][1:].tolist()
    assert rows[0]["contacts_gained"] == "-1" and rows[0]["method"] in ("ipm", "vertex", "simplex")


def test_the_trust_region_ties_s_bound_to_the_last_sqrt_gamma(ls_jammed_256):
    """schedule="trust" (docs/calippso.md §10.7): after an LP that stopped no stable sphere at its bound, the next
    regime-3 bound is TRUST_FACTOR sqrt(sqrt(Gamma_prev) - 1) R (the regime's bound where that is larger), the
    cutoff is as short as that bound allows, and the run ends with a valid certificate."""
    from spherejam.calippso.schedule import REGIME_S_BOUNDS, TRUST_FACTOR, TRUST_MIN

    result = run_calippso(ls_jammed_256, schedule="trust")
    assert_jammed(result, 3)
    h = result.history
    g, sb, ell, hit = h["sqrt_inflation_minus_1"], h["s_bound"], h["cutoff"], h["bound_active"]
    trusted = 0
    for k in range(1, result.iterations):
        # units of the largest diameter D = 2R
        cap = 0.5 * max(TRUST_FACTOR * math.sqrt(max(g[k - 1], 0.0)), TRUST_MIN)
        if hit[k - 1] == 0 and cap < 0.5 * REGIME_S_BOUNDS[1] and h["regime"][k] == 3:
            trusted += 1
            assert sb[k] == pytest.approx(cap, rel=1e-6)
            assert ell[k] == pytest.approx(1.1 + 2.0 * math.sqrt(3.0) * sb[k], rel=1e-6)
    assert trusted >= 2
