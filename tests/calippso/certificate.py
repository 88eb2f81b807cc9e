"""The certificate the CALiPPSO tests ask of a jammed result."""

import numpy as np


def assert_jammed(result, dim):
    assert result.completed
    assert result.isostatic, (result.n_contacts, result.n_stable)
    assert result.n_contacts == dim * (result.n_stable - 1) + 1
    assert result.force_balance_residual <= 1e-10
    assert result.packing.check(1e-10).ok
    assert result.packing.min_gap() > -1e-12
    assert np.all(result.forces > 0)
    assert result.history["sqrt_inflation_minus_1"][-1] <= 1e-12
    assert result.history["max_displacement"][-1] <= 1e-9
