"""What every engine run returns, plus the per-window history and progress output they share."""

from __future__ import annotations

import logging
import time
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..core import progress
from ..core.packing import Packing

log = logging.getLogger("spherejam")


class History:
    """Rows of scalars appended once per window or iteration, returned as columns of numpy arrays."""

    def __init__(self, columns: dict[str, np.ndarray] | None = None):
        self._rows: dict[str, list] = {k: list(np.asarray(v).tolist()) for k, v in (columns or {}).items()}

    def append(self, **row: Any) -> None:
        if self._rows and set(row) != set(self._rows):
            raise KeyError(f"history row has columns {sorted(row)}, expected {sorted(self._rows)}")
        for key, value in row.items():
            self._rows.setdefault(key, []).append(value)

    def __len__(self) -> int:
        return len(next(iter(self._rows.values()))) if self._rows else 0

    def last(self, key: str, default=None):
        col = self._rows.get(key)
        return col[-1] if col else default

    def as_arrays(self) -> dict[str, np.ndarray]:
        return {k: np.asarray(v) for k, v in self._rows.items()}


@dataclass
class RunResult:
    """A finished run: the packing, its per-window history and counters (collisions, events, windows, ...)."""

    packing: Packing
    history: dict[str, np.ndarray]
    counters: dict[str, Any] = field(default_factory=dict)
    wall_time: float = 0.0


class Progress:
    """Progress of a run: a log line (to the ``spherejam`` logger) at most every ``interval`` seconds, or, on a
    terminal, the live status line of :mod:`spherejam.core.progress` fed with every update's ``fields`` and ``bar``."""

    def __init__(self, label: str, interval: float = 10.0):
        self.label = label
        self.interval = interval
        self.start = time.perf_counter()
        self._last = -float("inf")

    @property
    def elapsed(self) -> float:
        return time.perf_counter() - self.start

    def update(self, message: str, force: bool = False, fields: dict[str, Any] | None = None,
               bar: tuple[float, str] | None = None) -> None:
        """Report ``message``; ``fields`` (name -> value) and ``bar`` (fraction in [0, 1], caption) are what the
        live status line shows. Updates without fields always go to the log."""
        line = progress.current() if fields is not None else None
        if line is not None:
            line.show(self.label, self.elapsed, fields, bar)
            if not force:
                return
        now = time.perf_counter()
        if force or now - self._last >= self.interval:
            self._last = now
            log.info("%s [%7.1f s] %s", self.label, now - self.start, message)
