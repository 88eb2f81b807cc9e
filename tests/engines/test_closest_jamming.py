"""Closest-jamming (MLS) search: state machine, starts from any packing, jammed inputs, checkpoints, validation.

The paper's parameters (gamma_0 = 10, final rate 1e-4, factor 2) cost ~1e5 collisions per particle; most tests use
fewer stages (final rate 1e-2, factor 4) on small N to stay fast. The science checks at N = 1e3-1e4 are in
``benchmarks/mls_science.py``.
"""

import dataclasses
import json

import numpy as np
import pytest

from packings import Killed, kill_at
from spherejam.core.errors import InputError
from spherejam.core.rate_ladder import final_stage, ladder_rates, last_rate_floor, stage_count, stage_rate
from spherejam.core.seeding import poisson_packing
from spherejam.engines.closest_jamming import MLSController, find_closest_jamming
from spherejam.engines.event_driven import WindowStats
from spherejam.engines.lubachevsky_stillinger import run_ls
from spherejam.engines.result import LSCounts, stats_from_metadata

NO_EVENTS = LSCounts(events=0, skin_events=0, moves=0, null_collisions=0, list_rebuilds=0)

QUICK = {"final_rate": 1e-2, "decrease_factor": 4.0, "progress_interval": 1e9}


def _check_state_machine(result, initial_rate, factor, final_rate, p_max=1e12, max_eq=50):
    """Replay the per-window history against the MLS rules of the paper (§III.B)."""
    h = result.history
    rate, p, stage = h["rate"], h["pressure"], h["stage"]
    n = len(rate)
    k = 0
    count = 0
    for w in range(n):
        last = w + 1 == n
        if rate[w] > 0:
            assert rate[w] == pytest.approx(initial_rate / factor**k, rel=1e-12)
            if p[w] >= p_max and rate[w] <= final_rate:
                assert last and result.stats.stop_reason == "final_rate"
                break
            assert not last
            if p[w] >= p_max:  # jam reached: equilibrate at zero rate
                assert rate[w + 1] == 0 and stage[w + 1] == stage[w] + 1
                count = 0
            else:
                assert rate[w + 1] == rate[w] and stage[w + 1] == stage[w]
        else:
            if p[w] < p_max:  # unjammed: compress again, slower
                k += 1
                assert not last
                assert rate[w + 1] == pytest.approx(initial_rate / factor**k, rel=1e-12)
                assert stage[w + 1] == stage[w] + 1
            else:
                count += 1
                if count >= max_eq:
                    assert last and result.stats.stop_reason == "jammed"
                    break
                assert not last and rate[w + 1] == 0 and stage[w + 1] == stage[w]
    c = result.stats
    assert p[-1] >= p_max
    assert c.extras.stalled_stages == 0  # small N: the double-precision floor is far above p_max
    assert c.extras.stages == stage[-1] + 1
    assert c.extras.rate_decreases == k
    assert c.collisions == h["collisions"].sum()
    assert c.steps == n


def _assert_jammed_result(result, start):
    out = result.packing
    assert out.check(1e-10).ok
    assert out.min_gap() < 1e-9
    assert out.metadata["algorithm"] == "mls"
    assert out.metadata["reduced_pressure"] >= 1e12
    c = result.stats
    assert c.completed and c.stop_reason in ("final_rate", "jammed")
    assert c.phi_final == pytest.approx(out.phi, rel=1e-12)  # phi_J
    assert c.phi_initial == pytest.approx(start.scaled_to_contact().phi, rel=1e-9)
    assert c.phi_final >= c.phi_initial - 1e-12
    assert 0.58 < c.phi_final < 0.68


def test_mls_from_poisson_start():
    start = poisson_packing(100, 0.0, seed=1)
    result = find_closest_jamming(start, seed=3, **QUICK)
    _assert_jammed_result(result, start)
    _check_state_machine(result, 10.0, 4.0, 1e-2)
    assert result.stats.extras.stages >= 5


def test_mls_from_ls_start_polydisperse():
    start = run_ls(poisson_packing(150, 0.3, seed=2), 0.5, seed=1, progress_interval=1e9).packing
    result = find_closest_jamming(start, seed=4, **QUICK)
    _assert_jammed_result(result, start)
    _check_state_machine(result, 10.0, 4.0, 1e-2)
    assert result.packing.metadata["parameters"]["input_algorithm"] == "ls"


