"""The GCP fit and its confidence interval on synthetic data with known coefficients."""

import numpy as np
import pytest

from spherejam import InputError
from spherejam.workflow.fits import design_matrix, fit_gcp

TRUE = np.array([0.6612, -0.05, 0.3, -1.2])


def test_exact_recovery_without_noise():
    rate = np.geomspace(1e-5, 1e-1, 40)
    phi = design_matrix(rate) @ TRUE
    fit = fit_gcp(rate, phi)
    np.testing.assert_allclose(fit.coefficients, TRUE, rtol=1e-8, atol=1e-10)
    assert fit.half_width < 1e-10


def test_confidence_interval_coverage_is_95_percent():
    rng = np.random.default_rng(1)
    rate = np.geomspace(1e-5, 3e-2, 30)
    clean = design_matrix(rate) @ TRUE
    trials, hits = 2000, 0
    for _ in range(trials):
        fit = fit_gcp(rate, clean + rng.normal(0, 2e-3, rate.size))
        hits += abs(fit.phi_gcp - TRUE[0]) <= fit.half_width
    coverage = hits / trials
    # binomial std at p = 0.95, n = 2000 is 0.005: 0.93 ... 0.97 is a ~4-sigma band
    assert 0.93 < coverage < 0.97


def test_uses_only_the_slowest_points():
    rate = np.geomspace(1e-4, 1.0, 50)
    phi = design_matrix(rate) @ TRUE
    phi[rate > 1e-2] = 0.0  # a "fast plateau" that must be excluded
    fit = fit_gcp(rate, phi, n_points=20)
    assert fit.n_points == 20 and fit.min_inverse_rate == pytest.approx(1 / rate[19])
    assert fit.phi_gcp == pytest.approx(TRUE[0], abs=1e-9)


def test_too_few_points_and_bad_input():
    with pytest.raises(InputError, match="n_points"):
        fit_gcp([1e-3, 1e-4, 1e-5], [0.6, 0.61, 0.62])
    with pytest.raises(InputError, match="confidence"):
        fit_gcp(np.ones(5), np.ones(5), confidence=1.5)
    fit = fit_gcp(np.geomspace(1e-4, 1e-2, 4), np.array([0.64, 0.65, 0.66, 0.67]))
    assert np.isnan(fit.half_width)  # no residual degrees of freedom: no interval, not a fake one
