"""Rattlers of a contact graph: the particles outside its k-core (k = d + 1 for a jammed packing in d dimensions).

A particle with fewer than k contacts with non-rattlers is a rattler, recursively; the fixed point is the k-core,
computed by peeling in O(N + K). A contact with a body that is never a rattler (a container's wall) counts for its
particle through ``fixed`` (contacts per particle that peeling never removes). Both the contact analysis of a packing
(:mod:`spherejam.analysis.contacts`, contacts by gap) and CALiPPSO's certificate (contacts by LP dual) take their
rattlers from here.
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


def rattler_mask(n: int, pair_i: np.ndarray, pair_j: np.ndarray, min_contacts: int,
                 fixed: np.ndarray | None = None) -> np.ndarray:
    """True for rattlers: particles outside the ``min_contacts``-core of the contact graph. ``fixed`` (N,): contacts
    of each particle with bodies that are never rattlers (a container's walls), counted toward its contacts."""
    require(int(min_contacts) == min_contacts and min_contacts >= 1, "min_contacts", min_contacts,
            "must be an integer >= 1")
    pair_i = np.ascontiguousarray(pair_i, dtype=np.int64)
    pair_j = np.ascontiguousarray(pair_j, dtype=np.int64)
    fixed = np.zeros(int(n), dtype=np.int64) if fixed is None else np.ascontiguousarray(fixed, dtype=np.int64)
    require(fixed.shape == (int(n),) and bool(np.all(fixed >= 0)), "fixed", fixed.shape,
            f"must be ({int(n)},) counts >= 0")
    return ~k_core(int(n), pair_i, pair_j, int(min_contacts), fixed)