def test_mls_from_fb_start():
    fb = pytest.importorskip("spherejam.engines.force_biased")
    start = fb.run_fb(poisson_packing(120, 0.0, seed=3), 1e-2, progress_interval=1e9).packing
    result = find_closest_jamming(start, seed=5, initial_rate=1.0, **QUICK)
    _assert_jammed_result(result, start)
    _check_state_machine(result, 1.0, 4.0, 1e-2)


@pytest.fixture(scope="module")
def paper_mls_50():
    """Paper parameters (gamma_0 = 10, f = 2, final rate 1e-4) on N = 50: the start and its MLS result."""
    start = poisson_packing(50, 0.0, seed=1)
    return start, find_closest_jamming(start, seed=1, progress_interval=1e9)


def test_paper_parameters_on_small_packing_and_jammed_input_barely_moves(paper_mls_50):
    """MLS on its own jammed output changes phi by far less than 1e-4."""
    start, first = paper_mls_50
    _assert_jammed_result(first, start)
    _check_state_machine(first, 10.0, 2.0, 1e-4)
    assert first.stats.extras.final_rate_reached <= 1e-4 or first.stats.stop_reason == "jammed"
    again = find_closest_jamming(first.packing, seed=2, progress_interval=1e9)
    assert abs(again.stats.phi_final - first.stats.phi_final) < 1e-4
    assert again.packing.check(1e-10).ok


def test_rule_b_stops_after_max_equilibration_windows(paper_mls_50):
    jammed = paper_mls_50[1].packing
    result = find_closest_jamming(jammed, seed=7, max_equilibration_windows=3, progress_interval=1e9)
    _check_state_machine(result, 10.0, 2.0, 1e-4, max_eq=3)
    assert abs(result.stats.phi_final - jammed.phi) < 1e-4


def test_checkpoint_resume_of_stages_is_identical(tmp_path):
    start = poisson_packing(80, 0.0, seed=6)
    reference = find_closest_jamming(start, seed=2, **QUICK)
    assert reference.stats.extras.stages > 3
    ckpt = tmp_path / "mls.h5"

    with pytest.raises(Killed):
        find_closest_jamming(start, seed=2, checkpoint=ckpt, checkpoint_interval=0.0, callback=kill_at(12), **QUICK)
    assert ckpt.exists()
    resumed = find_closest_jamming(start, seed=2, checkpoint=ckpt, checkpoint_interval=0.0, **QUICK)
    assert resumed.stats.resumed is True
    assert not ckpt.exists()
    assert np.array_equal(resumed.packing.positions, reference.packing.positions)
    assert np.array_equal(resumed.history["stage"], reference.history["stage"])
    assert resumed.stats.phi_final == reference.stats.phi_final


def test_deterministic():
    start = poisson_packing(60, 0.1, seed=9)
    a = find_closest_jamming(start, seed=1, **QUICK)
    b = find_closest_jamming(start, seed=1, **QUICK)
    assert np.array_equal(a.packing.positions, b.packing.positions)
    assert a.stats.collisions == b.stats.collisions


@pytest.mark.parametrize(
    "kwargs, field",
    [
        ({"initial_rate": 0.0}, "initial_rate"),
        ({"initial_rate": -1.0}, "initial_rate"),
        ({"decrease_factor": 1.0}, "decrease_factor"),
        ({"final_rate": 0.0}, "final_rate"),
        ({"p_max": 1.0}, "p_max"),
        ({"max_equilibration_windows": 0}, "max_equilibration_windows"),
        ({"events_per_particle": 0}, "events_per_particle"),
        ({"seed": -3}, "seed"),
        ({"max_wall_time": -1.0}, "max_wall_time"),
        ({"max_collisions": 0}, "max_collisions"),
        ({"stall_windows": 0}, "stall_windows"),
        ({"stall_windows": 2.5}, "stall_windows"),
    ],
)
def test_bad_parameters_are_rejected(kwargs, field):
    with pytest.raises(InputError, match=field):
        find_closest_jamming(poisson_packing(10, 0.0, seed=1), **kwargs)


