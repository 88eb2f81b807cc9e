"""The typed run summary: every engine fills it the same way, it survives a packing file, and the counters of files
written before it existed (LS/MLS ``windows``, FB ``iterations``/``finished``) read into the same fields."""

import dataclasses

import pytest

from spherejam.core.errors import PackingFileError
from spherejam.core.packing_io import read_packing, write_packing
from spherejam.core.seeding import poisson_packing
from spherejam.engines.closest_jamming import find_closest_jamming
from spherejam.engines.force_biased import run_fb
from spherejam.engines.lubachevsky_stillinger import run_ls
from spherejam.engines.result import (
    BUDGET_STOPS,
    STOP_REASONS,
    FBCounts,
    LSCounts,
    MLSCounts,
    RunStats,
    stats_from_metadata,
)

# counters as spherejam 0.1 wrote them before the typed summary (copied from files of that version)
OLD_LS = {"collisions": 22436, "events": 25200, "windows": 21, "skin_events": 197, "moves": 2567,
          "null_collisions": 0, "list_rebuilds": 149, "wall_time": 0.43, "stop_reason": "p_max",
          "phi_initial": 8.35e-05, "phi_final": 0.5961, "resumed": False}
OLD_MLS = {"collisions": 3231, "events": 3600, "windows": 3, "skin_events": 0, "moves": 369, "null_collisions": 0,
           "list_rebuilds": 0, "wall_time": 0.02, "stop_reason": "max_collisions", "phi_initial": 0.5961,
           "phi_final": 0.5962, "resumed": False, "stages": 3, "rate_decreases": 1, "equilibration_windows": 1,
           "final_rate_reached": 2.5, "phi_J": 0.5962}  # from before the stall rule: no stalled_stages
OLD_FB = {"iterations": 5, "wall_time": 0.16, "phi_inner": 0.2529, "phi_outer": 0.6395, "rho_inner": 0.7605,
          "rho_outer": 1.0361, "finished": False, "resumed": False, "neighbour_rebuilds": 3, "history_stride": 1}


def test_old_counters_read_into_the_typed_summary():
    ls = stats_from_metadata({"algorithm": "ls", "counters": OLD_LS})
    assert (ls.stop_reason, ls.completed, ls.steps, ls.collisions, ls.phi_final) == ("p_max", True, 21, 22436,
                                                                                      0.5961)
    assert ls.extras == LSCounts(events=25200, skin_events=197, moves=2567, null_collisions=0, list_rebuilds=149)
    mls = stats_from_metadata({"algorithm": "mls", "counters": OLD_MLS})
    assert mls.stop_reason == "max_collisions" and not mls.completed and mls.steps == 3
    assert isinstance(mls.extras, MLSCounts) and mls.extras.stages == 3 and mls.extras.stalled_stages == 0
    fb = stats_from_metadata({"algorithm": "fb", "counters": OLD_FB, "parameters": {"max_iterations": 5}})
    assert fb.stop_reason == "max_iterations" and not fb.completed
    assert (fb.steps, fb.collisions, fb.phi_initial, fb.phi_final) == (5, None, None, 0.2529)
    assert fb.extras == FBCounts(phi_outer=0.6395, rho_inner=0.7605, rho_outer=1.0361, neighbour_rebuilds=3,
                                 history_stride=1)
    # an unfinished FB run without an iteration cap was stopped by the wall clock; a finished one converged
    assert stats_from_metadata({"algorithm": "fb", "counters": OLD_FB}).stop_reason == "max_wall_time"
    done = stats_from_metadata({"algorithm": "fb", "counters": {**OLD_FB, "finished": True}})
    assert done.stop_reason == "converged" and done.completed


def test_summary_is_refused_for_other_files_and_broken_counters():
    with pytest.raises(PackingFileError, match="x.h5: no run summary"):
        stats_from_metadata({"algorithm": "calippso", "counters": {}}, "x.h5")
    broken = {k: v for k, v in OLD_LS.items() if k != "moves"}
    with pytest.raises(PackingFileError, match="x.h5: unreadable run summary.*moves"):
        stats_from_metadata({"algorithm": "ls", "counters": broken}, "x.h5")
    with pytest.raises(PackingFileError, match="x.h5: unreadable run summary.*windows"):
        stats_from_metadata({"algorithm": "mls", "counters": {k: v for k, v in OLD_MLS.items() if k != "windows"}},
                            "x.h5")
    with pytest.raises(PackingFileError, match="stop_reason"):
        stats_from_metadata({"algorithm": "ls", "counters": {**OLD_LS, "stop_reason": "tired"}}, "x.h5")


def test_every_engine_fills_the_summary_and_it_survives_the_file(tmp_path):
    start = poisson_packing(80, 0.0, seed=4)
    ls = run_ls(start, 0.3, seed=1, progress_interval=1e9)
    mls = find_closest_jamming(ls.packing, seed=1, final_rate=1e-2, decrease_factor=4.0, progress_interval=1e9)
    fb = run_fb(start, 1e-2, progress_interval=1e9)
    for result, algorithm, steps_column, extras in ((ls, "ls", "window", LSCounts), (mls, "mls", "window", MLSCounts),
                                                    (fb, "fb", "iteration", FBCounts)):
        s = result.stats
        assert isinstance(s, RunStats) and type(s.extras) is extras
        assert s.stop_reason in STOP_REASONS and s.completed == (s.stop_reason not in BUDGET_STOPS)
        assert s.completed and not s.resumed and s.wall_time > 0
        assert s.steps == result.history[steps_column][-1]
        assert s.phi_final == pytest.approx(result.packing.phi, rel=1e-12)
        assert 0 < s.phi_initial <= s.phi_final
        assert (s.collisions is None) == (algorithm == "fb")
        path = tmp_path / f"{algorithm}.h5"
        write_packing(path, result.packing, result.history)
        back = read_packing(path)
        assert back.metadata["counters"] == s.as_dict()  # the stored form is flat JSON
        assert stats_from_metadata(back.metadata, str(path)) == s
    assert ls.stats.stop_reason == "p_max" and mls.stats.stop_reason in ("final_rate", "jammed")
    assert fb.stats.stop_reason == "converged"
    assert dataclasses.asdict(mls.stats.extras).keys() > dataclasses.asdict(ls.stats.extras).keys()
