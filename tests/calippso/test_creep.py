"""A creeping certification is told to its user once (calippso/creep.py, docs/calippso.md §8.1, §10.13)."""

import logging
import sys
from pathlib import Path

import numpy as np

from spherejam.calippso.creep import CREEP_WINDOW, creeping
from spherejam.calippso.run import run_calippso

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "benchmarks"))
from bench_calippso import ls_start  # noqa: E402


def test_the_rule_needs_two_windows_of_changed_contacts_without_a_decade_of_progress():
    w = CREEP_WINDOW
    flat = np.full(2 * w, 1e-7)
    changes = np.full(2 * w, 30)
    assert creeping(flat, changes)
    assert not creeping(flat[1:], changes[1:])  # one LP short of two windows
    falling = np.geomspace(1e-6, 1e-9, 2 * w)  # three decades in two windows: converging, not creeping
    assert not creeping(falling, changes)
    still = changes.copy()
    still[-1] = 0  # an LP that kept its contacts: the network may have settled
    assert not creeping(flat, still)
    unknown = changes.copy()
    unknown[:] = -1  # interior steps and the first LP: contacts not known, counted as changed
    assert creeping(flat, unknown)


def test_a_creeping_run_is_told_once_and_a_quick_one_not(caplog):
    # plain LS to p = 1e5 at gamma = 1e-2 is the creeping kind of start (docs/calippso.md §10.2: 76 LPs at N = 256)
    creeper, _ = ls_start(256, 1e5, 1e-2, 3, kind="ls")
    with caplog.at_level(logging.WARNING, logger="spherejam"):
        result = run_calippso(creeper, max_iterations=3 * CREEP_WINDOW, progress_interval=1e9)
    told = [r.getMessage() for r in caplog.records if "creeps" in r.getMessage()]
    assert not result.completed and len(told) == 1 and "docs/calippso.md §8.1" in told[0]
    h = result.history
    assert creeping(h["sqrt_inflation_minus_1"], h["contact_changes"])
    caplog.clear()
    # an input at its own pressure (LS then MLS at p_max = 1e5) converges in a few LPs, and nothing is said
    quick, _ = ls_start(256, 1e5, 1e-2, 3, kind="mls")
    with caplog.at_level(logging.WARNING, logger="spherejam"):
        result = run_calippso(quick, progress_interval=1e9)
    assert result.completed and result.iterations < 2 * CREEP_WINDOW
    assert not [r for r in caplog.records if "creeps" in r.getMessage()]
