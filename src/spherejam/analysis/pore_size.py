"""Pore-size entropy of a periodic packing, d = 2..5 (docs/algorithms.md §6.5): the fraction of random points farther
than a quarter of the mean diameter from every sphere surface, sampled until the entropy settles."""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from ..core import neighbours
from ..core.errors import require
from ..core.packing import Packing
from ..core.seeding import rng_for

#: Pore-size entropy: threshold r_0 = ā/4 (mean radius R = ā/2, alpha = 2), S = alpha^2 ln P (docs/algorithms.md §6.5).
PORE_ALPHA = 2.0
PORE_MIN_SAMPLES = 10**7
PORE_CHECK_EVERY = 10**4
PORE_REL_CHANGE = 1e-3
PORE_MAX_SAMPLES = 10**8


@njit(cache=True)
def _covered_voxels(positions, reach, box, g):
    """(g^3,) uint8 grid, 1 for voxels lying entirely inside one fattened sphere |y - x_i| < reach[i] (d = 3).

    Most random points fall in such voxels and are classified in O(1); only the rest need the exact test.
    """
    h = box / g
    half_diagonal = 0.5 * math.sqrt(3.0) * h
    covered = np.zeros(g * g * g, dtype=np.uint8)
    for i in range(positions.shape[0]):
        r_in = reach[i] - half_diagonal  # voxel centre within r_in => whole voxel within reach
        if r_in <= 0.0:
            continue
        x0, x1, x2 = positions[i, 0], positions[i, 1], positions[i, 2]
        for a in range(math.floor((x0 - r_in) / h), math.floor((x0 + r_in) / h) + 1):
            d0 = (a + 0.5) * h - x0
            for b in range(math.floor((x1 - r_in) / h), math.floor((x1 + r_in) / h) + 1):
                d1 = (b + 0.5) * h - x1
                for c in range(math.floor((x2 - r_in) / h), math.floor((x2 + r_in) / h) + 1):
                    d2 = (c + 0.5) * h - x2
                    if d0 * d0 + d1 * d1 + d2 * d2 <= r_in * r_in:
                        covered[((a % g) * g + (b % g)) * g + (c % g)] = 1
    return covered


@njit(cache=True)
def _uncovered(samples, positions, reach, box, m, visit, cell, start, order, covered, g, out):
    """out[s] = 1 if sample s lies at least reach[i] from every centre i (minimum image), else 0.

    ``covered`` (g^3 voxels, d = 3; g = 0 disables it) short-cuts points inside a fully covered voxel.
    ``visit`` lists the entries of the cell stencil in scan order, best the own cell first (the likeliest to hold a
    covering sphere).
    """
    ns, dim = samples.shape
    noff = visit.shape[0]
    lengths = np.full(dim, box)  # the periodic cube as a frame (core.neighbours)
    ms = np.full(dim, m, dtype=np.int64)
    periodic = np.ones(dim, dtype=np.bool_)
    coords = np.empty(dim, dtype=np.int64)
    shift = np.empty(dim)  # unused: differences are folded to the minimum image
    for s in range(ns):
        if g > 0:
            v = 0
            for k in range(3):
                v = v * g + math.floor(samples[s, k] / box * g) % g
            if covered[v]:
                out[s] = 0
                continue
        for k in range(dim):
            coords[k] = neighbours.axis_cell(samples[s, k], box, m)
        free = 1
        for o in range(noff):
            cj = neighbours.stencil_cell(coords, visit[o], 1, ms, lengths, periodic, shift)
            for idx in range(start[cj], start[cj + 1]):
                i = order[idx]
                r2 = 0.0
                for k in range(dim):
                    dx = neighbours.minimum_image(samples[s, k] - positions[i, k], box)
                    r2 += dx * dx
                if r2 < reach[i] * reach[i]:
                    free = 0
                    break
            if free == 0:
                break
        out[s] = free


def pore_size_entropy(
    packing: Packing, *, seed: int = 0, samples: int | None = None, min_samples: int = PORE_MIN_SAMPLES,
) -> tuple[float, float, int]:
    """Pore-size entropy S = alpha^2 ln P, alpha = 2 (docs/algorithms.md §6.5; Baranau et al., Soft Matter 9, 3361
    (2013)).

    P is the fraction of uniform random points y whose pore radius r(y) = min_i(|y - x_i| - a_i/2) exceeds ā/4.
    Points are drawn in chunks of 10^6 from the stream of ``seed`` (in box units, so the estimate is identical
    for a uniformly rescaled packing). With ``samples`` None the reference rule applies: check every 10^4 points
    and stop once at least ``min_samples`` were drawn and S changed by < 1e-3 (relative) since the last check.
    Returns ``(S, P, number of points)``; S = -inf if no large pore was found.
    """
    if samples is not None:
        require(int(samples) == samples and samples >= 1, "pore_samples", samples, "must be an integer >= 1")
    require(int(min_samples) == min_samples and min_samples >= 1, "min_samples", min_samples,
            "must be an integer >= 1")
    n, dim, box = packing.n, packing.dim, packing.require_cube("the pore-size entropy")
    threshold = packing.mean_diameter / (2.0 * PORE_ALPHA)
    reach = 0.5 * packing.diameters + threshold
    m = neighbours.cells_per_side(box, float(reach.max()), dim, n)
    visit = np.argsort(np.abs(neighbours.neighbour_offsets(dim, m)).sum(axis=1), kind="stable")  # own cell first
    cell, start, order = neighbours.cell_sort(packing.positions, np.full(dim, box), np.full(dim, m, dtype=np.int64))
    if dim == 3:  # voxels of side ~ min reach / 6, at most 256^3 of them
        g = int(min(256, max(1, math.ceil(6.0 * box / float(reach.min())))))
        covered = _covered_voxels(packing.positions, reach, box, g)
    else:
        g, covered = 0, np.zeros(1, dtype=np.uint8)
    rng = rng_for(seed)
    chunk = 100 * PORE_CHECK_EVERY
    target = int(samples) if samples is not None else PORE_MAX_SAMPLES
    drawn, found, previous = 0, 0, None
    while drawn < target:
        size = min(chunk, target - drawn)
        y = rng.random((size, dim)) * box
        hits = np.empty(size, dtype=np.uint8)
        _uncovered(y, packing.positions, reach, box, m, visit, cell, start, order, covered, g, hits)
        if samples is not None:
            found += int(hits.sum())
            drawn += size
            continue
        # the stopping rule, evaluated at every multiple of PORE_CHECK_EVERY
        cum = found + np.cumsum(hits.reshape(-1, PORE_CHECK_EVERY).sum(axis=1, dtype=np.int64))
        n_at = drawn + PORE_CHECK_EVERY * np.arange(1, len(cum) + 1)
        with np.errstate(divide="ignore"):
            s_at = PORE_ALPHA**2 * np.log(cum / n_at)
        for k in range(len(cum)):
            if previous is not None and n_at[k] >= min_samples and math.isfinite(s_at[k]) and abs(
                    s_at[k] - previous) < PORE_REL_CHANGE * abs(previous):
                p = float(cum[k] / n_at[k])
                return float(s_at[k]), p, int(n_at[k])
            previous = s_at[k] if math.isfinite(s_at[k]) else None
            if n_at[k] >= min_samples and cum[k] == 0:
                return -math.inf, 0.0, int(n_at[k])  # no large pore at all (e.g. a dense crystal)
        found = int(cum[-1])
        drawn += size
    p = found / drawn
    return (PORE_ALPHA**2 * math.log(p) if p > 0 else -math.inf), p, drawn
