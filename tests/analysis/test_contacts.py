"""Contacts, rattlers (k-core), coordination and the pressure-aware contact tolerance."""

import numpy as np
import pytest

from spherejam.analysis import contacts
from spherejam.core.errors import InputError
from spherejam.core.packing import Packing


def fcc(m: int, diameter: float = np.sqrt(0.5)) -> Packing:
    """m^3 conventional FCC cells of side 1 (nearest-neighbour distance 1/sqrt 2), spheres touching."""
    basis = np.array([[0, 0, 0], [0.5, 0.5, 0], [0.5, 0, 0.5], [0, 0.5, 0.5]])
    cells = np.array(np.meshgrid(*[np.arange(m)] * 3, indexing="ij")).reshape(3, -1).T
    pos = (cells[:, None, :] + basis[None]).reshape(-1, 3) + 0.1
    return Packing(pos, np.full(len(pos), diameter), float(m))


def naive_rattlers(n, i, j, k):
    """The reference rule: repeatedly drop every particle with < k contacts among the survivors."""
    alive = np.ones(n, bool)
    while True:
        keep = alive[i] & alive[j]
        deg = np.bincount(i[keep], minlength=n) + np.bincount(j[keep], minlength=n)
        drop = alive & (deg < k)
        if not drop.any():
            return ~alive
        alive &= ~drop


@pytest.mark.parametrize("seed", range(8))
@pytest.mark.parametrize("k", [3, 4, 5])
def test_k_core_equals_recursive_removal(seed, k):
    rng = np.random.default_rng(seed)
    n = int(rng.integers(5, 300))
    m = int(rng.integers(0, 4 * n))
    i = rng.integers(0, n, m)
    j = rng.integers(0, n, m)
    ok = i != j
    pairs = np.unique(np.sort(np.c_[i[ok], j[ok]], axis=1), axis=0)
    i, j = pairs[:, 0].copy(), pairs[:, 1].copy()
    got = contacts.rattler_mask(n, i, j, k)
    assert np.array_equal(got, naive_rattlers(n, i, j, k))


def test_the_rank_rule_keeps_a_wall_layer_sphere_on_three_coplanar_contacts():
    """Counted by hand (docs/containers.md §4, §5). Sphere 0 of a flat wall layer touches spheres 1-3 at 120 degrees,
    all centres on the plane z = r; 1-3 and the wall (node 4) are held (fixed contacts). Its three contacts span 2
    dimensions: too few for the k-core (3 < d + 1 = 4), enough for the rank rule (s + 1 = 3), which keeps it with one
    free direction (z). Its wall contact makes the span 3 and the count 4: kept, no free direction. Two collinear
    contacts (span 1) need 2; three in general position (span 3) need 4: a rattler."""
    from spherejam.core.rattlers import spanned_dimensions

    angles = np.deg2rad([0.0, 120.0, 240.0])
    plane = np.c_[np.cos(angles), np.sin(angles), np.zeros(3)]
    fixed = np.array([0, 4, 4, 4, 4])
    i, j = np.zeros(3, dtype=np.int64), np.arange(1, 4)
    assert contacts.rattler_mask(5, i, j, 4, fixed)[0]  # the k-core: a rattler
    assert not contacts.rattler_mask(5, i, j, 4, fixed, -plane)[0]  # the rank rule: held in its plane
    assert spanned_dimensions(5, i, plane)[0] == 2  # 3 - 2 = 1 free direction
    wall_i, wall_j = np.r_[i, 0], np.r_[j, 4]
    with_wall = np.r_[plane, [[0.0, 0.0, 1.0]]]
    assert not contacts.rattler_mask(5, wall_i, wall_j, 4, fixed, with_wall)[0]
    assert spanned_dimensions(5, wall_i, with_wall)[0] == 3
    # the isostatic count of sphere 0 alone (its partners held, no zero mode): d N_s - z + 1 - F = 3 - 0 + 1 - 1 = 3
    # contacts without the wall's, 3 + 1 - 0 = 4 with it: the contacts it has either way
    assert 3 * 1 - 0 + 1 - (3 - 2) == len(i) and 3 * 1 - 0 + 1 - 0 == len(wall_i)
    collinear = np.array([[1.0, 0.0, 0.0], [-1.0, 0.0, 0.0]])
    assert not contacts.rattler_mask(5, i[:2], j[:2], 4, fixed, collinear)[0]
    tilted = plane + np.array([0.0, 0.0, 0.3])  # out of the plane: span 3, three contacts are too few
    assert contacts.rattler_mask(5, i, j, 4, fixed, tilted)[0]
    # recursively: sphere 0 (three contacts in general position) goes, and then sphere 1, left with two contacts
    # spanning 2 dimensions; were those two collinear, it would stay, held along their line
    chain_i, chain_j = np.array([0, 0, 0, 1, 1]), np.array([1, 2, 3, 2, 3])
    chain = np.array([[1.0, 0.0, 0.3], [0.0, 1.0, 0.3], [-1.0, 0.0, 0.3], [0.0, 1.0, 0.0], [1.0, 0.0, 0.0]])
    held = np.array([0, 0, 4, 4, 4])
    assert contacts.rattler_mask(5, chain_i, chain_j, 4, held, chain)[:2].tolist() == [True, True]
    chain[4] = [0.0, -1.0, 0.0]
    assert contacts.rattler_mask(5, chain_i, chain_j, 4, held, chain)[:2].tolist() == [True, False]


