"""Steinhardt Q6, radical Voronoi volumes, g(r), pore-size entropy and the flat analysis record."""

import itertools
import math

import numpy as np
import pytest

from spherejam.analysis import structure
from spherejam.core.errors import InputError
from spherejam.core.packing import Packing
from spherejam.core.seeding import poisson_packing


def fcc(m: int) -> Packing:
    """m^3 conventional FCC cells of side 1, touching spheres of diameter 1/sqrt 2."""
    basis = np.array([[0, 0, 0], [0.5, 0.5, 0], [0.5, 0, 0.5], [0, 0.5, 0.5]])
    cells = np.array(np.meshgrid(*[np.arange(m)] * 3, indexing="ij")).reshape(3, -1).T
    pos = (cells[:, None, :] + basis[None]).reshape(-1, 3) + 0.1
    return Packing(pos, np.full(len(pos), np.sqrt(0.5)), float(m))

Q6_FCC = 0.57452425971  # sqrt(4 pi / 13 * sum_m |Y_6m|^2) over the 12 FCC bond directions


def dense_random(n, seed, neighbours=12.0):
    """Ideal-gas points with (overlapping) diameters giving ~``neighbours`` bonds within 1.2 D."""
    rng = np.random.default_rng(seed)
    box = 10.0
    dia = (neighbours / (n / box**3) / (4 / 3 * np.pi)) ** (1 / 3) / 1.2
    return Packing(rng.random((n, 3)) * box, np.full(n, dia), box)


def test_fcc_q6_global_and_local():
    qg, ql, _qi, nb = structure.steinhardt(fcc(3))
    assert qg == pytest.approx(Q6_FCC, abs=1e-9) and ql == pytest.approx(Q6_FCC, abs=1e-9)
    assert np.all(nb == 12)
    one = Packing(np.array([[0.0, 0, 0]] + [list(v) for v in 0.7 * np.eye(3)]), np.ones(4), 10.0)
    assert structure.steinhardt(one, 6)[3][0] == 3


def test_random_q6_is_small_and_local_matches_freud():
    freud = pytest.importorskip("freud")
    p = dense_random(3000, 1)
    qg, ql, qi, nb = structure.steinhardt(p)
    assert qg < 0.03  # ~ (number of bonds)^-1/2
    assert 0.2 < ql < 0.45
    i, j, d = structure.bond_network(p)
    box = freud.box.Box.cube(p.box)
    qi_, pi_, vec = np.r_[i, j], np.r_[j, i], np.r_[d, -d]
    order = np.lexsort((pi_, qi_))
    nlist = freud.locality.NeighborList.from_arrays(p.n, p.n, qi_[order], pi_[order], vec[order])
    st = freud.order.Steinhardt(6)
    st.compute((box, p.positions - p.box / 2), neighbors=nlist)
    ok = nb > 0
    np.testing.assert_allclose(st.particle_order[ok], qi[ok], atol=2e-5)  # freud works in float32


def test_crystalline_fraction_of_crystals_glasses_and_mixtures():
    assert structure.crystalline_fraction(fcc(3)) == (1.0, 1.0)
    assert structure.crystalline_fraction(dense_random(3000, 1)) == (0.0, 0.0)
    p = fcc(6)  # 864 particles in a box of side 6
    rng = np.random.default_rng(0)
    melted = p.positions.copy()
    top = melted[:, 2] > 3.1  # 5/12 of the particles: replace them by random points
    melted[top] = rng.random((top.sum(), 3)) * [6, 6, 2.9] + [0, 0, 3.1]
    frac, largest = structure.crystalline_fraction(Packing(melted, p.diameters, p.box))
    assert frac == largest and 0.5 < frac < 0.65  # the 7/12 left, give or take the interface
    slabs = p.positions.copy()
    z = slabs[:, 2]
    shaken = ((z > 1.6) & (z < 3.1)) | (z > 4.6)  # two crystalline slabs of 1/3 each, separated by shaken ones
    slabs[shaken] += rng.normal(0, 0.3, (shaken.sum(), 3))
    frac, largest = structure.crystalline_fraction(Packing(slabs, p.diameters, p.box))
    assert 0.6 < frac < 0.72 and 0.3 < largest < 0.37
    with pytest.raises(InputError, match="solid_bonds"):
        structure.crystalline_fraction(p, solid_bonds=0)


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
    v = structure.voronoi_volumes(p)
    assert v.sum() == pytest.approx(p.box**3, rel=1e-12)
    np.testing.assert_allclose(v, brute_power_volumes(p), rtol=1e-9)
    if sigma:
        assert not np.allclose(v, structure.voronoi_volumes(p, radical=False), rtol=1e-3)


def test_voronoi_of_crystals_and_against_freud():
    p = fcc(3)
    np.testing.assert_allclose(structure.voronoi_volumes(p), 1.0 / 4.0, rtol=1e-12)
    stats = structure.voronoi_statistics(structure.voronoi_volumes(p), p.diameters)
    assert stats["voronoi_volume_std"] < 1e-12 and stats["voronoi_entropy"] == -math.inf
    freud = pytest.importorskip("freud")
    q = poisson_packing(2000, 0.0, 2)  # monodisperse: radical = ordinary Voronoi
    vor = freud.locality.Voronoi()
    vor.compute((freud.box.Box.cube(q.box), q.positions - q.box / 2))
    np.testing.assert_allclose(structure.voronoi_volumes(q), vor.volumes, rtol=1e-4)  # freud: float32


