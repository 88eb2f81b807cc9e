"""g(r) (analysis/pair_correlation.py)."""

import numpy as np
import pytest

from spherejam.analysis.pair_correlation import pair_correlation
from spherejam.core.packing import Packing


@pytest.mark.parametrize("dim", [2, 3])
def test_pair_correlation_of_ideal_gas_is_one(dim):
    rng = np.random.default_rng(dim)
    n, box = 4000, 10.0
    p = Packing(rng.random((n, dim)) * box, np.full(n, 0.5), box)
    r, g = pair_correlation(p, r_max=12.0, bins=40)
    assert r[-1] < 10.0 and r[-1] > 9.0  # capped at L/2 (in units of the mean diameter 0.5)
    assert abs(g[5:].mean() - 1.0) < 0.01
    assert np.all(np.abs(g[5:] - 1.0) < 0.15)


def test_pair_correlation_of_fcc_peaks_at_contact(fcc):
    r, g = pair_correlation(fcc(4), r_max=2.5, bins=250)
    assert r[np.argmax(g)] == pytest.approx(1.0, abs=0.01)
