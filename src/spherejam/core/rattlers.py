"""Rattlers of a contact graph: the particles outside its k-core (k = d + 1 for a jammed packing in d dimensions).

A particle with fewer than k contacts with non-rattlers is a rattler, recursively; the fixed point is the k-core,
computed by peeling in O(N + K). A contact with a body that is never a rattler (a container's wall) counts for its
particle through ``fixed`` (contacts per particle that peeling never removes). Both the contact analysis of a packing
(:mod:`spherejam.analysis.contacts`, contacts by gap) and CALiPPSO's certificate (contacts by LP dual) take their
rattlers from here.

**Partial rattlers.** Given the contacts' directions, a particle whose contacts with non-rattlers span fewer than d
dimensions is a rattler too, however many they are: it can move along a direction orthogonal to all of them, which
opens every one at second order (a straight-line motion; docs/containers.md §5). In a generic packing this never
happens (d + 1 directions in general position span R^d); it does on a flat wall of a monodisperse packing, where
every sphere touching the wall has its centre on one plane, so that its contacts within that layer are exactly
coplanar. The rule peels recursively, with the k-core rule, to one fixed point.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from .errors import require


@njit(cache=True)
def k_core(n, pair_i, pair_j, k, fixed):
    """Membership of the k-core of the graph with n nodes and edges (pair_i, pair_j): True = in the core.

    Peels nodes of degree < k one at a time, updating the degrees of their neighbours (Batagelj-Zaversnik style),
    which gives the same fixed point as the recursive "fewer than k contacts with non-rattlers" rule. ``fixed[v]``
    adds to the degree of v edges to nodes outside the graph that are never peeled (walls).
    """
    m = pair_i.shape[0]
    degree = np.zeros(n, dtype=np.int64)
    for e in range(m):
        degree[pair_i[e]] += 1
        degree[pair_j[e]] += 1
    start = np.zeros(n + 1, dtype=np.int64)
    for v in range(n):
        start[v + 1] = start[v] + degree[v]
    fill = start[:-1].copy()
    adj = np.empty(2 * m, dtype=np.int64)
    for e in range(m):
        a, b = pair_i[e], pair_j[e]
        adj[fill[a]] = b
        fill[a] += 1
        adj[fill[b]] = a
        fill[b] += 1
    for v in range(n):  # the CSR above holds the graph's own edges; the fixed ones only count
        degree[v] += fixed[v]
    alive = np.ones(n, dtype=np.bool_)
    stack = np.empty(n, dtype=np.int64)
    top = 0
    for v in range(n):
        if degree[v] < k:
            alive[v] = False
            stack[top] = v
            top += 1
    while top > 0:
        top -= 1
        v = stack[top]
        for idx in range(start[v], start[v + 1]):
            u = adj[idx]
            if alive[u]:
                degree[u] -= 1
                if degree[u] < k:
                    alive[u] = False
                    stack[top] = u
                    top += 1
    return alive


#: A particle's contacts span fewer than d dimensions when the smallest eigenvalue of sum_k u_k u_k^T (u_k their unit
#: directions) is below this fraction of the largest: contacts tilted by ~1e-5 rad out of a common plane count as in
#: it, far above round-off (~1e-16 rad on an exactly flat layer) and far below any generic packing's tilt.
SPAN_TOLERANCE = 1e-10


def spanned_dimensions(n: int, pair_i: np.ndarray, pair_j: np.ndarray, vectors: np.ndarray,
                       fixed_vectors: tuple[np.ndarray, np.ndarray] | None = None) -> np.ndarray:
    """(n,) int: the dimensions the directions of each node's contacts span (0 for a node without contacts), with
    the relative eigenvalue threshold :data:`SPAN_TOLERANCE`. ``vectors`` (m, d): a direction of each contact (any
    length, any sign); ``fixed_vectors`` ``(nodes, directions)``: more contacts of single nodes (walls)."""
    vectors = np.asarray(vectors, dtype=np.float64).reshape(len(pair_i), -1)
    dim = vectors.shape[1]
    nodes = [np.asarray(pair_i, dtype=np.int64), np.asarray(pair_j, dtype=np.int64)]
    dirs = [vectors, vectors]
    if fixed_vectors is not None:
        nodes.append(np.asarray(fixed_vectors[0], dtype=np.int64))
        dirs.append(np.asarray(fixed_vectors[1], dtype=np.float64).reshape(len(nodes[-1]), dim))
    node = np.concatenate(nodes)
    u = np.concatenate(dirs)
    norm = np.linalg.norm(u, axis=1)
    u = u / np.where(norm > 0, norm, 1.0)[:, None]
    gram = np.zeros((int(n), dim, dim))
    np.add.at(gram, node, u[:, :, None] * u[:, None, :])
    eig = np.linalg.eigvalsh(gram)  # ascending, per node
    top = eig[:, -1]
    return np.sum(eig > SPAN_TOLERANCE * top[:, None], axis=1) * (top > 0)


def rattler_mask(n: int, pair_i: np.ndarray, pair_j: np.ndarray, min_contacts: int,
                 fixed: np.ndarray | None = None, vectors: np.ndarray | None = None,
                 anchored: np.ndarray | None = None, fixed_vectors=None) -> np.ndarray:
    """True for rattlers: particles outside the ``min_contacts``-core of the contact graph. ``fixed`` (N,): contacts
    of each particle with bodies that are never rattlers (a container's walls), counted toward its contacts.

    With ``vectors`` (m, d), the contacts' directions, a particle whose contacts with non-rattlers (and its
    ``fixed_vectors``, ``(particles, directions)`` of its contacts with walls) span fewer than d dimensions is a
    rattler too (a partial rattler, module docstring), recursively with the k-core rule; ``anchored`` (N,) bool marks
    nodes never peeled by that rule (walls given as nodes)."""
    require(int(min_contacts) == min_contacts and min_contacts >= 1, "min_contacts", min_contacts,
            "must be an integer >= 1")
    pair_i = np.ascontiguousarray(pair_i, dtype=np.int64)
    pair_j = np.ascontiguousarray(pair_j, dtype=np.int64)
    fixed = np.zeros(int(n), dtype=np.int64) if fixed is None else np.ascontiguousarray(fixed, dtype=np.int64)
    require(fixed.shape == (int(n),) and bool(np.all(fixed >= 0)), "fixed", fixed.shape,
            f"must be ({int(n)},) counts >= 0")
    rattler = ~k_core(int(n), pair_i, pair_j, int(min_contacts), fixed)
    if vectors is None:
        return rattler
    vectors = np.asarray(vectors, dtype=np.float64).reshape(len(pair_i), -1)
    dim = vectors.shape[1]
    anchored = np.zeros(int(n), dtype=bool) if anchored is None else np.asarray(anchored, dtype=bool)
    fv = None if fixed_vectors is None else (np.asarray(fixed_vectors[0], dtype=np.int64),
                                             np.asarray(fixed_vectors[1], dtype=np.float64))
    while True:  # a partial rattler's contacts leave its neighbours' counts and spans: peel again to a fixed point
        live = ~rattler[pair_i] & ~rattler[pair_j]
        span = spanned_dimensions(n, pair_i[live], pair_j[live], vectors[live],
                                  None if fv is None else (fv[0][~rattler[fv[0]]], fv[1][~rattler[fv[0]]]))
        partial = ~rattler & ~anchored & (span < dim)
        if not np.any(partial):
            return rattler
        rattler = rattler | partial
        live = ~rattler[pair_i] & ~rattler[pair_j]
        rattler = rattler | ~k_core(int(n), pair_i[live], pair_j[live], int(min_contacts),
                                    np.where(rattler, 0, fixed))
