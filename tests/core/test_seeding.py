import math

import numpy as np
import pytest

from spherejam import InputError
from spherejam.core.seeding import lognormal_diameters, poisson_packing, rng_for


@pytest.mark.parametrize("sigma", [0.05, 0.1, 0.3])
def test_lognormal_statistics_large_n(sigma):
    d = lognormal_diameters(400_000, sigma, rng_for(7))
    assert d.mean() == pytest.approx(1.0, abs=1e-12)
    assert d.std() / d.mean() == pytest.approx(sigma, rel=0.01)
    # log-normal: ln D is normal with variance ln(1 + sigma^2); check its skewness is ~0 and variance matches
    ln = np.log(d)
    assert ln.var() == pytest.approx(math.log1p(sigma**2), rel=0.01)
    assert abs(((ln - ln.mean()) ** 3).mean() / ln.std() ** 3) < 0.02


def test_monodisperse():
    assert np.all(lognormal_diameters(100, 0.0, rng_for(0)) == 1.0)


@pytest.mark.parametrize("dim", [2, 3, 4, 5])
def test_poisson_packing_touches_and_reproduces(dim):
    p = poisson_packing(500, 0.3, seed=3, dim=dim)
    q = poisson_packing(500, 0.3, seed=3, dim=dim)
    r = poisson_packing(500, 0.3, seed=4, dim=dim)
    assert p.dim == dim and p.n == 500
    np.testing.assert_array_equal(p.positions, q.positions)
    np.testing.assert_array_equal(p.diameters, q.diameters)
    assert not np.array_equal(p.positions, r.positions)
    assert p.closest_pair()[2] == pytest.approx(1.0, abs=1e-12)
    assert p.check().ok
    assert p.nominal_diameters.mean() == pytest.approx(1.0)
    assert np.all((p.positions >= 0) & (p.positions < p.box))


def test_poisson_density_is_tiny_for_large_n():
    p = poisson_packing(10_000, 0.0, seed=1)
    assert 1e-7 < p.phi < 1e-3


@pytest.mark.parametrize(
    "kwargs, field",
    [({"n": 1}, "n"), ({"n": 10, "sigma": -0.1}, "sigma"), ({"n": 10, "phi_nominal": 1.5}, "phi_nominal"),
     ({"n": 10, "dim": 6}, "dim"), ({"n": 10, "seed": -1}, "seed"), ({"n": 10, "sigma": float("nan")}, "sigma")],
)
def test_bad_input_names_field(kwargs, field):
    with pytest.raises(InputError, match=field):
        poisson_packing(**kwargs)
