"""The per-LP record of a CALiPPSO run as a small CSV file, one row per LP of the main loop (docs/calippso.md §10).

The rows are the run's history (the driver's ``history``), so the file and the checkpoint never disagree: when a run
starts or resumes, the file is rewritten from the history it resumes with (atomically: temporary file, then rename;
rows of LPs after the checkpoint, which the resumed run solves again, are dropped), and every LP then appends its row
and flushes it, so a killed run keeps the rows it solved. Columns (:data:`COLUMNS`):

- ``lp``: the LP's number (1, 2, ...); ``regime`` (docs §1.3);
- ``sqrt_gamma_minus_1``: sqrt(Gamma) - 1 as applied (Gamma the LP's inflation factor);
- ``max_s_stable``: max |s_{i,mu}| over non-rattlers, in units of the largest diameter after the step;
- ``s_bound``, ``cutoff``: the LP's per-component displacement bound and cutoff l, same units;
- ``bound_active``: components of non-rattlers at their bound;
- ``contacts_gained``, ``contacts_lost``: contacts among non-rattlers (pair keys) new in this LP, and gone since the
  previous one (-1 for the first LP);
- ``contacts``, ``rattlers``, ``isostatic`` (0/1), ``rows`` (rows of the LP as solved);
- ``method``, ``solver``: the solver path (:data:`~.solution.METHOD_CODES`, :data:`~.solution.SOLVER_CODES`);
- ``lp_cpu_s``, ``lp_wall_s``: CPU and wall seconds of the solve; ``iteration_cpu_s``, ``iteration_wall_s``: of the
  whole iteration (rows, solve, contact network, step);
- ``phi``: the packing fraction after the step.
"""

from __future__ import annotations

import csv
import os
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

from ..core.atomic import atomic_output
from .solution import METHOD_CODES, SOLVER_CODES

#: CSV column -> history column it is read from.
COLUMNS: dict[str, str] = {
    "lp": "", "regime": "regime", "sqrt_gamma_minus_1": "sqrt_inflation_minus_1",
    "max_s_stable": "max_displacement", "s_bound": "s_bound", "cutoff": "cutoff", "bound_active": "bound_active",
    "contacts_gained": "contacts_gained", "contacts_lost": "contacts_lost", "contacts": "n_contacts",
    "rattlers": "n_rattlers", "isostatic": "isostatic", "rows": "lp_rows", "method": "method", "solver": "solver",
    "lp_cpu_s": "cpu_time", "lp_wall_s": "solve_time", "iteration_cpu_s": "iteration_cpu_time",
    "iteration_wall_s": "iteration_wall_time", "phi": "phi",
}
_METHODS = {code: name for name, code in METHOD_CODES.items()}
_SOLVERS = {code: name for name, code in SOLVER_CODES.items()}


def _cells(row: Mapping[str, Any], lp: int) -> list[str]:
    """The CSV cells of LP number ``lp`` from its history row (history column -> value)."""
    out = []
    for column, key in COLUMNS.items():
        if column == "lp":
            out.append(str(lp))
            continue
        value = row.get(key)
        if value is None:  # a history from before the column existed (an older checkpoint)
            out.append("")
        elif column == "method":
            out.append(_METHODS.get(int(value), str(value)))
        elif column == "solver":
            out.append(_SOLVERS.get(int(value), str(value)))
        elif isinstance(value, (float, np.floating)):
            out.append(repr(float(value)))
        else:
            out.append(str(int(value)))
    return out


class LPLog:
    """The CSV record of one run's LPs at ``path`` (None: no record)."""

    def __init__(self, path: str | os.PathLike | None):
        self.path = None if path is None else Path(path)

    def start(self, history: dict[str, np.ndarray]) -> None:
        """Write the rows of the LPs already solved (a resumed run's history; none for a new run)."""
        if self.path is None:
            return
        n = len(history.get("sqrt_inflation_minus_1", ()))
        with atomic_output(self.path, ".csv") as tmp, open(tmp, "w", newline="") as fh:
            writer = csv.writer(fh)
            writer.writerow(COLUMNS)
            for row in range(n):
                writer.writerow(_cells({k: v[row] for k, v in history.items()}, row + 1))

    def append(self, row: Mapping[str, Any], lp: int) -> None:
        """Append the history row of LP number ``lp`` (the one just solved) and flush it to disk."""
        if self.path is None:
            return
        with open(self.path, "a", newline="") as fh:
            csv.writer(fh).writerow(_cells(row, lp))
            fh.flush()
            os.fsync(fh.fileno())
