"""Sparse rows of the CALiPPSO linear program: linearised non-overlap constraints, built by numba kernels.

For a pair i < j with the vector r_ij = r_i - r_j of one image and contact distance sigma_ij = (D_i + D_j)/2, the exact
non-overlap condition after displacements s is |r_ij + s_i - s_j|^2 >= Gamma sigma_ij^2 (Gamma: the inflation factor,
``inflation`` in the code, docs/calippso.md §1.1). Dropping the |s_i - s_j|^2 >= 0 term gives the linear row

    -2 r_ij . s_i + 2 r_ij . s_j + sigma_ij^2 Gamma <= |r_ij|^2,

whose feasible set lies inside the exact one, so every LP-feasible step is overlap-free for the constrained pairs.
Columns are ordered s_{0,0..d-1}, s_{1,0..d-1}, ..., s_{N-1,d-1}, Gamma (d N + 1 columns); each row has 2d + 1
nonzeros in increasing column order (CSR).

In a box smaller than two cutoffs a pair may meet through several images, and then has one row per image
(:func:`cutoff_rows`, docs/calippso.md §1.2); :func:`pair_keys` tells the rows of one pair apart.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numba import njit

from ..core.neighbours import Frame, minimum_image, pair_images, pairs_within


@njit(cache=True)
def pair_vectors(positions, box, pi, pj):
    """Minimum-image vectors r_ij = r_i - r_j of the listed pairs, shape (M, d)."""
    m = pi.shape[0]
    dim = positions.shape[1]
    out = np.empty((m, dim))
    for k in range(m):
        i = pi[k]
        j = pj[k]
        for a in range(dim):
            out[k, a] = minimum_image(positions[i, a] - positions[j, a], box)
    return out


@njit(cache=True)
def constraint_rows(rij, sigma2, pi, pj, n):
    """CSR arrays (start, index, value) and right-hand sides |r_ij|^2 of the linearised rows.

    ``rij`` are the pair vectors r_i - r_j, ``sigma2`` the squared contact distances, ``n`` the particle count.
    """
    m, dim = rij.shape
    nnz_row = 2 * dim + 1
    start = np.empty(m + 1, dtype=np.int32)
    index = np.empty(m * nnz_row, dtype=np.int32)
    value = np.empty(m * nnz_row)
    rhs = np.empty(m)
    inflation_col = n * dim
    for k in range(m):
        base = k * nnz_row
        start[k] = base
        i = pi[k]
        j = pj[k]
        # i < j, so the s_i columns come before the s_j columns and Gamma is last
        r2 = 0.0
        for a in range(dim):
            c = rij[k, a]
            r2 += c * c
            index[base + a] = i * dim + a
            value[base + a] = -2.0 * c
            index[base + dim + a] = j * dim + a
            value[base + dim + a] = 2.0 * c
        index[base + 2 * dim] = inflation_col
        value[base + 2 * dim] = sigma2[k]
        rhs[k] = r2
    start[m] = m * nnz_row
    return start, index, value, rhs


@njit(cache=True)
def row_excesses(rij, sigma2, pi, pj, s, inflation):
    """Excess of each linearised row over its right-hand side at (s, Gamma), relative to the pair's sigma_ij^2:
    <= 0 where the row holds. Relative, because the step's overlap check is: an absolute excess e overlaps a small
    pair by about e / (2 sigma_ij^2) (docs/calippso.md §5.5)."""
    m, dim = rij.shape
    out = np.empty(m)
    for k in range(m):
        i = pi[k]
        j = pj[k]
        lhs = inflation * sigma2[k]
        for a in range(dim):
            c = rij[k, a]
            lhs += 2.0 * c * (s[j, a] - s[i, a]) - c * c
        out[k] = lhs / sigma2[k]
    return out


def row_excess(rij, sigma2, pi, pj, s, inflation) -> float:
    """The largest of :func:`row_excesses` (-inf without rows)."""
    return float(np.max(row_excesses(rij, sigma2, pi, pj, s, inflation), initial=-np.inf))


@njit(cache=True)
def particle_force_sums(rij, weight, pi, pj, n):
    """Per-particle sums of weight_k * r_ij over the pairs (i gets +, j gets -), shape (n, d)."""
    m, dim = rij.shape
    out = np.zeros((n, dim))
    for k in range(m):
        w = weight[k]
        if w == 0.0:
            continue
        for a in range(dim):
            out[pi[k], a] += w * rij[k, a]
            out[pj[k], a] -= w * rij[k, a]
    return out


def pairs_in_cutoff(positions: np.ndarray, box: float, cutoff: float):
    """Pairs i < j with centre distance r_ij < ``cutoff`` (an absolute length), via the shared cell list."""
    n = positions.shape[0]
    return pairs_within(positions, np.full(n, float(cutoff)), box, 1.0)


def cutoff_rows(positions: np.ndarray, box: float, cutoff):
    """The LP's rows: every periodic image of every pair i < j closer than its cutoff, as ``(pi, pj, rij)`` with
    rij = r_i - r_j - n L of that image, sorted by (i, j, |rij|) (docs/calippso.md §1.2).

    ``box`` is the periodic cube's side, or a container's :class:`~spherejam.core.neighbours.Frame` (images along
    its periodic axes only). ``cutoff`` is one absolute length for every pair, or per particle a reach w_i
    (absolute), the cutoff of pair (i, j) then being (w_i + w_j) / 2: :func:`closable_reach` gives the rows a step
    can close (§1.4). While every cutoff is below L/2 these are the pairs within it with their minimum-image vectors
    (:func:`pair_vectors`), bit for bit; a sphere's own images are never within a cutoff <= L (§1.4).
    """
    n = positions.shape[0]
    reach = np.broadcast_to(np.asarray(cutoff, dtype=np.float64), (n,))
    pi, pj, d = pair_images(positions, reach, box, 1.0)
    if isinstance(box, Frame):  # a container's frame (docs/containers.md §5): each row's own image vector
        return pi, pj, -d
    rij = pair_vectors(positions, box, pi, pj)
    if np.any((pi[1:] == pi[:-1]) & (pj[1:] == pj[:-1])):
        # a pair listed more than once: shift each row from the minimum image to its own image by whole boxes
        shift = np.rint((-d - rij) / box)
        rij = rij + shift * box
    return pi, pj, rij


def step_approach(s_bound: float, dim: int) -> float:
    """How far two centres can approach in one step with |s_{i,mu}| <= s_bound: |s_i - s_j| <= 2 sqrt(d) s_bound.
    A pair farther than sqrt(Gamma) sigma_ij + this cannot overlap after a step with that Gamma (docs/calippso.md
    §1.4, §5.7)."""
    return 2.0 * math.sqrt(dim) * s_bound


def closable_reach(diameters: np.ndarray, sqrt_inflation_max: float, s_bound: float, dim: int) -> np.ndarray:
    """Per-particle reach w_i = sqrt(Gamma_max) D_i + :func:`step_approach` for :func:`cutoff_rows`: pair (i, j) is a
    row iff r_ij < sqrt(Gamma_max) sigma_ij + 2 sqrt(d) s_bound, the pairs that a step with |s_mu| <= s_bound and
    Gamma <= Gamma_max can bring into contact (docs/calippso.md §1.4). Lengths absolute."""
    return sqrt_inflation_max * np.asarray(diameters, dtype=np.float64) + step_approach(s_bound, dim)


def pair_keys(pi: np.ndarray, pj: np.ndarray, n: int) -> np.ndarray:
    """One int64 key per row, unique within an LP and stable from one LP to the next: i N + j for the first row of
    a pair, plus k N^2 for its k-th further row (k counted in row order, i.e. by distance for :func:`cutoff_rows`).

    Where every pair has one row (a box larger than two cutoffs) the keys are i N + j. Rows of one pair change rank
    only when two of its images are equally far, i.e. both in contact (docs/calippso.md §1.2). Keys of a subset of
    rows are the subset of the full list's keys, not the keys of the subset.
    """
    key = pi.astype(np.int64) * n + pj
    if key.size < 2 or np.all(key[1:] > key[:-1]):  # sorted and unique: one row per pair
        return key
    order = np.argsort(key, kind="stable")
    k = key[order]
    first = np.r_[True, k[1:] != k[:-1]]
    start = np.maximum.accumulate(np.where(first, np.arange(k.size), 0))
    rank = np.empty(k.size, dtype=np.int64)
    rank[order] = np.arange(k.size) - start
    return key + rank * (np.int64(n) * n)


@dataclass(frozen=True)
class Pins:
    """The s columns an LP fixes at 0: the gauge pins that remove its zero modes (rigid motions no row resists), and
    every column of its wall nodes (docs/containers.md §5).

    The LP's nodes are its ``spheres`` spheres, then one node per wall of a container, which never moves: a
    sphere-wall row is a pair row (i, wall node) with r_ij from the wall to the sphere (:mod:`.walls`). ``columns``
    are flat column indices (node d + axis, d = ``dim``), sorted; those of spheres are the gauge pins, one per zero
    mode. The periodic cube pins one sphere's d components (docs/calippso.md §1.1, §1.7): :func:`as_pins`.
    """

    columns: np.ndarray
    spheres: int
    dim: int

    @property
    def gauge(self) -> np.ndarray:
        """The gauge pins (columns of spheres)."""
        return self.columns[self.columns < self.spheres * self.dim]

    @property
    def zero_modes(self) -> int:
        """Zero modes the gauge pins remove: one per pinned sphere column."""
        return int(self.gauge.size)

    def pinned_spheres(self) -> np.ndarray:
        """The spheres with a pinned component (they must not be rattlers: docs/calippso.md §1.7)."""
        return np.unique(self.gauge // self.dim)

    def mask(self, nodes: int) -> np.ndarray:
        """(nodes, d) bool: True where a column is fixed."""
        out = np.zeros(nodes * self.dim, dtype=bool)
        out[self.columns] = True
        return out.reshape(nodes, self.dim)


def as_pins(pinned, n: int, dim: int) -> Pins:
    """``pinned`` as :class:`Pins`: a sphere index (every component of that sphere pinned, no walls: the periodic
    cube; ``n`` spheres) or already :class:`Pins`."""
    if isinstance(pinned, Pins):
        return pinned
    p = int(pinned)
    return Pins(np.arange(p * dim, (p + 1) * dim, dtype=np.int64), int(n), int(dim))
