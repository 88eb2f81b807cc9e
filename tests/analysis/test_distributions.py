"""Force and gap distributions (analysis/distributions.py): the power-law fit on synthetic data."""

import numpy as np

from spherejam.analysis.distributions import fit_cumulative_power_law


def test_power_law_fit_recovers_exponent():
    rng = np.random.default_rng(0)
    a_true = 0.6  # cumulative ~ x^0.6, i.e. gap exponent gamma = 0.4
    x = rng.random(20000) ** (1 / a_true) * 1e-2
    a, se, k = fit_cumulative_power_law(x, 1e-6, 1e-2)
    assert abs(a - a_true) < 4 * se and se < 0.02
    assert k == np.count_nonzero(x >= 1e-6)
