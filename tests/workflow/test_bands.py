"""Band edges of fast-compression phi_J: the paper's eq. 18 quantiles by hand, and order-statistic intervals."""

import math

import numpy as np
import pytest
from scipy import stats

from spherejam import InputError
from spherejam.workflow.bands import band_edges, lower_quantile, quantile_interval, upper_quantile

# 20 values, shuffled; sorted they are 0.630, 0.631, ..., 0.649
VALUES = np.array([0.630 + 0.001 * k for k in (7, 19, 0, 12, 3, 15, 8, 1, 18, 10, 5, 13, 2, 16, 9, 4, 17, 11, 6, 14)])


def test_alpha_quantiles_by_hand():
    # n = 20, alpha = 0.95: phi_RCP is the smallest x with #(<= x)/20 >= 0.95, i.e. the 19th value, 0.648;
    # phi_LT the largest x with #(>= x)/20 >= 0.95, i.e. the 2nd value, 0.631 (19 of 20 values are >= it)
    assert upper_quantile(VALUES, 0.95) == pytest.approx(0.648, abs=1e-12)
    assert lower_quantile(VALUES, 0.95) == pytest.approx(0.631, abs=1e-12)
    # alpha = 0.9: 18th and 3rd values
    assert upper_quantile(VALUES, 0.9) == pytest.approx(0.647, abs=1e-12)
    assert lower_quantile(VALUES, 0.9) == pytest.approx(0.632, abs=1e-12)
    # fewer than 1 / (1 - alpha) = 20 values: the sample extremes
    few = VALUES[:10]
    assert upper_quantile(few, 0.95) == few.max() and lower_quantile(few, 0.95) == few.min()
    # NaN values (cut MLS runs) are dropped; an empty band has no edge
    assert upper_quantile(np.append(VALUES, np.nan), 0.95) == pytest.approx(0.648, abs=1e-12)
    assert math.isnan(upper_quantile([], 0.95))
    with pytest.raises(InputError, match="alpha"):
        upper_quantile(VALUES, 1.0)


def test_order_statistic_interval_by_hand_and_not_estimable_ends():
    x = np.arange(1.0, 101.0)  # X_(k) = k
    lo, hi = quantile_interval(x, 0.5, 0.95)
    # B ~ Bin(100, 0.5): P(B <= 39) = 0.0176 <= 0.025 < P(B <= 40) = 0.0284, so l = 40; symmetric u = 61
    assert (lo, hi) == (40.0, 61.0)
    assert stats.binom.cdf(39, 100, 0.5) <= 0.025 < stats.binom.cdf(40, 100, 0.5)
    # the 95 % quantile needs n >= 72 for an upper bound: 0.95^72 = 0.0249 <= 0.025 < 0.95^71
    assert math.isnan(quantile_interval(np.arange(71.0), 0.95, 0.95)[1])
    assert quantile_interval(np.arange(1.0, 73.0), 0.95, 0.95)[1] == 72.0
    # and the 5 % quantile, symmetrically, a lower bound
    assert math.isnan(quantile_interval(np.arange(71.0), 0.05, 0.95)[0])
    assert quantile_interval(np.arange(1.0, 73.0), 0.05, 0.95)[0] == 1.0


def test_interval_coverage_is_at_least_the_confidence():
    rng = np.random.default_rng(3)
    level, trials, hits = 0.9, 1000, 0
    true = stats.norm.ppf(level)
    for _ in range(trials):
        lo, hi = quantile_interval(rng.normal(size=150), level, 0.95)
        hits += lo <= true <= hi
    assert hits / trials >= 0.93  # at least 0.95 by construction (conservative); 0.93 allows binomial noise


def test_band_edges_methods():
    e = band_edges(VALUES, 0.95, 0.95)
    assert e.n == 20 and e.phi_min == pytest.approx(0.630) and e.phi_max == pytest.approx(0.649)
    value, half = e.edge("high", "minmax")
    assert value == e.phi_max and math.isnan(half)  # a sample extreme has no confidence interval
    value, half = e.edge("high", "quantile")
    assert value == pytest.approx(0.648) and math.isnan(half)  # 20 values cannot bound the 95 % quantile above
    big = band_edges(np.linspace(0.63, 0.65, 200), 0.95, 0.95)
    value, half = big.edge("low", "quantile")
    lo, hi = big.q_low_ci
    assert lo <= value <= hi and half == pytest.approx((hi - lo) / 2) and half > 0
    with pytest.raises(InputError, match="bands.method"):
        e.edge("low", "median")
