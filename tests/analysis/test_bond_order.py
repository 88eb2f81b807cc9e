"""Steinhardt Q6 and the crystalline fraction (analysis/bond_order.py)."""

import numpy as np
import pytest

from spherejam.analysis import bond_order
from spherejam.core.errors import InputError
from spherejam.core.packing import Packing

Q6_FCC = 0.57452425971  # sqrt(4 pi / 13 * sum_m |Y_6m|^2) over the 12 FCC bond directions


def dense_random(n, seed, neighbours=12.0):
    """Ideal-gas points with (overlapping) diameters giving ~``neighbours`` bonds within 1.2 D."""
    rng = np.random.default_rng(seed)
    box = 10.0
    dia = (neighbours / (n / box**3) / (4 / 3 * np.pi)) ** (1 / 3) / 1.2
    return Packing(rng.random((n, 3)) * box, np.full(n, dia), box)


def test_fcc_q6_global_and_local(fcc):
    qg, ql, _qi, nb = bond_order.steinhardt(fcc(3))
    assert qg == pytest.approx(Q6_FCC, abs=1e-9) and ql == pytest.approx(Q6_FCC, abs=1e-9)
    assert np.all(nb == 12)
    one = Packing(np.array([[0.0, 0, 0]] + [list(v) for v in 0.7 * np.eye(3)]), np.ones(4), 10.0)
    assert bond_order.steinhardt(one, 6)[3][0] == 3


def test_random_q6_is_small_and_local_matches_freud():
    freud = pytest.importorskip("freud")
    p = dense_random(3000, 1)
    qg, ql, qi, nb = bond_order.steinhardt(p)
    assert qg < 0.03  # ~ (number of bonds)^-1/2
    assert 0.2 < ql < 0.45
    i, j, d = bond_order.bond_network(p)
    box = freud.box.Box.cube(p.box)
    qi_, pi_, vec = np.r_[i, j], np.r_[j, i], np.r_[d, -d]
    order = np.lexsort((pi_, qi_))
    nlist = freud.locality.NeighborList.from_arrays(p.n, p.n, qi_[order], pi_[order], vec[order])
    st = freud.order.Steinhardt(6)
    st.compute((box, p.positions - p.box / 2), neighbors=nlist)
    ok = nb > 0
    np.testing.assert_allclose(st.particle_order[ok], qi[ok], atol=2e-5)  # freud works in float32


def test_crystalline_fraction_of_crystals_glasses_and_mixtures(fcc):
    assert bond_order.crystalline_fraction(fcc(3)) == (1.0, 1.0)
    assert bond_order.crystalline_fraction(dense_random(3000, 1)) == (0.0, 0.0)
    p = fcc(6)  # 864 particles in a box of side 6
    rng = np.random.default_rng(0)
    melted = p.positions.copy()
    top = melted[:, 2] > 3.1  # 5/12 of the particles: replace them by random points
    melted[top] = rng.random((top.sum(), 3)) * [6, 6, 2.9] + [0, 0, 3.1]
    frac, largest = bond_order.crystalline_fraction(Packing(melted, p.diameters, p.box))
    assert frac == largest and 0.5 < frac < 0.65  # the 7/12 left, give or take the interface
    slabs = p.positions.copy()
    z = slabs[:, 2]
    shaken = ((z > 1.6) & (z < 3.1)) | (z > 4.6)  # two crystalline slabs of 1/3 each, separated by shaken ones
    slabs[shaken] += rng.normal(0, 0.3, (shaken.sum(), 3))
    frac, largest = bond_order.crystalline_fraction(Packing(slabs, p.diameters, p.box))
    assert 0.6 < frac < 0.72 and 0.3 < largest < 0.37
    with pytest.raises(InputError, match="solid_bonds"):
        bond_order.crystalline_fraction(p, solid_bonds=0)
