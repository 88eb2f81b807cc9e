"""Farr-Groot estimate of the random-close-packing density phi_RCP of polydisperse spheres (a reconstruction).

Farr & Groot (J. Chem. Phys. 131, 244104, 2009) map the packing of spheres onto a packing of rods on a line: a
random line cuts the spheres into chords, and the chords are packed one by one, largest first, into the largest free
gap of a periodic line, each with a free length f·L on both sides. The line fraction the rods fill is the estimate of
the volume fraction phi_RCP. The method section of that paper was not available to us: this module is our
**reconstruction** of the algorithm, validated against Farr's (2013) published single-lognormal formula
(:func:`farr2013_lognormal`, agreement <= 4e-4 for s <= 1.25) and against the exact bidisperse limits at infinite
size ratio. docs/farr_groot.md describes the method and its checks.

Conventions: ``sigma`` is the project's (and the paper's) polydispersity, the relative standard deviation of the
diameter D of a log-normal distribution; Farr's ``s`` is the standard deviation of ln D, s = sqrt(ln(1 + sigma^2)).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit
from scipy.special import ndtri

#: phi of monodisperse spheres the method is calibrated to (Farr's formula at s = 0: 1 - 0.57 + 0.2135).
PHI_MONODISPERSE = 0.6435
#: The free length per rod side, in units of the rod length, that gives PHI_MONODISPERSE with quantile chords.
F_DEFAULT = 0.76535


def s_of_sigma(sigma):
    """Farr's s = std(ln D) of a log-normal distribution whose relative std of D is sigma."""
    return np.sqrt(np.log1p(np.square(sigma)))


def farr2013_lognormal(s):
    """Farr's (2013) fitted phi_RCP of a single log-normal distribution with s = std(ln D) (Powder Technol. 245, 28)."""
    s = np.asarray(s, dtype=float)
    wave = np.cos(2 * np.pi * (1 - np.exp(-0.75 * s**0.7 - 0.025 * s**4))) - 1
    return 1 - 0.57 * np.exp(-s) + 0.2135 * np.exp(-0.57 * s / 0.2135) + 0.0019 * wave


@njit(cache=True)
def _pack_sorted_rods(lengths, f):
    """Line fraction of rods (sorted, longest first) packed greedily into the largest gap of a periodic line."""
    n = lengths.size
    heap = np.empty(n + 1)  # max-heap of gap lengths; every rod after the first adds one gap
    heap[0] = f * lengths[0]
    size = 1
    total = (1.0 + f) * lengths[0]
    filled = lengths[0]
    for k in range(1, n):
        x = lengths[k]
        g = heap[0]
        if g >= (1.0 + 2.0 * f) * x:
            a, b = f * x, g - (1.0 + f) * x
        else:  # the gap is too small: the rod pushes its neighbours apart and the line grows
            total += (1.0 + 2.0 * f) * x - g
            a, b = f * x, f * x
        # replace the top by a and sift down
        heap[0] = a
        i = 0
        while True:
            c = 2 * i + 1
            if c >= size:
                break
            if c + 1 < size and heap[c + 1] > heap[c]:
                c += 1
            if heap[c] <= heap[i]:
                break
            heap[i], heap[c] = heap[c], heap[i]
            i = c
        # push b and sift up
        heap[size] = b
        i = size
        size += 1
        while i > 0:
            p = (i - 1) // 2
            if heap[p] >= heap[i]:
                break
            heap[i], heap[p] = heap[p], heap[i]
            i = p
        filled += x
    return filled / total


def pack_rods(lengths, f: float = F_DEFAULT) -> float:
    """phi of rods of the given lengths packed by the Farr-Groot rule (any order; they are sorted here)."""
    lengths = np.sort(np.asarray(lengths, dtype=float))[::-1]
    if lengths.size == 0 or not np.all(np.isfinite(lengths)) or lengths[-1] <= 0:
        raise ValueError("rod lengths must be a non-empty array of positive finite numbers")
    return float(_pack_sorted_rods(np.ascontiguousarray(lengths), float(f)))


def _chords(diameter, count):
    """``count`` deterministic chord lengths of a sphere of the given diameter: L = D sqrt(U) at U's quantiles."""
    return diameter * np.sqrt((np.arange(count) + 0.5) / count)


