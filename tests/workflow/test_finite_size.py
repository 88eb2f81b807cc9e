"""Finite-size scaling of the fast phi_J distribution (workflow/finite_size.py) on synthetic data of known form."""

import math

import numpy as np
import pytest

from spherejam.core.errors import InputError
from spherejam.workflow.finite_size import (
    expected_extreme,
    fit_scaling,
    leave_largest_out,
    parameter_intervals,
    predict_edges,
    sample_edge,
)

# A distribution of the known form: mu(N) = MU - A N^-X, s(N) = B N^-Y (magnitudes of the measured N = 1000 bands)
MU, A, X, B, Y = 0.640, 0.06, 0.5, 0.09, 0.5
LADDER = (250, 500, 1000, 2000)


def synthetic(rng, ns=LADDER, count=40, x=X, y=Y):
    return {n: rng.normal(MU - A * n**-x, B * n**-y, size=count) for n in ns}


def exact(ns=LADDER, count=12, x=X, y=Y):
    """Samples whose mean and standard deviation are exactly those of the model."""
    z = np.random.default_rng(1).normal(size=count)
    z = (z - z.mean()) / z.std(ddof=1)
    return {n: MU - A * n**-x + B * n**-y * z for n in ns}


def test_expected_extreme_of_normal_samples():
    # closed forms: E[max of 2] = 1/sqrt(pi), E[max of 3] = 3/(2 sqrt(pi))
    assert expected_extreme(1) == 0.0
    assert expected_extreme(2) == pytest.approx(1 / math.sqrt(math.pi), abs=1e-9)
    assert expected_extreme(3) == pytest.approx(3 / (2 * math.sqrt(math.pi)), abs=1e-9)
    # and a large n against Monte Carlo
    draws = np.random.default_rng(0).normal(size=(20000, 165)).max(axis=1)
    assert expected_extreme(165) == pytest.approx(draws.mean(), abs=3 * draws.std() / math.sqrt(len(draws)))


def test_fit_recovers_exact_model():
    fit = fit_scaling(exact())
    assert (fit.mu_inf, fit.a, fit.b) == pytest.approx((MU, A, B), rel=1e-9)
    free = fit_scaling(exact(x=0.8, y=0.3), shift_exponent=None, width_exponent=None)
    assert (free.x, free.y, free.mu_inf) == pytest.approx((0.8, 0.3, MU), rel=1e-5)


def test_known_exponent_recovered_within_its_interval():
    data = synthetic(np.random.default_rng(7), count=60)
    free = fit_scaling(data, shift_exponent=None, width_exponent=None)
    ci = parameter_intervals(data, n_boot=600, seed=3, shift_exponent=None, width_exponent=None)
    assert ci["x"][0] <= X <= ci["x"][1], (free.x, ci["x"])
    assert ci["y"][0] <= Y <= ci["y"][1], (free.y, ci["y"])
    assert ci["mu_inf"][0] <= MU <= ci["mu_inf"][1]
    # an interval that means something: the width exponent is bounded away from 0 (no scaling) and 1.5
    assert 0 < ci["y"][0] and ci["y"][1] < 1.5


def test_prediction_at_paper_size_covers_the_truth():
    data = synthetic(np.random.default_rng(11), ns=(250, 500, 1000))
    for side, sign in (("high", 1), ("low", -1)):
        [p10k, pinf] = predict_edges(data, [10_000, math.inf], side, sample_size=165, n_boot=600, seed=5)
        truth = MU - A * 1e4**-X + sign * expected_extreme(165) * B * 1e4**-Y
        assert p10k.interval[0] <= truth <= p10k.interval[1], (p10k, truth)
        assert pinf.value == pytest.approx(fit_scaling(data).mu_inf)
        assert pinf.interval[0] <= MU <= pinf.interval[1]


def test_quantile_edge_is_the_alpha_quantile():
    from scipy import stats

    fit = fit_scaling(exact())
    for n in (500, 10_000):
        z = stats.norm.ppf(0.95)
        assert fit.edge(n, "high", "quantile") == pytest.approx(fit.mean(n) + z * fit.width(n))
        assert fit.edge(n, "low", "quantile") == pytest.approx(fit.mean(n) - z * fit.width(n))


def test_leave_largest_out_on_model_data_and_on_wrong_model():
    data = synthetic(np.random.default_rng(2), ns=(250, 500, 1000), count=16)
    v = leave_largest_out(data, "high", n_boot=600, seed=1)
    assert v.n_particles == 1000 and v.sample_size == 16
    assert v.measured == data[1000].max()
    assert v.within_prediction_interval, v
    # data whose mean does not follow the fixed form (a jump at the held-out N) are caught by the validation
    shifted = dict(data)
    shifted[1000] = data[1000] + 0.02
    assert not leave_largest_out(shifted, "high", n_boot=600, seed=1).within_prediction_interval


def test_sample_edge_is_eq18():
    x = np.arange(1, 21, dtype=float)
    assert sample_edge(x, "high", "quantile") == 19 and sample_edge(x, "low", "quantile") == 2
    assert sample_edge(x, "high", "minmax") == 20 and sample_edge(x, "low", "minmax") == 1


@pytest.mark.parametrize("samples, needle", [
    ({500: [0.63, 0.64, 0.65]}, ">= 2 values of N"),
    ({500: [0.63, 0.64], 1000: [0.63, 0.64, 0.65]}, "N=500: 2 packings"),
    ({500: [0.64] * 4, 1000: [0.63, 0.64, 0.65]}, "width of 0"),
    ({1: [0.63, 0.64, 0.65], 1000: [0.63, 0.64, 0.65]}, "N=1"),
])
def test_bad_samples(samples, needle):
    with pytest.raises(InputError, match=needle):
        fit_scaling(samples)


def test_deterministic():
    data = synthetic(np.random.default_rng(4), ns=(250, 500, 1000))
    a = predict_edges(data, [10_000], "low", sample_size=85, n_boot=200, seed=9)
    b = predict_edges(data, [10_000], "low", sample_size=85, n_boot=200, seed=9)
    assert a == b