def test_voronoi_entropy_is_the_fitted_gamma_entropy():
    from scipy import stats

    rng = np.random.default_rng(4)
    d = np.ones(5000)
    v = 0.6938 + rng.gamma(12.0, 0.02, 5000)
    out = structure.voronoi_statistics(v, d)
    free = v - 0.6938
    k = free.mean() ** 2 / free.var()
    assert out["voronoi_k"] == pytest.approx(k)
    assert out["voronoi_entropy"] == pytest.approx(stats.gamma(k, scale=free.mean() / k).entropy())
    # in units of the mean diameter: rescaling all lengths changes nothing
    out2 = structure.voronoi_statistics(v * 8.0, d * 2.0)
    assert out2["voronoi_entropy"] == pytest.approx(out["voronoi_entropy"], rel=1e-12)


@pytest.mark.parametrize("dim", [2, 3])
def test_pair_correlation_of_ideal_gas_is_one(dim):
    rng = np.random.default_rng(dim)
    n, box = 4000, 10.0
    p = Packing(rng.random((n, dim)) * box, np.full(n, 0.5), box)
    r, g = structure.pair_correlation(p, r_max=12.0, bins=40)
    assert r[-1] < 10.0 and r[-1] > 9.0  # capped at L/2 (in units of the mean diameter 0.5)
    assert abs(g[5:].mean() - 1.0) < 0.01
    assert np.all(np.abs(g[5:] - 1.0) < 0.15)


def test_pair_correlation_of_fcc_peaks_at_contact():
    r, g = structure.pair_correlation(fcc(4), r_max=2.5, bins=250)
    assert r[np.argmax(g)] == pytest.approx(1.0, abs=0.01)


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
    s, frac, used = structure.pore_size_entropy(p, seed=9, samples=20_000)
    y = np.random.default_rng(np.random.SeedSequence(9)).random((20_000, 3)) * p.box
    assert frac == brute_large_pore_fraction(p, y)
    assert used == 20_000 and s == pytest.approx(4 * math.log(frac))
    assert 0.001 < frac < 0.5


def test_pore_entropy_invariant_under_rescaling_and_reproducible():
    p = poisson_packing(300, 0.2, 4, phi_nominal=0.5)
    p = at_density(p, 0.5)
    a = structure.pore_size_entropy(p, seed=1, samples=50_000)
    for scale in (1e-3, 7.0):
        q = Packing(p.positions * scale, p.diameters * scale, p.box * scale)
        b = structure.pore_size_entropy(q, seed=1, samples=50_000)
        assert b[0] == pytest.approx(a[0], rel=1e-3) and abs(b[1] - a[1]) * 50_000 <= 2
    assert structure.pore_size_entropy(p, seed=1, samples=50_000) == a


def test_pore_entropy_stopping_rule():
    p = poisson_packing(100, 0.0, 4, phi_nominal=0.5)
    p = at_density(p, 0.4)
    s, frac, used = structure.pore_size_entropy(p, seed=2, min_samples=30_000)
    assert used >= 30_000 and used % structure.PORE_CHECK_EVERY == 0 and used < 10**6
    assert s == pytest.approx(4 * math.log(frac))
    assert structure.pore_size_entropy(fcc(3), samples=10_000)[0] == -math.inf  # no pore > a/4 in FCC


def test_analyze_returns_every_variable():
    p = fcc(3)
    p.metadata["reduced_pressure"] = 1e12
    out = structure.analyze(p, pore_samples=10_000)
    assert list(out) == list(structure.VARIABLES)
    assert out["z_nonrattler"] == 12.0 and out["q6_local"] == pytest.approx(Q6_FCC)
    assert out["crystalline_fraction"] == 1.0
    assert all(isinstance(v, float) for v in out.values())
    assert all(len(v) == 2 and v[1] == "1" for v in structure.VARIABLES.values())
    q = poisson_packing(200, 0.1, 1, dim=4)
    out4 = structure.analyze(q, pore_samples=10_000)
    assert math.isnan(out4["q6_global"]) and math.isnan(out4["voronoi_entropy"])
    assert math.isnan(out4["crystalline_fraction"])
    assert math.isfinite(out4["pore_size_entropy"])
    with pytest.raises(InputError, match="d=4"):
        structure.voronoi_volumes(q)
    with pytest.raises(InputError, match="pore_samples"):
        structure.pore_size_entropy(p, samples=0)


def test_cli_analyze_writes_the_variables(tmp_path, capsys):
    import json

    from spherejam.cli import main
    from spherejam.core.packing_io import write_packing

    path = tmp_path / "fcc.h5"
    write_packing(path, fcc(3))
    out = tmp_path / "s.json"
    assert main(["analyze", str(path), "--json", "--pore-samples", "1000", "-o", str(out), "--scan"]) == 0
    record = json.loads(out.read_text())
    assert json.loads(capsys.readouterr().out) == record
    assert set(structure.VARIABLES) <= set(record) and record["z_nonrattler"] == 12.0
    assert record["pore_size_entropy"] is None  # -inf (no large pore) is not JSON
    assert all(z == 12.0 for z in record["tolerance_scan"]["z_nonrattler"])
    assert main(["analyze", str(path), "--contact-tolerance", "2"]) == 2
