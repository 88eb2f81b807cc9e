"""What the workflow does when a Snakemake run ends (its ``onsuccess`` and ``onerror`` handlers, rules/common.smk).

The local profile's ``max-jobs-per-timespan: 1000/60s`` (docs/cluster.md §9) spares the scheduler a wake-up every
second, but Snakemake arms its re-evaluation with a non-daemon ``threading.Timer`` of the whole timespan, so the
interpreter would wait up to 60 s after the last job before it exits: a one-figure rebuild would take a minute
longer than its job. At the end of a run nothing is left to re-evaluate, so the pending timers are cancelled.
"""

from __future__ import annotations

import threading


def cancel_pending_timers() -> int:
    """Cancel every ``threading.Timer`` still waiting in this process; returns how many were cancelled."""
    timers = [t for t in threading.enumerate() if isinstance(t, threading.Timer) and t.is_alive()]
    for timer in timers:
        timer.cancel()
    return len(timers)
