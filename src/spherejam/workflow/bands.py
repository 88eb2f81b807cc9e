"""Edges of the band of closest jamming densities phi_J of fast compressions (the paper's Table 3 and phi_LT, phi_RCP).

Two estimators of each edge, chosen per experiment (``bands.method``, see docs/statistics.md):

* ``minmax``: the sample minimum and maximum, the paper's phi_min^fast and phi_max^fast (its eq. 17 for large
  packings, where untypical basins are practically never sampled).
* ``quantile``: the paper's eq. 18 for packings small enough that every basin can be sampled. phi_RCP is the density
  phi_0 with P(phi_J <= phi_0) = alpha, phi_LT the one with P(phi_J >= phi_0) = alpha (alpha = 0.95 in the paper).
  On a sample of n values the empirical probabilities are step functions, so we take the smallest order statistic
  that reaches the probability: phi_RCP = X_(ceil(alpha n)), phi_LT = X_(floor((1 - alpha) n) + 1). For
  n < 1 / (1 - alpha) they are the sample maximum and minimum.

Confidence intervals use order statistics (distribution-free): for the p-quantile, [X_(l), X_(u)] with B ~ Binomial(n,
p) the number of values below the quantile, l the largest rank with P(B <= l - 1) <= (1 - c)/2 and u the smallest with
P(B >= u) <= (1 - c)/2, so each side fails with probability at most (1 - c)/2 and the coverage is at least c. When no
rank in 1..n satisfies a side, the sample cannot bound the quantile on that side (for p = 0.95 and c = 0.95 the upper
side needs n >= 72): that bound is NaN, "not estimable". The sample minimum and maximum estimate no fixed parameter
(they move outward as n grows), so the ``minmax`` method has no confidence interval.

Densities are volume fractions (dimensionless).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..core.errors import InputError

METHODS = ("minmax", "quantile")
BAND_DEFAULTS = {"method": "minmax", "alpha": 0.95, "confidence": 0.95, "min_packings": 5}
#: The ``fast`` config section's defaults: a compression is fast below these 1/gamma (the paper's Fig. 2b, 2d).
FAST_DEFAULTS = {"ls_max_inverse_rate": 5.0, "fb_max_inverse_rate": 1000.0}


def _sorted_finite(values) -> np.ndarray:
    x = np.asarray(values, dtype=float).ravel()
    return np.sort(x[np.isfinite(x)])


def _check_level(name: str, value: float) -> float:
    if not (isinstance(value, (int, float)) and 0 < value < 1):
        raise InputError(f"{name}={value!r}: must be in (0, 1)")
    return float(value)


def upper_quantile(values, alpha: float = 0.95) -> float:
    """phi_RCP by eq. 18: the smallest sample value x with (number of values <= x) / n >= alpha; NaN if empty."""
    alpha = _check_level("alpha", alpha)
    x = _sorted_finite(values)
    if len(x) == 0:
        return math.nan
    rank = max(1, math.ceil(alpha * len(x) - 1e-9))  # 1-based; the tolerance keeps 0.95 * 20 at rank 19
    return float(x[rank - 1])


def lower_quantile(values, alpha: float = 0.95) -> float:
    """phi_LT by eq. 18 mirrored: the largest sample value x with (number of values >= x) / n >= alpha."""
    alpha = _check_level("alpha", alpha)
    x = _sorted_finite(values)
    if len(x) == 0:
        return math.nan
    rank = min(len(x), math.floor((1.0 - alpha) * len(x) + 1e-9) + 1)
    return float(x[rank - 1])


def quantile_interval(values, level: float, confidence: float = 0.95) -> tuple[float, float]:
    """Distribution-free confidence interval (lower, upper) of the ``level``-quantile from order statistics.

    Either end is NaN when the sample is too small to bound the quantile on that side (see the module docstring).
    """
    from scipy import stats

    level = _check_level("level", level)
    confidence = _check_level("confidence", confidence)
    x = _sorted_finite(values)
    n = len(x)
    if n == 0:
        return math.nan, math.nan
    tail = (1.0 - confidence) / 2.0
    ranks = np.arange(1, n + 1)
    below = stats.binom.cdf(ranks - 1, n, level)  # P(B <= r - 1): X_(r) lies above the quantile
    above = stats.binom.sf(ranks - 1, n, level)  # P(B >= r): X_(r) lies below the quantile
    ok_low = ranks[below <= tail]
    ok_high = ranks[above <= tail]
    low = float(x[ok_low.max() - 1]) if len(ok_low) else math.nan
    high = float(x[ok_high.min() - 1]) if len(ok_high) else math.nan
    return low, high


@dataclass(frozen=True)
class BandEdges:
    """Both edges of one band of n values, by both methods, with the quantile intervals (NaN = not estimable)."""

    n: int
    phi_min: float
    phi_max: float
    q_low: float  # phi_LT by eq. 18
    q_high: float  # phi_RCP by eq. 18
    q_low_ci: tuple[float, float]
    q_high_ci: tuple[float, float]

    def edge(self, side: str, method: str) -> tuple[float, float]:
        """(estimate, confidence half-width) of the ``low`` or ``high`` edge by ``method``; NaN = not estimable.

        The half-width of a quantile is half the length of its interval; the sample extremes have none.
        """
        if method not in METHODS:
            raise InputError(f"bands.method={method!r}: must be one of {', '.join(METHODS)}")
        if method == "minmax":
            return (self.phi_min if side == "low" else self.phi_max), math.nan
        value, (lo, hi) = (self.q_low, self.q_low_ci) if side == "low" else (self.q_high, self.q_high_ci)
        return value, (hi - lo) / 2.0 if math.isfinite(lo) and math.isfinite(hi) else math.nan


def band_edges(values, alpha: float = 0.95, confidence: float = 0.95) -> BandEdges:
    """Edges of the band of ``values`` (NaN values are dropped)."""
    x = _sorted_finite(values)
    if len(x) == 0:
        nan2 = (math.nan, math.nan)
        return BandEdges(0, math.nan, math.nan, math.nan, math.nan, nan2, nan2)
    return BandEdges(
        n=len(x), phi_min=float(x[0]), phi_max=float(x[-1]),
        q_low=lower_quantile(x, alpha), q_high=upper_quantile(x, alpha),
        q_low_ci=quantile_interval(x, 1.0 - alpha, confidence),
        q_high_ci=quantile_interval(x, alpha, confidence),
    )


__all__ = ["METHODS", "BAND_DEFAULTS", "FAST_DEFAULTS", "BandEdges", "band_edges", "lower_quantile", "upper_quantile",
           "quantile_interval"]
