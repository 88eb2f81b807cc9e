"""The compression-rate controller of LS-type runs: it decides the rate gamma window by window and when the
run stops (plain LS: constant gamma, stop at p >= p_max; MLS subclasses it in
:mod:`spherejam.engines.closest_jamming`)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, get_type_hints

if TYPE_CHECKING:
    from .event_driven import WindowStats
    from .result import LSCounts, MLSCounts

CHECKPOINT_KIND_LS = "ls"


@dataclass
class RateState:
    """What a :class:`Controller` changes window by window (a checkpoint saves it whole): the rate gamma."""

    rate: float


def restore_dataclass(cls, saved: dict[str, Any]):
    """``cls`` from a checkpoint's dict, each field cast to its type; a field the checkpoint lacks (written before
    the field existed) takes its default."""
    return cls(**{name: kind(saved[name]) for name, kind in get_type_hints(cls).items() if name in saved})


class Controller:
    """Decides the compression rate window by window (plain LS: constant rate, stop at p >= p_max); its
    changing part is ``state`` (a :class:`RateState`)."""

    kind = CHECKPOINT_KIND_LS

    def __init__(self, rate: float, p_max: float):
        self.state = RateState(float(rate))
        self.p_max = float(p_max)

    @property
    def rate(self) -> float:
        return self.state.rate

    def restore(self, saved: dict[str, Any]) -> None:
        """Continue from a checkpoint's ``dataclasses.asdict(state)``."""
        self.state = restore_dataclass(type(self.state), saved)

    def after_window(self, stats: WindowStats) -> str | None:
        """Update the rate after a window; return a stop reason or None."""
        return "p_max" if stats.pressure >= self.p_max else None

    def extra_row(self) -> dict[str, Any]:
        """Columns the controller adds to the history row of a window."""
        return {}

    def progress_fields(self) -> dict[str, Any]:
        """What the live status line shows of the controller (the driver adds p, phi, collisions/s)."""
        return {"γ": self.rate}

    def extras(self, counts: LSCounts) -> LSCounts | MLSCounts:
        """The extras of the run's :class:`RunStats`, from the event totals."""
        return counts