def test_max_collisions_cut_is_deterministic_and_marked():
    start = poisson_packing(60, 0.1, seed=9)
    a = find_closest_jamming(start, seed=1, max_collisions=5000, **QUICK)
    b = find_closest_jamming(start, seed=1, max_collisions=5000, **QUICK)
    assert a.stats.stop_reason == "max_collisions"
    assert 5000 <= a.stats.collisions < 5000 + 40 * start.n  # cut at the first window end past the cap
    assert np.array_equal(a.packing.positions, b.packing.positions)
    assert a.packing.check().n_overlaps == 0


def test_cli_mls(tmp_path):
    from spherejam.cli import main
    from spherejam.core.packing_io import read_packing, write_packing

    src = tmp_path / "in.h5"
    write_packing(src, poisson_packing(60, 0.0, seed=4))
    out = tmp_path / "out.h5"
    argv = ["mls", str(src), "-o", str(out), "--final-rate", "1e-2", "--decrease-factor", "4",
            "--progress-interval", "1e9"]
    assert main(argv) == 0
    packing, history = read_packing(out, with_history=True)
    assert packing.metadata["algorithm"] == "mls"
    assert packing.metadata["counters"]["phi_final"] == pytest.approx(packing.phi)
    assert "stage" in history
    assert main(["mls", str(src), "-o", str(out), "--decrease-factor", "0.5"]) == 2
    assert main(["mls", str(src), "-o", str(out), "--max-collisions-per-particle", "-1"]) == 2
    assert main(argv + ["--max-collisions-per-particle", "10"]) == 0
    stats = stats_from_metadata(read_packing(out).metadata)
    assert stats.stop_reason == "max_collisions" and not stats.completed


def _window(p: float) -> WindowStats:
    return WindowStats(duration=1e-12, pressure=p, temperature=0.2, collisions=1, events=1, skin_events=0, moves=0,
                       null_collisions=0, list_rebuilds=0, reached_target=False)


def _feed(controller, pressures):
    """Windows with these pressures; the stop reason and the (rate, stage) after each window."""
    trace = []
    for p in pressures:
        reason = controller.after_window(_window(p))
        trace.append((controller.rate, controller.state.stage))
        if reason:
            return reason, trace
    return None, trace


def test_stall_rule_ends_a_stage_whose_pressure_is_stuck_below_p_max():
    """The N = 10^4 floor: p flat at ~6.7e11 < p_max = 1e12 (2.5 % noise) ends the stage after stall_windows."""
    c = MLSController(10.0, 2.0, 1.0, 1e12, 50, stall_windows=20)
    flat = 6.7e11 * (1 + 0.0125 * np.sin(np.arange(21)))
    # the count starts at the first window in the band: 20 more windows end the stage
    reason, trace = _feed(c, np.concatenate([[8e11, 3e4, 1e8], flat]))
    assert reason is None
    assert [rate for rate, _ in trace] == [10.0] * 23 + [0.0]
    assert c.state.stalled_stages == 1 and c.state.stage == 1 and c.state.stall_count == 0
    assert isinstance(c.extras(NO_EVENTS).stalled_stages, int)  # JSON-safe for checkpoints
    # equilibration at p < p_max: compress again at gamma_0 / f
    reason, trace = _feed(c, [6.7e11])
    assert reason is None and trace[-1] == (5.0, 2)
    # a stall at a rate <= the final rate ends the search, marked as such
    c = MLSController(10.0, 2.0, 20.0, 1e12, 50, stall_windows=5)
    reason, trace = _feed(c, [7e11] * 10)
    assert reason == "final_rate_stalled" and len(trace) == 6
    assert c.extras(NO_EVENTS).stalled_stages == 1


@pytest.mark.parametrize(
    "pressures, stall_windows",
    [
        (7e11 * np.ones(100), None),  # rule off: the paper's algorithm
        (5e10 * np.ones(100), 5),  # a plateau far below p_max is not the precision floor
        (1e11 * 1.02 ** np.arange(100), 20),  # slow but steady growth (+10 % every 5 windows)
        (7e11 * (1 + 0.3 * (np.arange(100) % 2)), 5),  # noisy p (small N): never 5 windows within 10 %
    ],
)
def test_stall_rule_does_not_fire_on_growth_low_plateaus_or_when_off(pressures, stall_windows):
    c = MLSController(10.0, 2.0, 1e-4, 1e12, 50, stall_windows=stall_windows)
    reason, trace = _feed(c, pressures)
    assert reason is None and c.state.stalled_stages == 0 and c.state.stage == 0


