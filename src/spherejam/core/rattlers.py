"""Rattlers of a contact graph: the particles outside its k-core (k = d + 1 for a jammed packing in d dimensions).

A particle with fewer than k contacts with non-rattlers is a rattler, recursively; the fixed point is the k-core,
computed by peeling in O(N + K). A contact with a body that is never a rattler (a container's wall) counts for its
particle through ``fixed`` (contacts per particle that peeling never removes). Both the contact analysis of a packing
(:mod:`spherejam.analysis.contacts`, contacts by gap) and CALiPPSO's certificate (contacts by LP dual) take their
rattlers from here.

**Contacts that span fewer than d dimensions** (docs/containers.md §5). d + 1 is the least number of contacts whose
positive forces can balance in d dimensions, if their directions span R^d. On a flat wall of a monodisperse packing
every sphere touching the wall has its centre on one plane, so its contacts within that layer are exactly coplanar:
three of them, at positive forces, balance it within the plane. Given the contacts' directions, the rule is therefore
the one behind the k-core, by rank: a particle needs s + 1 contacts with non-rattlers (at most ``min_contacts``), s
the dimensions their directions span; fewer are linearly independent and cannot balance at positive forces. Such a
particle with s < d is a **partial rattler**: held by its contacts in s dimensions, its d - s others (its free
directions) are not loaded; it counts s degrees of freedom in the isostatic count.
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


#: Directions span fewer dimensions when the smallest eigenvalues of sum_k u_k u_k^T (u_k their unit vectors) fall
#: below this fraction of the largest: contacts tilted by less than ~1e-5 rad out of a common plane count as in it,
#: far above round-off (~1e-16 rad on an exactly flat layer) and far below any generic packing's tilt.
SPAN_TOLERANCE = 1e-10


def spanned_dimensions(n: int, node: np.ndarray, vectors: np.ndarray) -> np.ndarray:
    """(n,) int: the dimensions the directions ``vectors`` (m, d; any length and sign) of each node's contacts span,
    ``node`` (m,) the node of each (0 for a node without contacts; threshold :data:`SPAN_TOLERANCE`)."""
    u = np.asarray(vectors, dtype=np.float64)
    u = u if u.ndim == 2 else u.reshape(len(node), -1)
    norm = np.linalg.norm(u, axis=1)
    u = u / np.where(norm > 0, norm, 1.0)[:, None]
    gram = np.zeros((int(n), u.shape[1], u.shape[1]))
    np.add.at(gram, np.asarray(node, dtype=np.int64), u[:, :, None] * u[:, None, :])
    eig = np.linalg.eigvalsh(gram)  # ascending, per node
    top = eig[:, -1:]
    return np.sum(eig > SPAN_TOLERANCE * top, axis=1) * (top[:, 0] > 0)


def rattler_mask(n: int, pair_i: np.ndarray, pair_j: np.ndarray, min_contacts: int,
                 fixed: np.ndarray | None = None, vectors: np.ndarray | None = None) -> np.ndarray:
    """True for rattlers: particles outside the ``min_contacts``-core of the contact graph. ``fixed`` (N,): contacts
    of each particle with bodies that are never rattlers (a container's walls), counted toward its contacts.

    With ``vectors`` (m, d), the contacts' directions (walls given as nodes of the graph, with ``fixed`` at least
    ``min_contacts`` so that they never peel), a particle needs only s + 1 contacts with non-rattlers, s the
    dimensions their directions span (module docstring): from the k-core, particles are peeled and restored by that
    rule to a fixed point."""
    require(int(min_contacts) == min_contacts and min_contacts >= 1, "min_contacts", min_contacts,
            "must be an integer >= 1")
    pair_i = np.ascontiguousarray(pair_i, dtype=np.int64)
    pair_j = np.ascontiguousarray(pair_j, dtype=np.int64)
    fixed = np.zeros(int(n), dtype=np.int64) if fixed is None else np.ascontiguousarray(fixed, dtype=np.int64)
    require(fixed.shape == (int(n),) and bool(np.all(fixed >= 0)), "fixed", fixed.shape,
            f"must be ({int(n)},) counts >= 0")
    rattler = ~k_core(int(n), pair_i, pair_j, int(min_contacts), fixed)
    if vectors is None or not np.any(rattler):
        return rattler
    vectors = np.asarray(vectors, dtype=np.float64)
    vectors = vectors if vectors.ndim == 2 else vectors.reshape(len(pair_i), -1)
    node = np.concatenate([pair_i, pair_j])
    both = np.concatenate([vectors, vectors])
    alive = ~rattler
    for _ in range(int(n) + 1):
        # each particle's contacts with the particles standing: their number and span; a change moves the fixed point
        live = alive[pair_i] & alive[pair_j]
        live2 = np.concatenate([live, live])
        count = np.bincount(node[live2], minlength=int(n)) + fixed
        # a particle not standing: its contacts with those that stand, were it restored
        reach = (alive[pair_i] | alive[pair_j])
        reach2 = np.concatenate([reach & alive[pair_j], reach & alive[pair_i]])
        count_out = np.bincount(node[reach2], minlength=int(n)) + fixed
        span = spanned_dimensions(n, node[live2], both[live2])
        span_out = spanned_dimensions(n, node[reach2], both[reach2])
        peeled = alive & (count < np.minimum(int(min_contacts), span + 1))
        restored = ~alive & (count_out >= np.minimum(int(min_contacts), span_out + 1)) & (span_out > 0)
        if np.any(peeled):
            alive &= ~peeled
        elif np.any(restored):
            alive |= restored
        else:
            break
    return ~alive
