"""Cell-list neighbour search in a periodic cube, exact for polydisperse spheres, in any dimension d.

A pair (i, j) is *within scale s* when its minimum-image distance r_ij < s * D_ij, with D_ij = (D_i + D_j)/2 the
contact distance. The cell side is at least s * max_i D_i >= s * max_ij D_ij, so every such pair lies in the same or
an adjacent cell whatever the size ratio; the search costs O(N) for a bounded size ratio.

All kernels are numba ``njit(cache=True)`` functions over plain arrays, so engines can reuse them.
"""

from __future__ import annotations

import itertools

import numpy as np
from numba import njit


@njit(cache=True, inline="always")
def fold(dx, box, half):
    """Minimum image of a difference known to lie in (-1.5 L, 1.5 L) (coordinates kept in [0, L)): one fold."""
    if dx > half:
        return dx - box
    if dx < -half:
        return dx + box
    return dx


@njit(cache=True)
def minimum_image(dx, box):
    """Fold a coordinate difference into [-box/2, box/2]."""
    return dx - box * np.floor(dx / box + 0.5)


def cells_per_side(box: float, min_side: float, dim: int, n: int) -> int:
    """Cells per box side for cells of side >= ``min_side``; 1 (all pairs) when fewer than 3 fit.

    Also caps the number of cells at about 2N (dilute, tiny-cutoff searches would otherwise allocate huge grids).
    """
    m = int(np.floor(box / min_side)) if min_side > 0 else 1
    m = min(m, max(3, int(np.floor((2.0 * n) ** (1.0 / dim)))))
    return m if m >= 3 else 1


def neighbour_offsets(dim: int, m: int) -> np.ndarray:
    """All cell offsets in {-1, 0, 1}^dim (just the zero offset when there is a single cell)."""
    if m == 1:
        return np.zeros((1, dim), dtype=np.int64)
    return np.array(list(itertools.product((-1, 0, 1), repeat=dim)), dtype=np.int64)


@njit(cache=True)
def cell_sort(positions, box, m):
    """Sort particles into an m^d grid. Returns (cell of each particle, CSR start per cell, particle order)."""
    n, dim = positions.shape
    ncells = m**dim
    cell = np.empty(n, dtype=np.int64)
    for i in range(n):
        c = 0
        stride = 1
        for k in range(dim):
            ck = int(np.floor(positions[i, k] / box * m))
            ck = ck % m  # positions exactly at box (round-off) or slightly outside
            c += ck * stride
            stride *= m
        cell[i] = c
    counts = np.zeros(ncells + 1, dtype=np.int64)
    for i in range(n):
        counts[cell[i] + 1] += 1
    for c in range(ncells):
        counts[c + 1] += counts[c]
    start = counts.copy()
    order = np.empty(n, dtype=np.int64)
    fill = counts[:-1].copy()
    for i in range(n):
        order[fill[cell[i]]] = i
        fill[cell[i]] += 1
    return cell, start, order


@njit(cache=True)
def _neighbour_cell(c, offset, m, dim):
    out = 0
    stride = 1
    rem = c
    for k in range(dim):
        ck = rem % m
        rem //= m
        ck = (ck + offset[k]) % m
        out += ck * stride
        stride *= m
    return out


@njit(cache=True)
def _pairs_kernel(positions, diameters, box, scale, m, offsets, count_only, out_i, out_j, out_r):
    n, dim = positions.shape
    cell, start, order = cell_sort(positions, box, m)
    noff = offsets.shape[0]
    npairs = 0
    for i in range(n):
        ci = cell[i]
        for o in range(noff):
            cj = _neighbour_cell(ci, offsets[o], m, dim)
            for idx in range(start[cj], start[cj + 1]):
                j = order[idx]
                if j <= i:
                    continue
                r2 = 0.0
                for k in range(dim):
                    dx = minimum_image(positions[j, k] - positions[i, k], box)
                    r2 += dx * dx
                cut = scale * 0.5 * (diameters[i] + diameters[j])
                if r2 < cut * cut:
                    if not count_only:
                        out_i[npairs] = i
                        out_j[npairs] = j
                        out_r[npairs] = np.sqrt(r2)
                    npairs += 1
    return npairs


def pairs_within(positions: np.ndarray, diameters: np.ndarray, box: float, scale: float = 1.0):
    """All pairs i < j with r_ij < scale * D_ij (minimum image).

    Returns ``(i, j, r)`` arrays sorted by (i, j). ``scale`` is dimensionless (1 = contact).
    """
    positions = np.ascontiguousarray(positions, dtype=np.float64)
    diameters = np.ascontiguousarray(diameters, dtype=np.float64)
    n, dim = positions.shape
    m = cells_per_side(box, scale * float(diameters.max()), dim, n)
    offsets = neighbour_offsets(dim, m)
    empty_i = np.empty(0, dtype=np.int64)
    empty_r = np.empty(0, dtype=np.float64)
    count = _pairs_kernel(positions, diameters, float(box), float(scale), m, offsets, True, empty_i, empty_i, empty_r)
    out_i = np.empty(count, dtype=np.int64)
    out_j = np.empty(count, dtype=np.int64)
    out_r = np.empty(count, dtype=np.float64)
    _pairs_kernel(positions, diameters, float(box), float(scale), m, offsets, False, out_i, out_j, out_r)
    key = np.lexsort((out_j, out_i))
    return out_i[key], out_j[key], out_r[key]


def closest_pair(positions: np.ndarray, diameters: np.ndarray, box: float):
    """The pair with the smallest normalised distance h_ij = r_ij / D_ij.

    Returns ``(i, j, h)``. Overlap-free iff h >= 1. Grows the search scale from a density-based guess until a pair
    is found, so it works from Poisson configurations (h ~ 1e-2) to jammed ones (h ~ 1).
    """
    n, dim = positions.shape
    if n < 2:
        raise ValueError("closest_pair needs at least 2 particles")
    mean_d = float(np.mean(diameters))
    spacing = (box**dim / n) ** (1.0 / dim)
    scale = min(1.0, 0.5 * spacing / mean_d) if mean_d > 0 else 1.0
    scale = max(scale, 1e-300)
    max_scale = 2.0 * box * np.sqrt(dim) / max(float(np.min(diameters)), 1e-300)
    while True:
        i, j, r = pairs_within(positions, diameters, box, scale)
        if len(r):
            h = r / (0.5 * (diameters[i] + diameters[j]))
            k = int(np.argmin(h))
            return int(i[k]), int(j[k]), float(h[k])
        if scale > max_scale:
            raise ValueError("closest_pair found no pair (degenerate diameters?)")
        scale *= 2.0


def brute_force_pairs(positions: np.ndarray, diameters: np.ndarray, box: float, scale: float = 1.0):
    """O(N^2) reference for :func:`pairs_within` (tests and tiny systems)."""
    n = len(positions)
    ii, jj = np.triu_indices(n, 1)
    d = positions[jj] - positions[ii]
    d -= box * np.floor(d / box + 0.5)
    r = np.sqrt((d * d).sum(axis=1))
    keep = r < scale * 0.5 * (diameters[ii] + diameters[jj])
    return ii[keep], jj[keep], r[keep]