def test_stall_rule_state_round_trips_and_old_checkpoints_load():
    c = MLSController(10.0, 2.0, 1e-4, 1e12, 50, stall_windows=10)
    _feed(c, [7e11] * 6)
    saved = json.loads(json.dumps(dataclasses.asdict(c.state)))  # as a checkpoint stores it
    copy = MLSController(10.0, 2.0, 1e-4, 1e12, 50, stall_windows=10)
    copy.restore(saved)
    assert copy.state == c.state and copy.state.stall_count == 5
    old = {k: v for k, v in saved.items() if not k.startswith("stall")}
    fresh = MLSController(10.0, 2.0, 1e-4, 1e12, 50, stall_windows=10)
    fresh.restore(old)  # a checkpoint from before the rule: the count starts afresh
    assert fresh.state.stall_count == 0 and fresh.state.stall_reference == 0.0 and fresh.rate == c.rate


def test_rate_ladder_is_gamma0_over_f_to_the_k_and_the_engine_compresses_at_it():
    """One ladder (core/rate_ladder.py) for the engine, the cost model and the config check."""
    assert ladder_rates(10.0, 2.0, 1e-4) == [10.0 / 2.0**k for k in range(18)]  # the paper's: 10 ... 10 / 2^17
    assert final_stage(10.0, 2.0, 1e-4) == 17 and ladder_rates(1e-4, 2.0, 1e-4) == [1e-4]
    assert stage_rate(3.3, 1.5, 7) == 3.3 / 1.5**7  # from gamma_0 each time, bitwise, not a running product
    rates = ladder_rates(3.3, 1.5, 1e-3)
    assert rates[-2] > 1e-3 >= rates[-1] > last_rate_floor(1.5, 1e-3)
    # the search jams at every rate, unjams when equilibrated, and stops at the ladder's last rate
    c = MLSController(3.3, 1.5, 1e-3, 1e12, 50)
    reason, trace = _feed(c, [2e12, 1.0] * len(rates))
    assert reason == "final_rate" and c.final_stage == len(rates) - 1
    assert [3.3] + [rate for rate, _ in trace[:-1] if rate > 0] == rates  # the last window keeps its rate
    # its length without walking it, as the config check needs for a factor near 1
    for g0, f, gf in [(10.0, 2.0, 1e-4), (3.3, 1.5, 1e-3), (1.0, 1.01, 1e-5), (5.0, 7.0, 5.0), (1e3, 1.3, 2e-8)]:
        assert stage_count(g0, f, gf) == len(ladder_rates(g0, f, gf))


def test_a_ladder_of_too_many_rates_is_refused_before_it_is_walked():
    from spherejam.core.errors import InputError
    from spherejam.core.validation import MLS_MAX_STAGES, check_mls

    check_mls(10.0, 1.002, 1e-4)  # 5758 rates: allowed
    with pytest.raises(InputError, match=r"^mls.decrease_factor=1.0000001: .* has 115129\d{3} rates \(at most "):
        check_mls(10.0, 1.0000001, 1e-4)
    assert stage_count(10.0, 1.0000001, 1e-4) > MLS_MAX_STAGES


def test_cli_mls_stall_flags(tmp_path):
    from spherejam.cli import main
    from spherejam.core.packing_io import read_packing, write_packing

    src = tmp_path / "in.h5"
    write_packing(src, poisson_packing(40, 0.0, seed=4))
    out = tmp_path / "out.h5"
    quick = ["--final-rate", "1e-1", "--decrease-factor", "10", "--progress-interval", "1e9"]
    assert main(["mls", str(src), "-o", str(out), "--stall-windows", "77"] + quick) == 0
    assert read_packing(out).metadata["parameters"]["stall_windows"] == 77
    assert main(["mls", str(src), "-o", str(out), "--no-stall-rule"] + quick) == 0
    assert read_packing(out).metadata["parameters"]["stall_windows"] is None
    for bad in (["--stall-windows", "0"], ["--stall-windows", "5", "--no-stall-rule"]):
        assert main(["mls", str(src), "-o", str(out)] + bad) == 2  # argparse usage error
