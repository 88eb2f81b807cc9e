"""Pore-size entropy (analysis/pore_size.py)."""

import math

import numpy as np
import pytest

from spherejam.analysis import pore_size
from spherejam.core.packing import Packing
from spherejam.core.seeding import poisson_packing


def at_density(p: Packing, phi: float) -> Packing:
    """The same centres and relative sizes, diameters scaled to packing fraction ``phi`` (overlaps allowed)."""
    return p.replace(diameters=p.diameters * (phi / p.phi) ** (1 / p.dim))


def brute_large_pore_fraction(p, y):
    d = y[:, None, :] - p.positions[None]
    d -= p.box * np.floor(d / p.box + 0.5)
    r = np.sqrt((d * d).sum(-1)) - 0.5 * p.diameters[None]
    return np.mean(r.min(axis=1) / p.mean_diameter > 0.25)


@pytest.mark.parametrize("sigma", [0.0, 0.25])
def test_pore_fraction_matches_brute_force(sigma):
    p = poisson_packing(200, sigma, 3, phi_nominal=0.55)
    p = at_density(p, 0.55)  # dense, overlapping: a small large-pore fraction
    s, frac, used = pore_size.pore_size_entropy(p, seed=9, samples=20_000)
    y = np.random.default_rng(np.random.SeedSequence(9)).random((20_000, 3)) * p.box
    assert frac == brute_large_pore_fraction(p, y)
    assert used == 20_000 and s == pytest.approx(4 * math.log(frac))
    assert 0.001 < frac < 0.5


def test_pore_entropy_invariant_under_rescaling_and_reproducible():
    p = poisson_packing(300, 0.2, 4, phi_nominal=0.5)
    p = at_density(p, 0.5)
    a = pore_size.pore_size_entropy(p, seed=1, samples=50_000)
    for scale in (1e-3, 7.0):
        q = Packing(p.positions * scale, p.diameters * scale, p.box * scale)
        b = pore_size.pore_size_entropy(q, seed=1, samples=50_000)
        assert b[0] == pytest.approx(a[0], rel=1e-3) and abs(b[1] - a[1]) * 50_000 <= 2
    assert pore_size.pore_size_entropy(p, seed=1, samples=50_000) == a


def test_pore_entropy_stopping_rule(fcc):
    p = poisson_packing(100, 0.0, 4, phi_nominal=0.5)
    p = at_density(p, 0.4)
    s, frac, used = pore_size.pore_size_entropy(p, seed=2, min_samples=30_000)
    assert used >= 30_000 and used % pore_size.PORE_CHECK_EVERY == 0 and used < 10**6
    assert s == pytest.approx(4 * math.log(frac))
    assert pore_size.pore_size_entropy(fcc(3), samples=10_000)[0] == -math.inf  # no pore > a/4 in FCC
