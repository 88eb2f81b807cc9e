"""The active set of a CALiPPSO LP: predicting its optimal vertex (from an interior point, or from the previous LP's
contact network) and certifying the prediction by sparse LU and a few primal simplex pivots (docs/calippso.md §5.2,
§5.4).
"""

from __future__ import annotations

import math
import time

import numpy as np

from .constraints import constraint_rows
from .solution import LPSolution


def network_prediction(contact, rattler, pi, pj, n):
    """The next LP's predicted active set from this LP's isostatic contact network: ``(contact keys i*N + j of the
    contacts among non-rattlers, sorted; rattler mask)``, the arguments :func:`solve_active_set` takes."""
    stable = contact & ~rattler[pi] & ~rattler[pj]
    return np.sort(pi[stable] * n + pj[stable]), rattler.copy()


def interior_point_prediction(pi, pj, n, dim, sigma2, duals, slack, s=None, col_dual=None, s_bound=None):
    """The vertex an interior point of the LP is heading for: ``(contact keys, rattler mask, fixed)``, or None.

    On the central path lambda_k * slack_k is the same small number for every row, so the score
    (lambda_k sigma_k^2 M) / (slack_k / sigma_k^2) (M rows; both factors dimensionless, the first ~1 on an active
    row) grows without bound on the optimal active set and vanishes off it. An s component gets the same kind of
    score from its bound multiplier |col_dual| and its distance to the bound (with ``s``, ``col_dual`` and
    ``s_bound``): those scoring > 1 are predicted held at the bound (``fixed``: -1 / +1, else 0). Rows scoring > 1
    and the held components (as contacts with a wall) give the contact graph and its rattlers (outside the
    (d+1)-core); of the rows among stable particles the d (N_s - 1) + 1 - (held components) with the highest score
    are the predicted vertex, for :func:`solve_active_set` to certify.
    """
    from ..analysis.contacts import rattler_mask

    m = len(pi)
    score = duals * sigma2 * m / np.maximum(slack / sigma2, 1e-300)
    near = score > 1.0
    fixed = np.zeros((n, dim), dtype=np.int8)
    if s is not None and s_bound is not None and math.isfinite(s_bound):
        # scales of a bound multiplier (~ 2 sigma lambda, A's entries are 2 r) and of a distance to the bound (s_bound)
        sigma = math.sqrt(float(np.median(sigma2)))
        distance = np.maximum(s_bound - np.abs(s), 0.0) / s_bound
        bound_score = np.abs(col_dual) * m * sigma / 2.0 / np.maximum(distance, 1e-300)
        fixed = np.where(bound_score > 1.0, np.sign(s), 0).astype(np.int8)
    wall_i = np.nonzero(fixed)[0]
    ci = np.concatenate([pi[near], wall_i])
    cj = np.concatenate([pj[near], np.full(wall_i.size, n)])  # node n: the wall of the s bounds, never a rattler
    rattler = rattler_mask(n + 1, ci, cj, dim + 1)[:n]
    fixed[rattler] = 0
    n_stable = n - int(np.count_nonzero(rattler))
    nu = dim * (n_stable - 1) + 1 - int(np.count_nonzero(fixed))
    stable = np.flatnonzero(~rattler[pi] & ~rattler[pj])
    if n_stable < dim + 2 or nu < 1 or stable.size < nu:
        return None
    top = stable[np.argsort(-score[stable], kind="stable")[:nu]]
    return np.sort(pi[top] * n + pj[top]), rattler, fixed


