"""The per-step history of a run (engines and CALiPPSO): rows of scalars appended once per window or iteration."""

from __future__ import annotations

from typing import Any

import numpy as np


class History:
    """Rows of scalars appended once per window or iteration, returned as columns of numpy arrays.

    With ``max_rows`` (and ``step`` naming the column that counts the steps) long runs are thinned: only rows whose
    step is a multiple of ``stride`` are kept; once 2 * max_rows rows are held the stride doubles and the rows off
    it are dropped. ``force=True`` keeps a row off the stride (the first and the last one)."""

    def __init__(self, columns: dict[str, np.ndarray] | None = None, *, step: str | None = None,
                 max_rows: int | None = None, stride: int = 1):
        self._rows: dict[str, list] = {k: list(np.asarray(v).tolist()) for k, v in (columns or {}).items()}
        self.step, self.max_rows, self.stride = step, max_rows, int(stride)

    def append(self, force: bool = False, **row: Any) -> None:
        if self._rows and set(row) != set(self._rows):
            raise KeyError(f"history row has columns {sorted(row)}, expected {sorted(self._rows)}")
        if self.max_rows is not None:
            step = row[self.step]
            if (not force and step % self.stride) or self.last(self.step) == step:
                return
        for key, value in row.items():
            self._rows.setdefault(key, []).append(value)
        if self.max_rows is not None and len(self) >= 2 * self.max_rows:
            self.stride *= 2
            keep = [i for i, s in enumerate(self._rows[self.step]) if s % self.stride == 0]
            self._rows = {k: [v[i] for i in keep] for k, v in self._rows.items()}

    def __len__(self) -> int:
        return len(next(iter(self._rows.values()))) if self._rows else 0

    def last(self, key: str, default=None):
        col = self._rows.get(key)
        return col[-1] if col else default

    def as_arrays(self) -> dict[str, np.ndarray]:
        return {k: np.asarray(v) for k, v in self._rows.items()}
