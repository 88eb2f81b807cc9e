"""The active set of a CALiPPSO LP: predicting its optimal vertex (from an interior point, or from the previous LP's
contact network) and certifying the prediction by sparse LU and a few primal simplex pivots (docs/calippso.md §5.2,
§5.4).
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..core.rattlers import rattler_mask
from .constraints import as_pins, constraint_rows, pair_keys, particle_force_sums
from .highs import highs_model
from .solution import LPSolution


def network_prediction(contact, rattler, pi, pj, n):
    """The next LP's predicted active set from this LP's isostatic contact network: ``(contact keys
    (:func:`~.constraints.pair_keys`) of the contacts among non-rattlers, sorted; rattler mask)``, the arguments
    :func:`solve_active_set` takes."""
    stable = contact & ~rattler[pi] & ~rattler[pj]
    return np.sort(pair_keys(pi, pj, n)[stable]), rattler.copy()


def vertex_prediction(contact, duals, s, s_bound, rij, pi, pj, n, pinned):
    """The next LP's predicted active set from this LP's vertex when some of its stable s components are held at
    their bound: ``(contact keys, rattler mask, held)`` (``held`` (N, d): -1 / +1 at the lower / upper bound, else 0),
    or None unless the contacts among stable particles and the held components are together one square system
    (d (N_s - 1) + 1 unknowns).

    A component is held if it is at its bound and the contact forces on it do not balance (> 1e-6 of the mean force:
    the bound pushes back); a rattler's components rest at a bound with no force. Particles are stable if they are
    in the (d+1)-core of the contact graph with the bounds as a wall, so a particle pressed against its bound is not a
    rattler. The next LP has a wider bound (docs §1.5): the held components are bound rows of the predicted basis,
    which :func:`solve_active_set` releases by pivots where they no longer bind."""
    weight = np.where(contact, duals, 0.0)
    if not np.any(weight > 0):
        return None
    mean_force = float(np.mean(weight[weight > 0] * np.linalg.norm(rij[weight > 0], axis=1)))
    pushed = np.abs(particle_force_sums(rij, weight, pi, pj, n)) > 1e-6 * mean_force
    held = np.where(pushed & (np.abs(s) >= (1.0 - 1e-9) * s_bound), np.sign(s), 0).astype(np.int8)
    pins = as_pins(pinned, n, s.shape[1])
    held.ravel()[pins.columns] = 0
    rattler, _, nu = _walled_network(pi[contact], pj[contact], held, n, pins)
    stable = contact & ~rattler[pi] & ~rattler[pj]
    if int(np.count_nonzero(stable)) != nu:
        return None
    return np.sort(pair_keys(pi, pj, n)[stable]), rattler, held


def _walled_network(ci, cj, held, n, pins=None):
    """Rattlers of the contact graph (pairs ``ci``-``cj``) with the s bounds as a wall: node n, never a rattler, and
    each held component (``held`` (N, d), nonzero) a contact with it, so a particle pressed against its bound is
    stable. A container's wall nodes (``pins``, :class:`~.constraints.Pins`) are never rattlers either. Clears
    ``held`` on the rattlers, in place. Returns ``(rattler mask, N_s, contacts among stable particles that make the
    square system with the held components: d N_s - z + 1 - held)``, z the zero modes (d in a periodic box)."""
    dim = held.shape[1]
    wall_i = np.nonzero(held)[0]
    pins = as_pins(0, n, dim) if pins is None else pins
    # the bound (node n) and a container's wall nodes stay in the core: with fewer than d + 1 held components among
    # stable particles the bound node would be peeled, and with it every particle that the bound holds against d
    # contacts (docs/calippso.md §5.4)
    walls = np.zeros(n + 1, dtype=np.int64)
    walls[pins.spheres:] = dim + 1
    rattler = rattler_mask(n + 1, np.concatenate([ci, wall_i]), np.concatenate([cj, np.full(wall_i.size, n)]),
                           dim + 1, walls)[:n]
    held[rattler] = 0
    n_stable = pins.spheres - int(np.count_nonzero(rattler[:pins.spheres]))
    return rattler, n_stable, dim * n_stable - pins.zero_modes + 1 - int(np.count_nonzero(held))


def interior_point_prediction(pi, pj, n, dim, sigma2, duals, slack, s=None, col_dual=None, s_bound=None,
                              pinned=None):
    """The vertex an interior point of the LP is heading for: ``(contact keys, rattler mask, fixed)``, or None.

    On the central path lambda_k * slack_k is the same small number for every row, so the score
    (lambda_k sigma_k^2 M) / (slack_k / sigma_k^2) (M rows; both factors dimensionless, the first ~1 on an active
    row) grows without bound on the optimal active set and vanishes off it. An s component gets the same kind of
    score from its bound multiplier |col_dual| and its distance to the bound (with ``s``, ``col_dual`` and
    ``s_bound``): those scoring > 1 are predicted held at the bound (``fixed``: -1 / +1, else 0). Rows scoring > 1
    and the held components (as contacts with a wall) give the contact graph and its rattlers (outside the
    (d+1)-core); of the rows among stable particles the d (N_s - 1) + 1 - (held components) with the highest score,
    made to cover every unknown (:func:`covering_rows`), are the predicted vertex, for :func:`solve_active_set` to
    certify.
    """
    m = len(pi)
    score = duals * sigma2 * m / np.maximum(slack / sigma2, 1e-300)
    near = score > 1.0
    fixed = np.zeros((n, dim), dtype=np.int8)
    if s is not None and s_bound is not None and math.isfinite(s_bound):
        # scales of a bound multiplier (~ 2 sigma lambda, A's entries are 2 r) and of a distance to the bound (s_bound)
        sigma = math.sqrt(float(np.median(sigma2)))
        distance = np.maximum(s_bound - np.abs(s), 0.0) / s_bound
        # a multiplier at round-off (a rattler's component resting at its bound) holds nothing, even at distance 0
        multiplier = np.abs(col_dual)
        multiplier = np.where(multiplier > DUAL_ZERO * sigma * float(np.max(duals, initial=0.0)), multiplier, 0.0)
        bound_score = multiplier * m * sigma / 2.0 / np.maximum(distance, 1e-300)
        fixed = np.where(bound_score > 1.0, np.sign(s), 0).astype(np.int8)
    rattler, n_stable, nu = _walled_network(pi[near], pj[near], fixed, n,
                                            None if pinned is None else as_pins(pinned, n, dim))
    stable = np.flatnonzero(~rattler[pi] & ~rattler[pj])
    if n_stable < dim + 2 or nu < 1 or stable.size < nu:
        return None
    free = np.repeat(~rattler, dim) & (fixed.ravel() == 0)
    free[as_pins(0 if pinned is None else pinned, n, dim).columns] = False
    top = covering_rows(stable[np.argsort(-score[stable], kind="stable")], nu, pi, pj, free, dim)
    return np.sort(pair_keys(pi, pj, n)[top]), rattler, fixed


def covering_rows(order, nu, pi, pj, free, dim):
    """The ``nu`` first rows of ``order`` (pair rows, the likeliest contact first) made a structurally nonsingular
    basis of the unknowns ``free`` (mask of the N d s components; the held and pinned ones excluded) and Gamma: the
    rows a maximum matching of rows to unknowns leaves unmatched are replaced, for each unknown left uncovered, by
    the first row further down ``order`` that touches its sphere. A stable sphere whose rows all rank below the
    first ``nu`` leaves its columns empty, and the LU refuses the prediction; at N = 1e4 and 16384 most uncertified
    predictions were such, and once covered they were certified in 6 and 90 pivots (docs/calippso.md §5.2). The
    first ``nu`` rows unchanged where they are nonsingular already, or where no row can cover an empty column."""
    from scipy.sparse import csr_matrix
    from scipy.sparse.csgraph import maximum_bipartite_matching

    top = order[:nu]
    n_free = int(np.count_nonzero(free))
    if n_free + 1 != nu:  # not the square system the prediction is
        return top
    column = np.full(free.size, -1, dtype=np.int64)
    column[free] = np.arange(n_free)
    comps = np.concatenate([pi[top, None] * dim + np.arange(dim), pj[top, None] * dim + np.arange(dim)], axis=1)
    cols = column[comps]
    r = np.repeat(np.arange(top.size), 2 * dim).reshape(cols.shape)
    ok = cols >= 0
    rows = np.concatenate([r[ok], np.arange(top.size)])
    cols = np.concatenate([cols[ok], np.full(top.size, n_free)])  # every pair row has Gamma's column
    incidence = csr_matrix((np.ones(rows.size), (rows, cols)), shape=(top.size, nu))
    match = maximum_bipartite_matching(incidence, perm_type="column")
    if np.all(match >= 0):
        return top
    covered = np.zeros(nu, dtype=bool)
    covered[match[match >= 0]] = True
    empty = np.flatnonzero(~covered[:-1])  # Gamma's column is never left empty while a row is unmatched
    need = np.zeros(free.size // dim, dtype=np.int64)
    np.add.at(need, np.flatnonzero(free)[empty] // dim, 1)
    added = []
    for row in order[nu:]:
        sphere = pi[row] if need[pi[row]] > 0 else pj[row] if need[pj[row]] > 0 else -1
        if sphere >= 0:
            need[sphere] -= 1
            added.append(row)
            if len(added) == empty.size:
                return np.concatenate([top[match >= 0], np.asarray(added, dtype=top.dtype)])
    return top


#: Pivots an active-set solve may take where HiGHS has no warm start to offer (an interior point's vertex; every LP
#: from N = 4096 on, the previous network's capped by network_pivot_limit): each costs three sparse solves, a small
#: fraction of an interior-point solve, and a prediction is seldom off by more than ~100 rows (docs/calippso.md
#: §5.2). With a warm start at hand, 10 (the default).
MAX_PIVOTS = 500
#: Duals above -DUAL_ZERO x their median magnitude count as >= 0 (round-off of an exactly zero force).
DUAL_ZERO = 1e-12
#: Primal pivots by the steepest dual before Bland's rule takes over (which cannot cycle on a degenerate vertex).
BLAND_AFTER = 50
#: Pivots between two checks of an active-set solve's pace: a pivot may fix several negative duals or none, and
#: their count can rise for a while, so the count alone does not say how many pivots are still needed; with the pace
#: over this many it does (docs/calippso.md §5.4).
PROGRESS_EVERY = 100
#: Pivots before an active-set solve's pace is first checked. Until 2026-12-07 an attempt with more than 10 negative
#: duals per pivot left was given up before it pivoted; but a nearly singular basis has nearly every dual wrong, and
#: pivots put them right: at N = 1e4 10 667 in 6 pivots, at N = 16384 8387 in 90 (docs/calippso.md §5.4).
PROBE_PIVOTS = 20
#: Row replacements between two factorisations of the basis matrix (BasisInverse), at least: each adds two vectors to
#: every later solve, so a fresh LU pays off after a few dozen at small N. A large basis waits until the update
#: vectors hold as many numbers as its LU factors, because its LU fills in faster than N grows (docs/calippso.md §5.4).
REFACTOR_EVERY = 50


#: Pivots the shortcut from the previous network is taken to need for each contact the LP before it changed: it is
#: tried only where the last LP's changes times this fit in :func:`network_pivot_limit` (40 changes at N = 1e4). On
#: the held-out N = 1e4 run 24 of 25 attempts after LPs that changed <= 40 contacts succeeded, 5 of 22 after 41-66,
#: and those 5 cost more than a HiPO vertex; after 70-200 all 42 attempts on record failed (docs/calippso.md §5.4).
PIVOTS_PER_CHANGE = 5


def network_pivot_limit(n: int) -> int:
    """Pivots allowed to an active-set solve of the previous LP's network where HiGHS has no warm start (N
    particles): :data:`MAX_PIVOTS` up to N = 4000, then falling as 1/N to 100 (200 at N = 10^4, 122 at N = 16384).

    Its alternative is one cold HiPO solve, and a pivot's share of that grows with N (the basis's LU fills in): at
    N = 10^4 a pivot costs 0.6-2 s (its LU and updates included) and the LP 75-95 s, so the cap bounds a failed
    attempt's loss to a few such solves, where 500 pivots in each of three attempts cost over 20 (docs/calippso.md
    §5.4). An interior point's vertex keeps :data:`MAX_PIVOTS`: its alternative is a crossover,
    which costs several cold solves.
    """
    return max(100, min(MAX_PIVOTS, 2_000_000 // max(int(n), 1)))


class BasisInverse:
    """Solves with the square matrix of the rows ``basis`` of ``matrix`` (sparse, CSR), while rows are replaced.

    One sparse LU, then the product form of the inverse: replacing row k by a row that differs by v is the rank-one
    change B' = B + e_k v^T, whose inverse Sherman-Morrison gives from B's with c = B^-1 e_k, w = B^-T v and
    delta = 1 + v.c. A replacement then costs two solves instead of a factorisation; every ``refactor_every``
    replacements (:data:`REFACTOR_EVERY`, or more for a large basis) the current rows are factorised afresh. Raises
    RuntimeError when the matrix is singular.
    """

    def __init__(self, matrix, basis: np.ndarray):
        from scipy.sparse.csgraph import structural_rank

        self.matrix, self.basis = matrix, basis
        # a matching says what the LU would find only after flailing: at N = 16384 a predicted basis with one
        # stable sphere's columns empty took SuperLU 83 CPU-s to refuse, its structural rank 0.15 s (docs §5.4)
        rank = structural_rank(matrix[basis].tocsr())
        if rank < basis.size:
            raise RuntimeError(f"structurally singular: structural rank {rank} of {basis.size}")
        self._factorise()

    def _factorise(self) -> None:
        from scipy.sparse.linalg import splu

        self.lu = splu(self.matrix[self.basis].tocsc())
        self.updates: list[tuple[np.ndarray, np.ndarray, np.ndarray, float]] = []  # (c, v, w, delta)
        # the product form costs 2 n numbers per update and solve, the LU solve its factors' nonzeros
        self.refactor_every = max(REFACTOR_EVERY, (self.lu.L.nnz + self.lu.U.nnz) // (2 * self.basis.size))

    def solve(self, b: np.ndarray) -> np.ndarray:
        """x with B x = b."""
        x = self.lu.solve(b)
        for c, v, _, delta in self.updates:
            x = x - c * (float(v @ x) / delta)
        return x

    def solve_transposed(self, b: np.ndarray) -> np.ndarray:
        """y with B^T y = b."""
        y = self.lu.solve(b, trans="T")
        for c, _, w, delta in self.updates:
            y = y - w * (float(c @ b) / delta)
        return y

    def replace(self, k: int, row: int, column: np.ndarray | None = None) -> None:
        """Put row ``row`` of the matrix in place of basis position ``k``; ``column`` = B^-1 e_k if the caller has
        it already (a primal pivot's edge direction is its negative)."""
        v = (self.matrix[row] - self.matrix[self.basis[k]]).toarray().ravel()
        c = column
        if c is None:
            e_k = np.zeros(self.basis.size)
            e_k[k] = 1.0
            c = self.solve(e_k)
        delta = 1.0 + float(v @ c)
        if not abs(delta) > 1e-12 * max(1.0, float(np.max(np.abs(c)))):
            raise RuntimeError("singular basis after a row replacement")
        w = self.solve_transposed(v)
        self.basis[k] = row
        if len(self.updates) + 1 >= self.refactor_every:
            self._factorise()
        else:
            self.updates.append((c, v, w, delta))


def _place_rattlers(rij, sigma2, pi, pj, s, inflation, rattler, s_bound, margin) -> bool:
    """Move the rattlers' s (in place) so that every row with a rattler holds with ``margin``; False if impossible.

    The stable particles and Gamma are fixed, so the rows are linear in the rattlers' s alone: a small LP (no
    objective) over the rattlers' components within the s bounds, solved by HiGHS (simplex: a tiny LP).
    """
    import highspy
    from scipy.sparse import csr_matrix

    n, dim = s.shape
    rows = np.flatnonzero(rattler[pi] | rattler[pj])
    movers = np.flatnonzero(rattler)
    col = np.full(n, -1, dtype=np.int64)
    col[movers] = np.arange(movers.size)
    r = rij[rows]
    # |r|^2 + 2 r.(s_i - s_j) - Gamma sigma^2 >= margin; the stable end's term moves to the bound
    fixed_i = np.where(rattler[pi[rows]], 0.0, 1.0)[:, None] * s[pi[rows]]
    fixed_j = np.where(rattler[pj[rows]], 0.0, 1.0)[:, None] * s[pj[rows]]
    lower = margin + inflation * sigma2[rows] - np.einsum("ij,ij->i", r, r + 2.0 * (fixed_i - fixed_j))
    entries_r, entries_c, entries_v = [], [], []
    for end, sign in ((pi[rows], 2.0), (pj[rows], -2.0)):
        moving = rattler[end]
        for axis in range(dim):
            entries_r.append(np.flatnonzero(moving))
            entries_c.append(col[end[moving]] * dim + axis)
            entries_v.append(sign * r[moving, axis])
    a = csr_matrix((np.concatenate(entries_v), (np.concatenate(entries_r), np.concatenate(entries_c))),
                   shape=(rows.size, movers.size * dim))
    ncol = movers.size * dim
    h = highspy.Highs()
    h.setOptionValue("output_flag", False)
    h.setOptionValue("solver", "simplex")
    h.setOptionValue("threads", 1)
    h.passModel(highs_model(np.zeros(ncol), np.full(ncol, -s_bound), np.full(ncol, s_bound), lower,
                            np.full(rows.size, np.inf), a.indptr, a.indices, a.data))
    h.run()
    if h.getModelStatus() != highspy.HighsModelStatus.kOptimal:
        return False
    s[movers] = np.asarray(h.getSolution().col_value).reshape(movers.size, dim)
    return True


def _with_bound_rows(a, rhs, nu, s_bound, inflation_bounds):
    """The pair rows ``a`` (CSR, nu columns: the free s components, then Gamma) and their right-hand side, with the
    rows s_c <= s_bound and -s_c <= s_bound of every free component and Gamma <= hi, -Gamma <= -lo (finite bounds
    only) appended: every constraint of the LP as a row a . u <= b."""
    from scipy.sparse import csr_matrix, vstack

    k = nu - 1
    lo, hi = inflation_bounds
    cols = [np.arange(k), np.arange(k)]
    vals = [np.ones(k), -np.ones(k)]
    b = [np.full(k, float(s_bound)), np.full(k, float(s_bound))]
    for value, bound in ((1.0, hi), (-1.0, -lo)):
        if np.isfinite(bound):
            cols.append(np.array([k]))
            vals.append(np.array([value]))
            b.append(np.array([bound]))
    cols, vals = np.concatenate(cols), np.concatenate(vals)
    bounds = csr_matrix((vals, (np.arange(cols.size), cols)), shape=(cols.size, nu))
    return vstack([a, bounds], format="csr"), np.concatenate([rhs, *b])


def _fail(why: list[str] | None, reason: str) -> None:
    if why is not None:
        why.append(reason)
    return None


#: Times an active-set solve may turn the predicted rattlers that found no place into members of the network. Each round
#: costs a factorisation and pivots from the vertex the round before reached, out of the solve's one pivot budget, which
#: is what bounds the cost; the cap only stops a solve that keeps finding new stuck rattlers. At N = 1e4, sigma = 0.3 a
#: vertex needed four rounds (20, 5, 4, 2 rattlers): 107 CPU-s, where the fallback cost 355 (docs/calippso.md §5.4).
MAX_PROMOTIONS = 8


def solve_active_set(rij, sigma2, pi, pj, n, contact_keys, rattler, *, s_bound, pinned, inflation_bounds,
                     feasibility=1e-12, max_pivots=None, rattler_s=None, fixed=None,
                     why: list[str] | None = None) -> LPSolution | None:
    """Solve the LP from a predicted active set by simplex pivots; None if that does not work out.

    The prediction is the isostatic contact network of the previous LP (``contact_keys``: the pair keys of its
    contacts, ``rattler`` its rattlers), or a network with components held at their bound (``fixed``, below). Its
    rows, as equalities, form a square system in the displacements of the stable, non-pinned particles and Gamma
    (N_c + held components = d(N_s - 1) + 1 unknowns); a sparse LU gives the vertex and, with the transpose, the
    duals. The bounds of the unknowns (s_bound, the Gamma bounds) are rows as well, so the pivots below treat a
    bound like a contact. While a dual is negative, that row is released along the edge that keeps the others tight
    and the first row to close enters (primal simplex, exact ratio test). A vertex beyond other rows with duals >= 0
    is repaired by dual simplex pivots (the most violated row enters, the dual ratio test picks the one that
    leaves); beyond other rows with negative duals, those rows are relaxed until primal pivots have made the duals
    >= 0, then restored by dual pivots. Every pivot updates the basis matrix's LU (:class:`BasisInverse`). The
    vertex is returned only when it is *certified optimal*: all duals >= 0 (a zero one is a contact without force,
    at a degenerate optimum), all rows and bounds satisfied (to ``feasibility``, absolute, sigma^2 units), i.e.
    primal and dual feasible with complementary slackness. Rattlers start from ``rattler_s`` ((N, d), e.g. an
    interior point, whose rattlers sit inside their cages; default 0) and are pushed out of rows they violate, or
    placed by a small LP when pushing does not settle them; rattlers that find no place join the network with their
    d tightest rows and the solve starts again from the vertex reached (:data:`MAX_PROMOTIONS` times). ``fixed``
    ((N, d) of -1 / 0 / +1) predicts s components of stable particles held at their lower / upper s bound: each
    one's bound row starts in the basis in place of a contact, and leaves it by a pivot like a contact where its
    multiplier is negative (the returned solution's ``held`` says which components the final vertex holds). Anything
    else -- a singular system, more than ``max_pivots`` pivots in all attempts -- returns None and the caller solves
    the LP with HiGHS; the reasons are appended to ``why`` (a list, if given), for the LP's failure log. Near
    convergence the active set barely changes, and this replaces a HiGHS solve by a factorisation and a few solves
    (docs/calippso.md §5.4).
    """
    why = [] if why is None else why
    t0 = time.perf_counter()
    # one budget for the whole solve: at N = 10^4 three attempts of the full budget cost several HiGHS solves
    # (docs §5.4)
    budget = allowed = 10 if max_pivots is None else max_pivots
    for promotion in range(MAX_PROMOTIONS + 1):
        stuck: dict = {}
        sol = _solve_vertex(rij, sigma2, pi, pj, n, contact_keys, rattler, s_bound=s_bound, pinned=pinned,
                            inflation_bounds=inflation_bounds, feasibility=feasibility, max_pivots=budget,
                            rattler_s=rattler_s, fixed=fixed, why=why, stuck=stuck)
        budget -= stuck.get("pivots", 0)
        if sol is not None or "rattlers" not in stuck or promotion == MAX_PROMOTIONS:
            if sol is not None:
                sol.solve_time = time.perf_counter() - t0  # the attempts before a promotion included
                sol.method += f"+{promotion}promoted" if promotion else ""
            return sol
        if budget <= 0:
            return _fail(why, f"no pivots left of {allowed} to place the rattlers again")
        promoted = _promote(rij, sigma2, pi, pj, n, rattler, stuck)
        if promoted is None:
            return _fail(why, "a predicted rattler that found no place has fewer than d rows with the network")
        extra_keys, rattler = promoted
        if "vertex_keys" in stuck:
            # the next round starts from the vertex this one reached, where the promoted rattlers' rows leave every
            # other unknown and dual as they were, so it pivots only for what the newcomers change; from the first
            # prediction it would pay this round's pivots again (docs §5.4)
            contact_keys, fixed = stuck["vertex_keys"], stuck["vertex_held"]
        contact_keys = np.sort(np.concatenate([contact_keys, extra_keys]))
        why.append(f"{extra_keys.size // rij.shape[1]} rattler(s) joined the network")
    return None


def _promote(rij, sigma2, pi, pj, n, rattler, stuck):
    """The predicted rattlers that found no place at the vertex, made members of the network: each gets its d rows
    with the lowest slack at that vertex (with partners in the network) as predicted contacts. Returns ``(the new
    rows' keys, the new rattler mask)``, or None when a rattler has fewer than d such rows."""
    dim = rij.shape[1]
    s, inflation, movers = stuck["s"], stuck["inflation"], stuck["rattlers"]
    rattler = rattler.copy()
    rattler[movers] = False
    slack = _slack(rij, sigma2, pi, pj, s, inflation)
    keys = []
    all_keys = pair_keys(pi, pj, n)
    taken = np.zeros(len(pi), dtype=bool)
    for q in movers:
        rows = np.flatnonzero(((pi == q) | (pj == q)) & ~rattler[pi] & ~rattler[pj] & ~taken)
        if rows.size < dim:
            return None
        best = rows[np.argsort(slack[rows], kind="stable")[:dim]]
        taken[best] = True
        keys.append(all_keys[best])
    return np.concatenate(keys), rattler


def _solve_vertex(rij, sigma2, pi, pj, n, contact_keys, rattler, *, s_bound, pinned, inflation_bounds,
                  feasibility, max_pivots, rattler_s, fixed, why, stuck):
    """One attempt of :func:`solve_active_set`, of at most ``max_pivots`` pivots; ``stuck`` receives the pivots
    taken (``pivots``) and, when only the rattlers' placement fails, the vertex (``s``, ``inflation``; as a
    prediction ``vertex_keys``, ``vertex_held``) and the rattlers still in violated rows (``rattlers``)."""
    t0 = time.perf_counter()
    try:
        system = _contact_system(rij, sigma2, pi, pj, n, contact_keys, rattler, s_bound, pinned, inflation_bounds,
                                 fixed)
        u, lam, pivots, relaxed, bound_pivots = _pivot(system, feasibility, max_pivots)
        stuck["pivots"] = pivots
        inflation = max(float(u[-1]), inflation_bounds[0])
        s = _vertex_displacements(system, u, rattler_s, s_bound, pinned, (n, rij.shape[1]))
        contact_rows = system.stable_rows[system.basis[system.basis < system.m_pair]]
        active = np.zeros(len(pi), dtype=bool)
        active[contact_rows] = True
        held = _held_at_vertex(system, n, rij.shape[1])
        slack = _settle_rattlers(rij, sigma2, pi, pj, s, inflation, rattler, active, s_bound, feasibility, stuck)
    except _NoVertex as failure:
        # only the rattlers found no place: the vertex stands, as the next round's prediction, unless a Gamma bound
        # is in its basis, which no prediction holds
        if "rattlers" in stuck and np.count_nonzero(held) + contact_rows.size == system.basis.size:
            stuck.update(vertex_keys=pair_keys(pi, pj, n)[contact_rows], vertex_held=held)
        return _fail(why, str(failure))
    if not (np.min(slack[~active], initial=0.0) >= -feasibility and np.all(np.abs(s) <= s_bound)):  # NaN fails
        return _fail(why, "a row or an s bound is violated at the vertex")
    duals = np.zeros(len(pi))
    duals[contact_rows] = np.maximum(lam[system.basis < system.m_pair], 0.0)
    method = f"active-set+{pivots}" + (f"+{relaxed}relaxed" if relaxed else "") + (
        f"+{bound_pivots}bounds" if bound_pivots else "")
    return LPSolution(s, inflation, duals, time.perf_counter() - t0, method, held=held)


class _NoVertex(Exception):
    """Why an active-set attempt gives up (its message goes to the caller's ``why``)."""


@dataclass
class _ContactSystem:
    """A predicted vertex as a linear system: every constraint of the LP among stable particles as a row a . u <= b
    in the unknowns u (the free s components, then Gamma), the ``m_pair`` pair rows first, then the bounds of the
    unknowns; the rows of the predicted contacts and of the components predicted at a bound are the initial
    ``basis``."""

    a: Any  # (rows, nu) scipy CSR
    rhs: np.ndarray
    m_pair: int
    basis: np.ndarray  # rows of a, one per unknown: replaced in place by the pivots
    stable_rows: np.ndarray  # the LP's rows among stable particles, in the order of a's pair rows
    free_comp: np.ndarray  # (N d,) the s components that are unknowns


def _contact_system(rij, sigma2, pi, pj, n, contact_keys, rattler, s_bound, pinned, inflation_bounds,
                    fixed) -> _ContactSystem:
    """The predicted vertex's linear system; raises :class:`_NoVertex` when the prediction is no square system."""
    from scipy.sparse import csr_matrix

    dim = rij.shape[1]
    pins = as_pins(pinned, n, dim)
    if np.any(rattler[pins.pinned_spheres()]):
        raise _NoVertex("the pinned particle is predicted a rattler")
    # unknowns: the s components of stable particles that are not pinned (nor a wall), then Gamma
    free_comp = np.repeat(~rattler, dim)
    free_comp[pins.columns] = False
    col_of = np.full(n * dim + 1, -1, dtype=np.int64)
    col_of[:-1][free_comp] = np.arange(np.count_nonzero(free_comp))
    nu = int(np.count_nonzero(free_comp)) + 1
    col_of[-1] = nu - 1
    # a component predicted at its bound is that bound's row in the basis, which a pivot can release
    held = np.zeros(n * dim, dtype=np.int8) if fixed is None else np.where(free_comp, np.ravel(fixed), 0)
    held_cols = col_of[:-1][held != 0]
    held_rows = np.where(held[held != 0] > 0, held_cols, (nu - 1) + held_cols)  # after the pair rows, see below
    if contact_keys.size + held_rows.size != nu:  # not isostatic: no square system
        raise _NoVertex(f"{contact_keys.size} predicted contacts and {held_rows.size} held components for {nu} "
                        "unknowns")
    # the rows among stable particles, in the reduced columns (the pinned particle dropped)
    stable_rows = np.flatnonzero(~rattler[pi] & ~rattler[pj])
    start, index, value, rhs = constraint_rows(rij[stable_rows], sigma2[stable_rows], pi[stable_rows],
                                               pj[stable_rows], n)
    keep = col_of[index] >= 0
    row_id = np.repeat(np.arange(stable_rows.size), np.diff(start))
    a_all = csr_matrix((value[keep], (row_id[keep], col_of[index][keep])), shape=(stable_rows.size, nu))
    # the bounds of the unknowns as rows too (s_c <= s_bound for every free component c, then -s_c <= s_bound, then
    # Gamma within its bounds, after the pair rows), so that a bound a pivot runs into enters the basis like a
    # contact (docs §5.4)
    a_all, rhs_all = _with_bound_rows(a_all, rhs, nu, s_bound, inflation_bounds)
    key = pair_keys(pi, pj, n)[stable_rows]
    basis = np.flatnonzero(np.isin(key, contact_keys))
    if basis.size != contact_keys.size:  # a predicted contact left the cutoff or involves a particle now a rattler
        raise _NoVertex(f"{contact_keys.size - basis.size} predicted contacts are not rows among stable particles")
    basis = np.concatenate([basis, stable_rows.size + held_rows])
    return _ContactSystem(a_all, rhs_all, stable_rows.size, basis, stable_rows, free_comp)


def _pivot(system: _ContactSystem, feasibility: float, max_pivots: int):
    """Pivot from the predicted vertex to a certified optimal one (the composite primal-dual simplex of
    :func:`solve_active_set`, docs §5.4). Returns ``(u, lambda, pivots, rows relaxed, bound rows entered)``; raises
    :class:`_NoVertex` when that fails."""
    a_all, rhs, basis = system.a, system.rhs, system.basis
    e_inflation = np.zeros(basis.size)
    e_inflation[-1] = 1.0
    try:
        binv = BasisInverse(a_all, basis)
    except RuntimeError as singular:
        raise _NoVertex(f"singular contact system ({singular})") from None
    # rows violated while duals are negative too: their right-hand side is relaxed so that the vertex is feasible,
    # primal pivots optimise that relaxed LP, then the relaxation is removed and dual pivots (the duals are >= 0 by
    # then) restore those rows (a composite primal-dual simplex, docs §5.4)
    relax = np.zeros(rhs.size)
    relaxed = bound_pivots = 0  # for the method string: how the vertex was reached
    checked = None  # (pivot, negative duals) at the last check of the pace
    due = PROBE_PIVOTS  # pivots from there to the next check
    for pivot in range(max_pivots + 1):
        b = rhs + relax
        u = binv.solve(b[basis])
        lam = binv.solve_transposed(e_inflation)
        if not (np.all(np.isfinite(u)) and np.all(np.isfinite(lam))):
            raise _NoVertex(f"non-finite solution after {pivot} pivots")
        slack = b - a_all @ u
        slack[basis] = 0.0
        r = int(np.argmin(slack))
        if slack[r] < -feasibility:
            # a predicted vertex beyond some other row (a degenerate interior point ranks a few rows wrongly): dual
            # simplex pivots while the duals are feasible, the most violated row entering
            violated = int(np.count_nonzero(slack < -feasibility))
            zero = _zero_dual(lam)
            if np.min(lam) < -zero:
                bad = slack < -feasibility
                relax[bad] -= 2.0 * slack[bad]  # the row then has slack |violation| > 0, not a degenerate block
                relaxed += int(np.count_nonzero(bad))
                slack[bad] = -slack[bad]
        if slack[r] < -feasibility and not np.any(relax):
            if pivot == max_pivots:
                raise _NoVertex(f"{violated} rows still violated after {max_pivots} pivots")
            bound_pivots += _dual_pivot(binv, a_all, r, lam, pivot, system.m_pair)
            continue
        k = int(np.argmin(lam))
        # optimal once no dual is negative; an exact (round-off) zero is a contact without force at a degenerate
        # optimum, which no pivot improves
        zero = _zero_dual(lam)
        if lam[k] >= -zero:
            if np.any(relax):  # the relaxed LP is optimal: back to the true rows, dual pivots from here
                relax[:] = 0.0
                continue
            return u, lam, pivot, relaxed, bound_pivots
        negative = np.flatnonzero(lam < -zero)
        if pivot >= BLAND_AFTER:  # a degenerate vertex can cycle: Bland's rule, the lowest row index leaves
            k = int(negative[np.argmin(basis[negative])])
        if pivot == max_pivots:
            raise _NoVertex(f"{negative.size} duals still negative (lowest {lam[k]:.1e} of a median "
                            f"{float(np.median(lam)):.1e}) after {max_pivots} pivots")
        if checked is None:
            checked = (pivot, negative.size)
        elif pivot - checked[0] >= due:
            # a prediction further off than the pivots left, and too slow at its pace since the last check to be
            # done in them, is given up now rather than after them: at large N the pivots left can cost more than
            # a HiGHS solve. (Either alone is no reason: a pivot can fix several duals, and a few dozen left are
            # worth the pivots whatever the recent pace.)
            pace = (checked[1] - negative.size) / (pivot - checked[0])  # duals fixed per pivot
            left = max_pivots - pivot
            if negative.size > left and negative.size > pace * left:
                raise _NoVertex(f"{negative.size} duals still negative after {pivot} pivots ({checked[1]} after "
                                f"{checked[0]}): too slow for the {max_pivots - pivot} left")
            checked, due = (pivot, negative.size), PROGRESS_EVERY
        bound_pivots += _primal_pivot(binv, a_all, k, slack, pivot, system.m_pair)
    raise _NoVertex(f"relaxed rows not restored after {max_pivots} pivots")


def _zero_dual(lam) -> float:
    """The largest |dual| that counts as 0: round-off of an exactly zero force (DUAL_ZERO of the median)."""
    return DUAL_ZERO * float(np.median(np.abs(lam)))


def _dual_pivot(binv: BasisInverse, a_all, r: int, lam, pivot: int, m_pair: int) -> int:
    """The violated row ``r`` enters the basis, the row the dual ratio test picks leaves. Returns 1 if ``r`` is a
    bound row, else 0."""
    # leaving row k: Gamma falls by lam_k per unit of row k's slack, row r closes at alpha_k per unit
    alpha = binv.solve_transposed(a_all[r].toarray().ravel())
    # a tiny alpha_k would make the new basis (nearly) singular
    candidates = np.flatnonzero(alpha > max(1e-14, 1e-9 * float(np.max(np.abs(alpha)))))
    if candidates.size == 0:
        raise _NoVertex(f"a violated row cannot be satisfied after {pivot} pivots: the LP looks infeasible")
    # Harris's ratio test: of the rows whose dual reaches 0 within round-off of the first, the largest alpha. At a
    # degenerate vertex many duals are 0, some -1e-18; ranked by lam / alpha as they are, such a one with a tiny
    # alpha came first, and the new basis was singular (docs §5.4)
    lam_c = np.maximum(lam[candidates], 0.0)
    alpha_c = alpha[candidates]
    zero = _zero_dual(lam)
    tied = np.flatnonzero(lam_c / alpha_c <= np.min((lam_c + zero) / alpha_c))
    k = int(candidates[tied[np.argmax(alpha_c[tied])]])
    try:
        binv.replace(k, r)
    except RuntimeError:
        raise _NoVertex(f"singular contact system after {pivot + 1} pivots") from None
    return int(r >= m_pair)


def _primal_pivot(binv: BasisInverse, a_all, k: int, slack, pivot: int, m_pair: int) -> int:
    """Row ``binv.basis[k]`` (a negative dual) is released along the edge that keeps the other rows tight, and the
    first row to close enters (exact ratio test). Returns 1 if the entering row is a bound row, else 0."""
    basis = binv.basis
    # release row basis[k]: direction d with A_B d = -e_k; Gamma grows at rate -lam_k > 0
    e_k = np.zeros(basis.size)
    e_k[k] = -1.0
    d = binv.solve(e_k)
    rate = a_all @ d
    rate[basis] = 0.0
    blocking = np.flatnonzero(rate > 1e-14)
    if blocking.size == 0:  # unbounded edge: only the s bounds stop it
        raise _NoVertex(f"an unbounded edge after {pivot} pivots")
    ratios = np.maximum(slack[blocking], 0.0) / rate[blocking]
    j = int(np.argmin(ratios))  # ties: the lowest row index (blocking is sorted), as Bland's rule wants
    try:
        binv.replace(k, blocking[j], column=-d)
    except RuntimeError:
        raise _NoVertex(f"singular contact system after {pivot + 1} pivots") from None
    return int(blocking[j] >= m_pair)


def _vertex_displacements(system: _ContactSystem, u, rattler_s, s_bound: float, pinned: int,
                          shape: tuple[int, int]) -> np.ndarray:
    """The vertex's s (N, d): the unknowns ``u``, the pinned particle at 0, the rattlers at ``rattler_s`` (within the
    bounds; 0 if None)."""
    s = np.zeros(shape) if rattler_s is None else np.clip(rattler_s, -s_bound, s_bound)
    s.ravel()[as_pins(pinned, shape[0], shape[1]).columns] = 0.0
    s.ravel()[system.free_comp] = np.clip(u[:-1], -s_bound, s_bound)  # round-off of an active bound row
    return s


def _held_at_vertex(system: _ContactSystem, n: int, dim: int) -> np.ndarray:
    """(N, d) -1 / +1 where the final basis holds an s component at its lower / upper bound, else 0."""
    k = int(np.count_nonzero(system.free_comp))
    bound = system.basis[(system.basis >= system.m_pair) & (system.basis < system.m_pair + 2 * k)] - system.m_pair
    held = np.zeros(n * dim, dtype=np.int8)
    comps = np.flatnonzero(system.free_comp)
    held[comps[bound % k]] = np.where(bound < k, 1, -1)
    return held.reshape(n, dim)


def _slack(rij, sigma2, pi, pj, s, inflation):
    """Every row's slack after the step s: |r|^2 + 2 r.(s_i - s_j) - Gamma sigma^2 (>= 0 where the row holds)."""
    return np.einsum("ij,ij->i", rij, rij + 2.0 * (s[pi] - s[pj])) - inflation * sigma2


def _settle_rattlers(rij, sigma2, pi, pj, s, inflation, rattler, active, s_bound, feasibility, stuck) -> np.ndarray:
    """Move the rattlers (``s`` in place) out of the rows they violate at the vertex: pushed away from a neighbour
    their cage wall has come to touch, which keeps the solution optimal, else placed by a small feasibility LP.
    Returns every row's slack; raises :class:`_NoVertex` (and fills ``stuck``, see :func:`_solve_vertex`) when
    they find no place or a row among stable particles is violated."""
    for _ in range(20):
        slack = _slack(rij, sigma2, pi, pj, s, inflation)
        bad = (slack < feasibility) & ~active
        if not np.any(bad):
            return slack
        if np.any(bad & ~rattler[pi] & ~rattler[pj] & (slack < -feasibility)):
            raise _NoVertex("a row among stable particles is violated at the vertex")
        for k in np.flatnonzero(bad & (rattler[pi] | rattler[pj])):
            push = 2.0 * (feasibility - slack[k]) / (2.0 * float(np.dot(rij[k], rij[k])))
            if rattler[pi[k]]:
                s[pi[k]] += push * rij[k]
            else:
                s[pj[k]] -= push * rij[k]
    # a rattler pushed back and forth in a tight cage: place the rattlers by a small feasibility LP
    if not _place_rattlers(rij, sigma2, pi, pj, s, inflation, rattler, s_bound, 2.0 * feasibility):
        slack = _slack(rij, sigma2, pi, pj, s, inflation)
        bad = (slack < feasibility) & ~active
        movers = np.unique(np.concatenate([pi[bad & rattler[pi]], pj[bad & rattler[pj]]]))
        if movers.size:  # else the tight rows are among stable particles (a degenerate vertex): no promotion
            stuck.update(s=s, inflation=inflation, rattlers=movers)
        raise _NoVertex("no feasible place for the rattlers at the vertex")
    return _slack(rij, sigma2, pi, pj, s, inflation)
