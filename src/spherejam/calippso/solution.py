"""What one CALiPPSO linear program's solve returns: the solution, the HiGHS basis it ends at (the next LP's warm
start), and the history codes of the method and solver that produced it (docs/calippso.md §5)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

#: History codes of how an LP was solved: "ipm" interior point + HiGHS crossover, "simplex" dual simplex,
#: "active-set" the previous LP's contact network certified by :func:`~.active_set.solve_active_set`, "warm" primal
#: simplex from the previous LP's basis, "vertex" interior point without crossover, its vertex certified by
#: :func:`~.active_set.solve_active_set`, "predicted" primal simplex from the basis of a "vertex" that was not
#: certified, "interior" an interior point taken as an intermediate step, no vertex (docs/calippso.md §10).
METHOD_CODES = {"ipm": 0, "simplex": 1, "active-set": 2, "warm": 3, "vertex": 4, "predicted": 5, "interior": 6}
#: History codes of which HiGHS solver produced an LP's solution ("none": the active-set solve alone, no HiGHS).
SOLVER_CODES = {"none": 0, "hipo": 1, "ipx": 2, "simplex": 3}


@dataclass
class LPBasis:
    """A HiGHS basis keyed by pair, so that the next LP (slightly different rows) can start from it.

    ``keys`` are the sorted keys of the rows (:func:`~.constraints.pair_keys`), ``rows`` their HiGHS basis status
    codes in that order, ``cols`` the status codes of the d N + 1 columns.
    """

    keys: np.ndarray
    rows: np.ndarray
    cols: np.ndarray


@dataclass
class LPSolution:
    """Solution of one LP: displacements s (N, d), the inflation factor Gamma (``inflation``), pair duals
    lambda >= 0, solve time (s), method used (a :data:`METHOD_CODES` name, "+pivots" for the active-set solves), the
    final basis (None if HiGHS did not provide one) and the HiGHS solver used."""

    s: np.ndarray
    inflation: float
    duals: np.ndarray
    solve_time: float
    method: str
    basis: LPBasis | None = None
    solver: str = "none"  # the HiGHS solver behind it (SOLVER_CODES)
    failed: str = ""  # the attempts that failed before this one (e.g. an uncertified vertex before crossover)
    rows: int = -1  # rows of the LP as solved (-1: every row given; fewer under constraint generation)
    rows_added: int = 0  # rows that constraint generation added after the first solve
    held: np.ndarray | None = None  # (N, d) -1 / +1: components the active-set solve's vertex holds at a bound

    @property
    def method_name(self) -> str:
        """The method without its pivot count: a key of :data:`METHOD_CODES`."""
        return self.method.split("+")[0]