def solve_active_set(rij, sigma2, pi, pj, n, contact_keys, rattler, *, s_bound, pinned, inflation_bounds,
                     feasibility=1e-12, max_pivots=None, rattler_s=None, fixed=None) -> LPSolution | None:
    """Solve the LP from a predicted active set by primal simplex pivots; None if that does not work out.

    The prediction is the isostatic contact network of the previous LP (``contact_keys`` = i*N + j of its contacts,
    ``rattler`` its rattlers). Its rows, as equalities, form a square system in the displacements of the stable,
    non-pinned particles and Gamma (N_c = d(N_s - 1) + 1 unknowns); a sparse LU gives the vertex and, with the
    transpose, the duals. While a dual is negative, that contact is released along the edge that keeps the others
    tight and the first pair row to close enters (the primal simplex method with the exact ratio test; every
    pivot refactorises). The vertex is returned only when it is *certified optimal*: all duals > 0, all rows and
    bounds satisfied (to ``feasibility``, absolute, sigma^2 units), i.e. primal and dual feasible with complementary
    slackness. Rattlers start from ``rattler_s`` ((N, d), e.g. an interior point, whose rattlers sit inside their
    cages; default 0) and are pushed out of rows they violate. ``fixed`` ((N, d) of -1 / 0 / +1) predicts s
    components of stable particles held at their lower / upper s bound: they leave the unknowns (one contact fewer
    each), and their bound multipliers must come out >= 0, else None (bounds never pivot). Anything else -- a
    rattler joining the network, another active s or a Gamma bound, a singular system, more than ``max_pivots``
    pivots -- returns None and the caller solves the LP with HiGHS. Near convergence the active set barely
    changes, and this replaces a HiGHS solve by a few factorisations (docs/calippso.md §5.4).
    """
    from scipy.sparse import csr_matrix
    from scipy.sparse.linalg import splu

    t0 = time.perf_counter()
    dim = rij.shape[1]
    if rattler[pinned]:
        return None
    free = ~rattler
    free[pinned] = False
    fixed = np.zeros((n, dim), dtype=np.int8) if fixed is None else np.where(free[:, None], fixed, 0).astype(np.int8)
    # unknowns: the s components of stable, non-pinned particles not held at a bound, then Gamma
    free_comp = np.repeat(free, dim) & (fixed.ravel() == 0)
    col_of = np.full(n * dim + 1, -1, dtype=np.int64)
    col_of[:-1][free_comp] = np.arange(np.count_nonzero(free_comp))
    nu = int(np.count_nonzero(free_comp)) + 1
    col_of[-1] = nu - 1
    if contact_keys.size != nu:
        return None  # not isostatic: no square system
    # the rows among stable particles, in the reduced columns (pinned particle and fixed components dropped)
    stable_rows = np.flatnonzero(~rattler[pi] & ~rattler[pj])
    start, index, value, rhs = constraint_rows(rij[stable_rows], sigma2[stable_rows], pi[stable_rows],
                                               pj[stable_rows], n)
    keep = col_of[index] >= 0
    row_id = np.repeat(np.arange(stable_rows.size), np.diff(start))
    a_all = csr_matrix((value[keep], (row_id[keep], col_of[index][keep])), shape=(stable_rows.size, nu))
    s_fixed = np.append(fixed.ravel() * float(s_bound), 0.0)
    held = s_fixed[index] != 0.0
    if np.any(held):  # a held component moves to the right-hand side
        rhs = rhs - np.bincount(row_id[held], weights=value[held] * s_fixed[index][held], minlength=rhs.size)
    key = pi[stable_rows] * n + pj[stable_rows]
    basis = np.flatnonzero(np.isin(key, contact_keys))
    if basis.size != nu:
        return None  # a predicted contact left the cutoff or involves a particle that is now a rattler
    if max_pivots is None:
        max_pivots = 10  # each pivot refactorises; beyond a few, HiGHS is cheaper
    e_inflation = np.zeros(nu)
    e_inflation[-1] = 1.0
    for pivot in range(max_pivots + 1):
        try:
            lu = splu(a_all[basis].tocsc())
        except RuntimeError:  # singular
            return None
        u = lu.solve(rhs[basis])
        lam = lu.solve(e_inflation, trans="T")
        if not (np.all(np.isfinite(u)) and np.all(np.isfinite(lam))):
            return None
        slack = rhs - a_all @ u
        if pivot == 0:
            in_basis = np.zeros(stable_rows.size, dtype=bool)
            in_basis[basis] = True
            if np.min(slack[~in_basis], initial=0.0) < -feasibility:
                return None  # the predicted vertex is not feasible at the new positions
        lo, hi = inflation_bounds
        if np.max(np.abs(u[:-1]), initial=0.0) > s_bound or not (lo - 1e-13 <= u[-1] <= hi):
            return None
        k = int(np.argmin(lam))
        if lam[k] > 0.0:
            break
        if pivot == max_pivots:
            return None
        # release row basis[k]: direction d with A_B d = -e_k; Gamma grows at rate -lam_k > 0
        e_k = np.zeros(nu)
        e_k[k] = -1.0
        d = lu.solve(e_k)
        rate = a_all @ d
        rate[basis] = 0.0
        blocking = np.flatnonzero(rate > 1e-14)
        if blocking.size == 0:
            return None  # unbounded edge: only the s bounds stop it
        ratios = np.maximum(slack[blocking], 0.0) / rate[blocking]
        j = int(np.argmin(ratios))
        step = ratios[j]
        if np.max(np.abs(u[:-1] + step * d[:-1]), initial=0.0) > s_bound:
            return None  # an s bound would block first
        basis[k] = blocking[j]
    if np.any(held):
        # bound multipliers: mu = -(A^T lambda)_j at an upper bound, +(A^T lambda)_j at a lower one, both >= 0
        row_lam = np.zeros(stable_rows.size)
        row_lam[basis] = lam
        at = np.zeros(n * dim + 1)
        np.add.at(at, index[held], value[held] * row_lam[row_id[held]])
        comps = np.flatnonzero(fixed.ravel())
        if np.any(-fixed.ravel()[comps] * at[comps] < 0.0):
            return None
    inflation = max(float(u[-1]), inflation_bounds[0])
    s = np.zeros((n, dim)) if rattler_s is None else np.clip(rattler_s, -s_bound, s_bound)
    s[pinned] = 0.0
    s.ravel()[free_comp] = u[:-1]
    s[fixed != 0] = fixed[fixed != 0] * float(s_bound)
    active = np.zeros(len(pi), dtype=bool)
    active[stable_rows[basis]] = True
    # every row of the LP: |r|^2 + 2 r.(s_i - s_j) - Gamma sigma^2 >= 0. Rattlers (columns without active rows)
    # may be pushed away from a neighbour their cage wall has come to touch; this keeps the solution optimal.
    for _ in range(20):
        slack = np.einsum("ij,ij->i", rij, rij + 2.0 * (s[pi] - s[pj])) - inflation * sigma2
        bad = (slack < feasibility) & ~active
        if not np.any(bad):
            break
        if np.any(bad & ~rattler[pi] & ~rattler[pj] & (slack < -feasibility)):
            return None
        for k in np.flatnonzero(bad & (rattler[pi] | rattler[pj])):
            push = 2.0 * (feasibility - slack[k]) / (2.0 * float(np.dot(rij[k], rij[k])))
            if rattler[pi[k]]:
                s[pi[k]] += push * rij[k]
            else:
                s[pj[k]] -= push * rij[k]
    else:
        return None
    if np.min(slack[~active], initial=0.0) < -feasibility or np.max(np.abs(s)) > s_bound:
        return None
    duals = np.zeros(len(pi))
    duals[stable_rows[basis]] = lam
    return LPSolution(s, inflation, duals, time.perf_counter() - t0, f"active-set+{pivot}")