def phi_rcp_mixture(diameters, number_fractions, n_rods: int = 200_000, f: float = F_DEFAULT) -> float:
    """phi_RCP of a discrete mixture: spheres of ``diameters`` in proportions ``number_fractions`` (by number).

    A line hits a sphere in proportion to its cross-section, so species i gets a share n_i D_i^2 of the rods.
    """
    d = np.asarray(diameters, dtype=float)
    n = np.asarray(number_fractions, dtype=float)
    if d.shape != n.shape or d.size == 0 or np.any(d <= 0) or np.any(n < 0) or n.sum() <= 0:
        raise ValueError("diameters must be positive and number_fractions non-negative, of the same length")
    w = n * d**2
    counts = np.rint(n_rods * w / w.sum()).astype(int)
    keep = counts > 0
    rods = np.concatenate([_chords(di, ci) for di, ci in zip(d[keep], counts[keep])])
    return pack_rods(rods, f)


def phi_rcp_bidisperse(size_ratio: float, small_volume_fraction: float, n_rods: int = 200_000,
                       f: float = F_DEFAULT) -> float:
    """phi_RCP of large (D = size_ratio) and small (D = 1) spheres; x_s is the small spheres' share of the solid."""
    x_s = float(small_volume_fraction)
    if not 0 <= x_s <= 1 or not size_ratio >= 1:
        raise ValueError(f"need size_ratio >= 1 and 0 <= small_volume_fraction <= 1, got {size_ratio}, {x_s}")
    d = np.array([float(size_ratio), 1.0])
    return phi_rcp_mixture(d, np.array([1 - x_s, x_s]) / d**3, n_rods, f)


def phi_rcp_lognormal(sigma: float, n_diameters: int = 2000, n_chords: int = 300, f: float = F_DEFAULT) -> float:
    """phi_RCP of log-normal diameters with relative standard deviation sigma (the paper's sigma).

    The diameters a line hits are log-normal with the same s = std(ln D) as the number distribution (the scale drops
    out), so ``n_diameters`` quantiles of that distribution, each cut into ``n_chords`` quantile chords, are packed.
    """
    if not (math.isfinite(sigma) and sigma >= 0):
        raise ValueError(f"sigma={sigma!r}: must be a finite number >= 0")
    s = float(s_of_sigma(sigma))
    d = np.exp(s * ndtri((np.arange(n_diameters) + 0.5) / n_diameters))
    rods = np.outer(d, _chords(1.0, n_chords)).ravel()
    return pack_rods(rods, f)


def phi_rcp_distribution(distribution, n_diameters: int = 4000, n_chords: int = 100, f: float = F_DEFAULT) -> float:
    """phi_RCP of any size distribution (a :class:`~spherejam.core.size_distribution.SizeDistribution` or its spec).

    A line hits spheres in proportion to n(D) D^2, so ``n_diameters`` quantiles of that hit-weighted distribution
    (taken over the distribution's representative points, :meth:`SizeDistribution.support`) are each cut into
    ``n_chords`` quantile chords and packed. A log-normal goes through :func:`phi_rcp_lognormal`, so both functions
    give it the same phi_RCP."""
    from ..core.size_distribution import LogNormal, parse

    dist = parse(distribution)
    if isinstance(dist, LogNormal):
        return phi_rcp_lognormal(dist.sigma, f=f)
    return phi_rcp_points(*dist.support(), n_diameters=n_diameters, n_chords=n_chords, f=f)


def phi_rcp_points(d, w, n_diameters: int = 4000, n_chords: int = 100, f: float = F_DEFAULT) -> float:
    """phi_RCP of diameters ``d`` with number weights ``w`` (points of a distribution; see
    :func:`phi_rcp_distribution`)."""
    d, w = np.asarray(d, dtype=float), np.asarray(w, dtype=float)
    order = np.argsort(d, kind="stable")
    d, hits = d[order], (w * d * d)[order]
    cdf = np.cumsum(hits) / hits.sum()
    u = (np.arange(n_diameters) + 0.5) / n_diameters
    picked = d[np.minimum(np.searchsorted(cdf, u, side="left"), d.size - 1)]
    return pack_rods(np.outer(picked, _chords(1.0, n_chords)).ravel(), f)


def phi_rcp_curve(sigmas, **kwargs) -> np.ndarray:
    """:func:`phi_rcp_lognormal` for each sigma."""
    return np.array([phi_rcp_lognormal(float(s), **kwargs) for s in np.atleast_1d(sigmas)])