@pytest.mark.parametrize("dim", [2, 3, 4, 5])
def test_contacts_match_brute_force(dim):
    rng = np.random.default_rng(dim)
    n, box = 150, 6.0
    pos = rng.random((n, dim)) * box
    dia = rng.uniform(0.5, 1.5, n) * (box**dim / n) ** (1 / dim)  # overlapping spheres: many near pairs
    p = Packing(pos, dia, box)
    got = contacts.contact_pairs(p, 0.05)
    ref = contacts.brute_force_contacts(p, 0.05)
    assert set(zip(got[0].tolist(), got[1].tolist())) == set(zip(ref[0].tolist(), ref[1].tolist()))
    assert len(got[0]) > 10
    assert np.array_equal(got[0], ref[0]) and np.array_equal(got[1], ref[1])  # every image, sorted by (i, j, h)
    np.testing.assert_allclose(got[2], ref[2], rtol=0, atol=1e-12)


def test_fcc_has_z12_and_no_rattlers():
    p = fcc(3)
    c = contacts.analyze_contacts(p).coordination
    assert c.z_mean == 12.0 and c.z_nonrattler == 12.0 and c.rattler_fraction == 0.0
    assert c.n_contacts == 6 * p.n
    assert c.isostatic_excess == 6 * p.n - (3 * (p.n - 1) + 1) and c.isostatic_at_tolerance == 0


def test_interstitial_small_sphere_is_a_rattler_and_others_keep_z12():
    p = fcc(3)
    # octahedral hole at (0.5, 0.5, 0.5) + 0.1 has room for a sphere of diameter (1 - 1/sqrt 2) ~ 0.29
    q = Packing(np.vstack([p.positions, [0.6, 0.6, 0.6]]), np.r_[p.diameters, 0.2], p.box)
    out = contacts.analyze_contacts(q, contact_tolerance=1e-6)
    assert out.rattler.sum() == 1 and out.rattler[-1]
    assert out.coordination.z_nonrattler == 12.0


@pytest.mark.parametrize("dim", [2, 3, 4, 5])
def test_hypercubic_lattice_any_dimension(dim):
    """Simple (hyper)cubic lattice of touching unit spheres: Z = 2d, K = dN = K_0 + d - 1, no rattlers."""
    m = 3
    pos = np.array(np.meshgrid(*[np.arange(m)] * dim, indexing="ij"), float).reshape(dim, -1).T + 0.5
    p = Packing(pos, np.ones(len(pos)), float(m))
    c = contacts.analyze_contacts(p).coordination
    assert c.z_nonrattler == 2 * dim and c.rattler_fraction == 0.0
    assert c.isostatic_excess == dim - 1


def test_perturbed_fcc_at_p_1e12_is_stable_over_tolerances():
    rng = np.random.default_rng(7)
    p = fcc(4)
    p = p.replace(positions=p.positions + 2e-13 * rng.standard_normal(p.positions.shape)).scaled_to_contact()
    p.metadata["reduced_pressure"] = 1e12
    scan = contacts.tolerance_scan(p)
    assert scan["contact_tolerance"].min() == pytest.approx(1e-11)
    assert np.all(scan["z_nonrattler"] == 12.0) and np.all(scan["rattler_fraction"] == 0.0)
    tol = contacts.analyze_contacts(p).coordination.contact_tolerance
    assert 1e-11 <= tol <= 1e-3
    # a tolerance below the actual gaps sees (almost) nothing: the rule must not pick one there
    assert contacts.analyze_contacts(p, contact_tolerance=1e-15).coordination.z_mean < 12.0


def test_tolerance_rule_finds_the_plateau_of_a_jammed_gap_distribution():
    """Synthetic gaps of a packing at p = 1e12: contacts h = E/(p f) with an exponential force distribution
    (weak forces give a tail to large gaps), near-contacts with N(h) = 6.4 N h^0.6 (Donev et al. 2005)."""
    rng = np.random.default_rng(3)
    n, p = 10_000, 1e12
    k0 = 3 * n
    f = rng.exponential(1.0, k0)
    contact_gaps = rng.exponential(1.0, k0) / (p * f)
    n_near = int(6.4 * n * 0.03**0.6)
    near_gaps = 0.03 * rng.random(n_near) ** (1 / 0.6)
    tol = contacts.choose_tolerance(np.r_[contact_gaps, near_gaps], p)
    wrong = np.count_nonzero(contact_gaps >= tol) + np.count_nonzero(near_gaps < tol)
    assert 2 * wrong / n < 0.01  # Z off by less than 0.01
    assert 1e-11 <= tol <= 1e-6


def test_tolerance_uses_metadata_pressure_and_validates():
    p = fcc(2)
    p.metadata["reduced_pressure"] = 1e6
    assert contacts.scan_grid(contacts.packing_pressure(p))[0] == pytest.approx(1e-5)
    with pytest.raises(InputError, match="contact_tolerance"):
        contacts.analyze_contacts(p, contact_tolerance=-1.0)
    with pytest.raises(InputError, match="pressure"):
        contacts.analyze_contacts(p, pressure=0.0)
    with pytest.raises(InputError, match="min_contacts"):
        contacts.rattler_mask(3, np.array([0]), np.array([1]), 0)
