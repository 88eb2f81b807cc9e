"""Radical Voronoi volumes and their statistics (analysis/voronoi.py)."""

import itertools
import math

import numpy as np
import pytest

from spherejam.analysis import voronoi
from spherejam.core.packing import Packing
from spherejam.core.seeding import poisson_packing


def brute_power_volumes(p: Packing) -> np.ndarray:
    """Each power cell by half-space intersection with all 27 periodic images (O(N^2), double precision)."""
    from scipy.spatial import ConvexHull, HalfspaceIntersection

    w = 0.25 * p.diameters**2
    shifts = np.array(list(itertools.product((-1, 0, 1), repeat=3)), float) * p.box
    img = (p.positions[None] + shifts[:, None]).reshape(-1, 3)
    wimg = np.tile(w, len(shifts))
    vols = []
    for i in range(p.n):
        x = p.positions[i]
        others = np.ones(len(img), bool)
        others[13 * p.n + i] = False  # the zero shift is index 13 in product order
        e = img[others] - x
        # e . y <= (|e|^2 + w_i - w_j) / 2 in the frame of x_i, as A y + b <= 0
        halfspaces = np.c_[e, -0.5 * ((e * e).sum(1) + w[i] - wimg[others])]
        hs = HalfspaceIntersection(halfspaces, np.zeros(3))
        vols.append(ConvexHull(hs.intersections).volume)
    return np.array(vols)


@pytest.mark.parametrize("sigma", [0.0, 0.3])
def test_voronoi_volumes_match_brute_force_and_sum_to_box(sigma):
    p = poisson_packing(40, sigma, 5, phi_nominal=0.3)
    v = voronoi.voronoi_volumes(p)
    assert v.sum() == pytest.approx(p.box**3, rel=1e-12)
    np.testing.assert_allclose(v, brute_power_volumes(p), rtol=1e-9)
    if sigma:
        assert not np.allclose(v, voronoi.voronoi_volumes(p, radical=False), rtol=1e-3)


def test_voronoi_of_crystals_and_against_freud(fcc):
    p = fcc(3)
    np.testing.assert_allclose(voronoi.voronoi_volumes(p), 1.0 / 4.0, rtol=1e-12)
    stats = voronoi.voronoi_statistics(voronoi.voronoi_volumes(p), p.diameters)
    assert stats["voronoi_volume_std"] < 1e-12 and stats["voronoi_entropy"] == -math.inf
    freud = pytest.importorskip("freud")
    q = poisson_packing(2000, 0.0, 2)  # monodisperse: radical = ordinary Voronoi
    vor = freud.locality.Voronoi()
    vor.compute((freud.box.Box.cube(q.box), q.positions - q.box / 2))
    np.testing.assert_allclose(voronoi.voronoi_volumes(q), vor.volumes, rtol=1e-4)  # freud: float32


def test_voronoi_entropy_is_the_fitted_gamma_entropy():
    from scipy import stats

    rng = np.random.default_rng(4)
    d = np.ones(5000)
    v = 0.6938 + rng.gamma(12.0, 0.02, 5000)
    out = voronoi.voronoi_statistics(v, d)
    free = v - 0.6938
    k = free.mean() ** 2 / free.var()
    assert out["voronoi_k"] == pytest.approx(k)
    assert out["voronoi_entropy"] == pytest.approx(stats.gamma(k, scale=free.mean() / k).entropy())
    # in units of the mean diameter: rescaling all lengths changes nothing
    out2 = voronoi.voronoi_statistics(v * 8.0, d * 2.0)
    assert out2["voronoi_entropy"] == pytest.approx(out["voronoi_entropy"], rel=1e-12)
