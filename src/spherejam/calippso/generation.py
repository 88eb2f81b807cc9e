"""Constraint generation for one CALiPPSO LP: solve over the rows of the pairs that can close in this LP, check
every other row of the cutoff at that solution, add the violated ones and re-solve, until none is violated
(docs/calippso.md §5.7).

A pair row can be violated only if the pair approaches by more than its gap to the inflated contact distance, and
|s_i - s_j| <= 2 sqrt(d) s_bound: a row with r_ij > sigma_ij sqrt(Gamma_guess) + 2 sqrt(d) s_bound holds at every
step with |s_{i,mu}| <= s_bound and sqrt(Gamma) <= sqrt(Gamma_guess). The LP over the other rows is a relaxation of
the full one; its optimum, once it satisfies every row, is an optimum of the full LP, with zero duals on the rows
left out.
"""

from __future__ import annotations

import time
from collections.abc import Callable

import numpy as np

from .constraints import row_excesses, step_approach
from .solution import LPSolution

#: sqrt(Gamma) - 1 of the near-row test, as a multiple of the previous LP's: sqrt(Gamma) - 1 falls from one LP to
#: the next near jamming, so a pair beyond this reach is violated only after an unexpected jump in Gamma.
GAMMA_GUESS_FACTOR = 10.0
#: Rounds of generation before the remaining rows are all added (the LP is then the full one, solved once more).
MAX_ROUNDS = 5


def near_rows(rij: np.ndarray, sigma2: np.ndarray, s_bound: float, sqrt_inflation_guess: float) -> np.ndarray:
    """Mask of the pair rows that may be violated at a step whose sqrt(Gamma) is at most ``sqrt_inflation_guess``:
    r_ij <= sigma_ij sqrt(Gamma_guess) + 2 sqrt(d) ``s_bound`` (lengths in the caller's unit)."""
    r = np.sqrt(np.einsum("ij,ij->i", rij, rij))
    return r <= np.sqrt(sigma2) * sqrt_inflation_guess + step_approach(s_bound, rij.shape[1])


def solve_generated(rij, sigma2, pi, pj, near: np.ndarray,
                    solve: Callable[[np.ndarray, LPSolution | None], LPSolution],
                    max_rounds: int = MAX_ROUNDS) -> tuple[LPSolution, int, int]:
    """Solve the LP over the rows ``near`` first, then add the violated rows of the others until none is.

    ``solve(rows, previous)`` solves the LP over the sorted row indices ``rows`` (``previous``: the solution of the
    round before, whose basis a re-solve starts from; None in the first round). A row counts as violated when its
    excess relative to sigma_ij^2 is > 0 (:func:`~.constraints.row_excesses`): stricter than the 10 x tolerance a
    solver's own rows are checked to (docs/calippso.md §5.5). After ``max_rounds`` rounds every remaining row is
    added. Returns ``(the solution with duals over all rows, rows in the last LP, rows added)``; its solve time is
    that of all rounds.
    """
    t0 = time.perf_counter()
    rows = np.flatnonzero(near)
    sol = solve(rows, None)
    failures = [sol.failed] if sol.failed else []
    for round_ in range(1, max_rounds + 1):
        out = np.ones(len(pi), dtype=bool)
        out[rows] = False
        far = np.flatnonzero(out)
        violated = far[row_excesses(rij[far], sigma2[far], pi[far], pj[far], sol.s, sol.inflation) > 0.0]
        if violated.size == 0:
            break
        rows = far if round_ == max_rounds else violated  # the last round: the full LP
        rows = np.union1d(np.flatnonzero(~out), rows)
        sol = solve(rows, sol)
        if sol.failed:
            failures.append(sol.failed)
    duals = np.zeros(len(pi))
    duals[rows] = sol.duals
    sol.duals = duals
    sol.solve_time = time.perf_counter() - t0
    sol.failed = "; ".join(failures)
    return sol, rows.size, rows.size - int(np.count_nonzero(near))
