"""Farr-Groot phi_RCP (our reconstruction) against Farr's published lognormal formula and exact bidisperse limits."""

import numpy as np
import pytest

from spherejam.analysis import farr_groot as fg

SIGMAS = [0.0, 0.05, 0.10, 0.15, 0.20, 0.25, 0.30]
# docs/farr_groot.md: s = sqrt(ln(1 + sigma^2)) and Farr's (2013) fit phi(s), rounded to 4 digits
S_OF_SIGMA = [0.0, 0.0500, 0.0998, 0.1492, 0.1980, 0.2462, 0.2936]
FARR_FIT = [0.6435, 0.6443, 0.6470, 0.6513, 0.6568, 0.6632, 0.6703]
PHI_1 = fg.PHI_MONODISPERSE


def test_sigma_convention():
    np.testing.assert_allclose(fg.s_of_sigma(np.array(SIGMAS)), S_OF_SIGMA, atol=5e-5)
    np.testing.assert_allclose(fg.farr2013_lognormal(np.array(S_OF_SIGMA)), FARR_FIT, atol=5e-5)


def test_monodisperse_calibration():
    assert fg.phi_rcp_lognormal(0.0) == pytest.approx(PHI_1, abs=2e-5)
    assert fg.phi_rcp_mixture([2.5], [1.0]) == pytest.approx(PHI_1, abs=2e-5)
    # a looser free length packs denser
    assert fg.phi_rcp_mixture([1.0], [1.0], f=0.74428) == pytest.approx(0.650, abs=1e-4)


def test_lognormal_follows_farr_2013_formula():
    ours = fg.phi_rcp_curve(SIGMAS)
    np.testing.assert_allclose(ours, FARR_FIT, atol=4e-4)
    assert np.all(np.diff(ours) > 0)
    # wide distributions: s = std(ln D) = 1.25 is sigma = 1.9; the discretised tails cost a few 1e-4
    for s, tol in ((0.5, 1e-4), (1.0, 2e-4), (1.25, 5e-4)):
        sigma = np.sqrt(np.expm1(s**2))
        assert fg.phi_rcp_lognormal(sigma) == pytest.approx(float(fg.farr2013_lognormal(s)), abs=tol)


@pytest.mark.parametrize("x_s", [0.05, 0.1, 0.2, 0.24, 0.4, 0.6, 0.8])
def test_bidisperse_infinite_ratio_limits(x_s):
    """At size ratio 1000 the small spheres fill the large ones' voids (x_s < x_s*) or the large ones sit in a
    matrix of small ones (x_s > x_s*): phi = phi_1/(1 - x_s) or phi_1/(x_s + phi_1 (1 - x_s))."""
    x_star = (1 - PHI_1) / (2 - PHI_1)
    exact = PHI_1 / (1 - x_s) if x_s <= x_star else PHI_1 / (x_s + PHI_1 * (1 - x_s))
    assert fg.phi_rcp_bidisperse(1000.0, x_s) == pytest.approx(exact, abs=5e-4)


@pytest.mark.parametrize("ratio, expected", [
    (2, [0.6655, 0.6798, 0.6819, 0.6799, 0.6758, 0.6642]),
    (10, [0.7150, 0.8044, 0.8147, 0.7855, 0.7579, 0.7078]),
])
def test_bidisperse_finite_ratio_reference_values(ratio, expected):
    got = [fg.phi_rcp_bidisperse(ratio, x) for x in (0.1, 0.2, 0.3, 0.4, 0.5, 0.7)]
    np.testing.assert_allclose(got, expected, atol=2e-4)


def test_invariants():
    d, n = np.array([1.0, 1.7, 3.0]), np.array([0.5, 0.3, 0.2])
    phi = fg.phi_rcp_mixture(d, n)
    assert fg.phi_rcp_mixture(7.3 * d, n) == pytest.approx(phi, abs=1e-9)  # scale-free
    assert fg.phi_rcp_bidisperse(1.0, 0.37) == pytest.approx(PHI_1, abs=2e-5)  # equal sizes: monodisperse
    assert fg.pack_rods([1.0, 0.2, 0.5]) == fg.pack_rods([0.2, 0.5, 1.0])  # order of the input does not matter


def test_bad_input():
    with pytest.raises(ValueError, match="sigma"):
        fg.phi_rcp_lognormal(-0.1)
    with pytest.raises(ValueError):
        fg.pack_rods([1.0, 0.0])
    with pytest.raises(ValueError):
        fg.phi_rcp_bidisperse(0.5, 0.2)
