"""What an engine run returns (:class:`RunResult`) and its typed summary (:class:`RunStats`), one vocabulary for
LS, MLS and FB, and the one reader of the summaries stored in packing files, old and new (:func:`stats_from_metadata`).

A packing file keeps the summary as the JSON mapping ``counters`` of its metadata (the file format's name for it):
the common fields of :class:`RunStats` plus the engine's extras, flat. Files written before the typed result used
other keys (LS/MLS ``windows``; FB ``iterations``, ``finished``, ``phi_inner``); :func:`stats_from_metadata` reads both.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

from ..core.errors import PackingFileError

if TYPE_CHECKING:
    import numpy as np

    from ..core.packing import Packing

#: Why a run stopped. A run is ``completed`` when it stopped by its own rule or target; the budget stops
#: (:data:`BUDGET_STOPS`) cut it short.
STOP_REASONS: dict[str, str] = {
    "p_max": "LS: a window's reduced pressure reached p_max",
    "target_phi": "LS: the packing fraction reached target_phi",
    "final_rate": "MLS: p >= p_max while compressing at a rate <= the final rate",
    "final_rate_stalled": "MLS: as final_rate, but the stage ended by the pressure-stall rule",
    "jammed": "MLS: p stayed >= p_max for max_equilibration_windows zero-rate windows",
    "self_contact": "LS/MLS: the largest sphere touched its own periodic image (diameter L): nothing can grow",
    "converged": "FB: the outer diameters shrank onto the inner ones (rho_out <= rho_in)",
    "max_collisions": "LS/MLS budget: the collisions in all reached max_collisions",
    "max_iterations": "FB budget: the iterations in all reached max_iterations",
    "max_wall_time": "budget: this call ran for max_wall_time seconds",
}
BUDGET_STOPS = frozenset({"max_collisions", "max_iterations", "max_wall_time"})
#: Budget stops after which the checkpoint is kept, so that a later call with a larger budget continues the run. A
#: max_collisions cut is final: it is the workflow's deterministic cap, and its result is the packing of record.
RESUMABLE_STOPS = frozenset({"max_iterations", "max_wall_time"})


@dataclass(frozen=True)
class LSCounts:
    """Event totals of an LS run (extras of :class:`RunStats`)."""

    events: int  #: all events: collisions, re-predictions at the skin, neighbour-list transfers
    skin_events: int
    moves: int  #: cell-list transfers
    null_collisions: int  #: predicted collisions of pairs already separating (round-off), not applied
    list_rebuilds: int


@dataclass(frozen=True)
class MLSCounts(LSCounts):
    """Event totals and stage counts of an MLS run (extras of :class:`RunStats`)."""

    stages: int  #: compression and equilibration stages
    rate_decreases: int  #: k, the number of restarts at gamma_0 / f^k
    equilibration_windows: int
    final_rate_reached: float  #: the last compression rate gamma
    stalled_stages: int  #: compression stages ended by the pressure-stall rule


@dataclass(frozen=True)
class FBCounts:
    """Final state of an FB run (extras of :class:`RunStats`)."""

    phi_outer: float  #: packing fraction of the outer spheres, phi_nominal * rho_out**d
    rho_inner: float
    rho_outer: float
    neighbour_rebuilds: int
    history_stride: int  #: the history keeps the iterations that are multiples of this (and the last one)


Extras = LSCounts | MLSCounts | FBCounts
#: algorithm (packing metadata) -> the type of its extras
EXTRAS: dict[str, type] = {"ls": LSCounts, "mls": MLSCounts, "fb": FBCounts}


@dataclass(frozen=True)
class RunStats:
    """The summary of one engine run, filled the same way by every engine.

    ``steps`` counts LS/MLS windows or FB iterations, ``collisions`` is None for FB; ``wall_time`` (s) is the
    whole run's, resumed calls included; ``phi_initial`` is None for FB files written before it was recorded.
    """

    stop_reason: str
    completed: bool
    steps: int
    collisions: int | None
    wall_time: float
    resumed: bool
    phi_initial: float | None
    phi_final: float
    extras: Extras

    def __post_init__(self):
        if self.stop_reason not in STOP_REASONS:
            raise ValueError(f"stop_reason={self.stop_reason!r}: not one of {', '.join(STOP_REASONS)}")

    def as_dict(self) -> dict[str, Any]:
        """The JSON form stored as the packing's ``counters``: the common fields, then the extras, flat."""
        out = {f.name: getattr(self, f.name) for f in dataclasses.fields(self) if f.name != "extras"}
        out.update(dataclasses.asdict(self.extras))
        return out


def is_completed(stop_reason: str) -> bool:
    """A run is completed unless a budget cut it short."""
    return stop_reason not in BUDGET_STOPS


@dataclass
class RunResult:
    """A run: the packing (actual diameters), its per-window or per-iteration history, its summary."""

    packing: Packing
    history: dict[str, np.ndarray]
    stats: RunStats


_COMMON = tuple(f.name for f in dataclasses.fields(RunStats) if f.name != "extras")


def stats_from_metadata(metadata: Mapping[str, Any], where: str = "packing") -> RunStats:
    """The :class:`RunStats` of a packing's metadata (``algorithm`` and ``counters``; a file's attributes or
    ``Packing.metadata``), written by this version or an older one. Raises :class:`PackingFileError` naming
    ``where`` if the counters are not those of an engine run."""
    algorithm = metadata.get("algorithm")
    counters = metadata.get("counters")
    if algorithm not in EXTRAS or not isinstance(counters, Mapping):
        raise PackingFileError(f"{where}: no run summary of an LS, MLS or FB run (algorithm {algorithm!r})")
    c = dict(counters)
    try:
        if "completed" not in c:  # written before the typed result
            c = _from_old(algorithm, c, metadata.get("parameters") or {})
        extras_type = EXTRAS[algorithm]
        extras = extras_type(**{f.name: c[f.name] for f in dataclasses.fields(extras_type)})
        return RunStats(**{k: c[k] for k in _COMMON}, extras=extras)
    except (KeyError, TypeError, ValueError) as exc:
        raise PackingFileError(f"{where}: unreadable run summary ({type(exc).__name__}: {exc})") from None


def _from_old(algorithm: str, c: dict[str, Any], parameters: Mapping[str, Any]) -> dict[str, Any]:
    """Old counters -> the current keys. LS/MLS: ``windows`` -> steps (MLS files from before the stall rule have
    no stalled stages); FB: ``iterations`` -> steps, ``finished`` -> stop_reason, ``phi_inner`` -> phi_final."""
    if algorithm == "fb":
        if c["finished"]:
            reason = "converged"
        else:
            cap = parameters.get("max_iterations")
            reason = "max_iterations" if cap is not None and c["iterations"] >= cap else "max_wall_time"
        c.update(stop_reason=reason, steps=c["iterations"], collisions=None, phi_final=c["phi_inner"],
                 phi_initial=None)
    else:
        c["steps"] = c["windows"]
        if algorithm == "mls":
            c.setdefault("stalled_stages", 0)
    c["completed"] = is_completed(c["stop_reason"])
    return c
