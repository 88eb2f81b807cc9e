"""Packed-bed correlations: published values, the excess over bulk, and unverified formulas kept out of comparisons."""

import numpy as np
import pytest

from spherejam.analysis import packed_bed
from spherejam.core.errors import InputError


def test_benyahia_oneill_published_values():
    # the example of CalebBell/fluids' voidage_Benyahia_Oneil_spherical (Dp = 1 mm, Dt = 50 mm)
    assert packed_bed.mean_porosity("benyahia_oneill", 50.0) == pytest.approx(0.3906653157443224, rel=1e-15)
    # phi = 1 - eps at D/d = 5, 7, 10, 20, as quoted with the correlation (docs/containers_structure.md)
    phi = 1.0 - packed_bed.mean_porosity("benyahia_oneill", np.array([5.0, 7.0, 10.0, 20.0]))
    np.testing.assert_allclose(phi, [0.564, 0.584, 0.596, 0.606], atol=5e-4)


def test_excess_over_bulk():
    got = packed_bed.correlation_excess("benyahia_oneill", np.array([5.0, 7.0, 10.0, 20.0]))
    np.testing.assert_allclose(got, [0.046, 0.026, 0.014, 0.004], atol=5e-4)
    assert packed_bed.excess_porosity(0.40, 0.36) == pytest.approx(0.04)
    rows = packed_bed.comparison([5.0, 60.0], [0.40, 0.37], 0.36)
    assert rows[0]["excess"] == pytest.approx(0.04)
    assert rows[0]["excess_benyahia_oneill"] == pytest.approx(1.74 / 6.14**2)
    assert rows[1]["excess_benyahia_oneill"] is None  # beyond D/d = 50
    assert not any(k.endswith(("dixon", "zou_yu")) for k in rows[0])


def test_range_and_names_are_refused_in_one_line():
    with pytest.raises(InputError, match="D/d=1.2"):
        packed_bed.mean_porosity("benyahia_oneill", 1.2)
    with pytest.raises(InputError, match="correlation='ergun'"):
        packed_bed.mean_porosity("ergun", 5.0)


@pytest.mark.parametrize("name", ["dixon", "zou_yu"])
def test_unverified_mean_correlations_are_excluded(name):
    assert not packed_bed.CORRELATIONS[name].verified
    with pytest.raises(InputError, match="unverified"):
        packed_bed.mean_porosity(name, 10.0)
    # available on request, and tending to its bulk limit
    far = packed_bed.mean_porosity(name, 1e6, allow_unverified=True)
    assert far == pytest.approx(packed_bed.CORRELATIONS[name].bulk, abs=1e-4)


@pytest.mark.parametrize("name", ["de_klerk", "mueller"])
def test_unverified_radial_correlations_are_excluded(name):
    with pytest.raises(InputError, match="unverified"):
        packed_bed.radial_porosity(name, [0.0, 0.5], 10.0)
    eps = packed_bed.radial_porosity(name, np.array([0.0]), 10.0, allow_unverified=True)
    assert eps[0] == pytest.approx(1.0)  # porosity 1 at the wall
