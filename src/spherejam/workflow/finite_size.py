"""Finite-size scaling of the fast phi_J distribution: from packings at a few N to the band edges at any N.

The method (docs/finite_size.md) is fixed before any comparison with the paper:

* the mean of the fast phi_J distribution at N particles, mu(N) = mu_inf - a N^(-x);
* its standard deviation, s(N) = b N^(-y);
* its shape, normal at every N.

x and y default to 1/2 (both the width and the shift of the jamming-density distribution scale as N^(-Omega),
Omega ~ 0.5; docs/finite_size.md gives the sources); either can be fitted instead where the data allow it. A band
edge at N is then a property of that distribution:

* ``minmax`` (the paper's eq. 17): the expected minimum or maximum of ``sample_size`` packings,
  mu + s E[Z_(1)] or mu + s E[Z_(n)] for standard normal order statistics;
* ``quantile`` (eq. 18): mu -/+ s z_alpha.

Intervals come from a bootstrap over packings (resampled within each N, refitted, predicted again): the interval of
the edge itself, and a prediction interval for the edge that one new sample of ``sample_size`` packings would show
(the extremes of a finite sample scatter about their expectation). Densities are volume fractions (dimensionless).
"""

from __future__ import annotations

import functools
import math
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from ..core.errors import InputError

#: The literature's exponent of both the shift of the mean and the width (docs/finite_size.md).
DEFAULT_EXPONENT = 0.5
#: Range searched when an exponent is fitted (a decay slower than N^-0.05 or faster than N^-3 is not scaling).
EXPONENT_RANGE = (0.05, 3.0)
SIDES = ("low", "high")
METHODS = ("minmax", "quantile")


@dataclass(frozen=True)
class ScalingFit:
    """mu(N) = mu_inf - a N^-x and s(N) = b N^-y, fitted to the fast phi_J of packings at several N."""

    mu_inf: float
    a: float
    x: float
    b: float
    y: float
    n_particles: tuple[int, ...]  # the N the fit used
    n_packings: tuple[int, ...]  # packings at each of them

    def mean(self, n_particles) -> np.ndarray:
        return self.mu_inf - self.a * np.asarray(n_particles, dtype=float) ** -self.x

    def width(self, n_particles) -> np.ndarray:
        return self.b * np.asarray(n_particles, dtype=float) ** -self.y

    def edge(self, n_particles: float, side: str, method: str = "minmax", sample_size: int | None = None,
             alpha: float = 0.95) -> float:
        """The expected band edge at ``n_particles`` (``side`` low = phi_LT, high = phi_RCP); ``n_particles`` may
        be ``math.inf`` (the limit: the width vanishes, both edges meet at mu_inf)."""
        _check_side_method(side, method)
        if math.isinf(n_particles):
            return self.mu_inf
        z = standard_edge(side, method, sample_size, alpha)
        return float(self.mean(n_particles) + z * self.width(n_particles))


def _check_side_method(side: str, method: str) -> None:
    if side not in SIDES:
        raise InputError(f"side={side!r}: must be one of {', '.join(SIDES)}")
    if method not in METHODS:
        raise InputError(f"method={method!r}: must be one of {', '.join(METHODS)}")


@functools.cache
def expected_extreme(sample_size: int) -> float:
    """E[max of ``sample_size`` standard normal values] (the minimum is its negative), by quadrature."""
    from scipy import integrate, stats

    n = int(sample_size)
    if n < 1:
        raise InputError(f"sample_size={sample_size!r}: must be >= 1")
    if n == 1:
        return 0.0

    def density(z: float) -> float:  # of the maximum, times z
        return z * n * stats.norm.pdf(z) * math.exp((n - 1) * stats.norm.logcdf(z))

    value, _ = integrate.quad(density, -12.0, 12.0, limit=200, epsabs=1e-12)
    return float(value)


def standard_edge(side: str, method: str, sample_size: int | None, alpha: float) -> float:
    """The edge of the standard normal distribution: E[Z_(1)] / E[Z_(n)] (minmax) or -/+ z_alpha (quantile)."""
    from scipy import stats

    if method == "minmax":
        if sample_size is None:
            raise InputError("sample_size: the minmax edge of a band needs the number of packings it is taken over")
        z = expected_extreme(sample_size)
    else:
        if not 0.5 < alpha < 1:
            raise InputError(f"alpha={alpha!r}: must be in (0.5, 1)")
        z = float(stats.norm.ppf(alpha))
    return z if side == "high" else -z


def _samples(samples: Mapping[int, np.ndarray]) -> dict[int, np.ndarray]:
    out = {}
    for n, values in sorted(samples.items()):
        x = np.asarray(values, dtype=float).ravel()
        x = x[np.isfinite(x)]
        if int(n) < 2:
            raise InputError(f"N={n!r}: must be >= 2")
        if len(x) < 3:
            raise InputError(f"N={n}: {len(x)} packings; a mean and a width need at least 3")
        out[int(n)] = x
    return out


def _weighted_line(t: np.ndarray, y: np.ndarray, w: np.ndarray) -> tuple[float, float, float]:
    """Weighted least squares y = c0 + c1 t: (c0, c1, weighted RSS)."""
    X = np.column_stack([np.ones_like(t), t]) * np.sqrt(w)[:, None]
    coef, *_ = np.linalg.lstsq(X, y * np.sqrt(w), rcond=None)
    rss = float(np.sum(w * (y - coef[0] - coef[1] * t) ** 2))
    return float(coef[0]), float(coef[1]), rss


def _fit_exponent(ns: np.ndarray, y: np.ndarray, w: np.ndarray, exponent: float | None):
    """(c0, c1, exponent) of y = c0 + c1 N^-exponent, the exponent fixed or profiled over EXPONENT_RANGE."""
    from scipy import optimize

    if exponent is not None:
        c0, c1, _ = _weighted_line(ns**-exponent, y, w)
        return c0, c1, float(exponent)
    if len(ns) < 3:
        raise InputError(f"a fitted exponent needs packings at >= 3 values of N, got {len(ns)}")
    res = optimize.minimize_scalar(lambda e: _weighted_line(ns**-e, y, w)[2], bounds=EXPONENT_RANGE,
                                   method="bounded", options={"xatol": 1e-6})
    c0, c1, _ = _weighted_line(ns**-res.x, y, w)
    return c0, c1, float(res.x)


def fit_scaling(samples: Mapping[int, np.ndarray], shift_exponent: float | None = DEFAULT_EXPONENT,
                width_exponent: float | None = DEFAULT_EXPONENT) -> ScalingFit:
    """Fit mu(N) and s(N) to ``samples`` (N -> fast phi_J of the packings at that N).

    The means are weighted by n/s^2 (their inverse variance); the widths are fitted in log s (weight n - 1, since
    var(log s) ~ 1/(2(n - 1))). An exponent given as None is fitted (N at >= 3 values)."""
    data = _samples(samples)
    if len(data) < 2:
        raise InputError(f"finite-size scaling needs packings at >= 2 values of N, got {len(data)}")
    ns = np.array(sorted(data), dtype=float)
    counts = np.array([len(data[int(n)]) for n in ns], dtype=float)
    means = np.array([data[int(n)].mean() for n in ns])
    widths = np.array([data[int(n)].std(ddof=1) for n in ns])
    if np.any(widths <= 0):
        raise InputError("phi_J: a width of 0 at some N (identical packings?); no scaling can be fitted")
    mu_inf, slope, x = _fit_exponent(ns, means, counts / widths**2, shift_exponent)
    if width_exponent is None:
        log_b, minus_y, _ = _weighted_line(np.log(ns), np.log(widths), counts - 1)
        b, y = math.exp(log_b), -minus_y
    else:
        y = float(width_exponent)
        b = math.exp(np.average(np.log(widths) + y * np.log(ns), weights=counts - 1))
    return ScalingFit(mu_inf=mu_inf, a=-slope, x=x, b=b, y=y, n_particles=tuple(int(n) for n in ns),
                      n_packings=tuple(int(c) for c in counts))


@dataclass(frozen=True)
class EdgePrediction:
    """A band edge predicted at ``n_particles``: the estimate, its confidence interval and the prediction interval
    of the edge one new sample of ``sample_size`` packings would show (NaN bounds: not estimable)."""

    n_particles: float
    side: str
    method: str
    sample_size: int | None
    value: float
    interval: tuple[float, float]
    prediction_interval: tuple[float, float]


def bootstrap_fits(samples: Mapping[int, np.ndarray], shift_exponent: float | None = DEFAULT_EXPONENT,
                   width_exponent: float | None = DEFAULT_EXPONENT, n_boot: int = 2000,
                   rng: np.random.Generator | None = None) -> list[ScalingFit | None]:
    """``n_boot`` refits of :func:`fit_scaling` to the packings resampled with replacement within each N (None
    for a resample that cannot be fitted, e.g. one with a width of 0)."""
    data = _samples(samples)
    rng = np.random.default_rng(0) if rng is None else rng
    fits: list[ScalingFit | None] = []
    for _ in range(n_boot):
        resampled = {n: rng.choice(x, size=len(x), replace=True) for n, x in data.items()}
        try:
            fits.append(fit_scaling(resampled, shift_exponent, width_exponent))
        except InputError:
            fits.append(None)
    return fits


def _percentiles(values: np.ndarray, confidence: float, n_boot: int) -> tuple[float, float]:
    """The central ``confidence`` percentile interval; NaN if more than a tenth of the refits failed."""
    ok = values[np.isfinite(values)]
    if len(ok) < 0.9 * n_boot:
        return math.nan, math.nan
    tail = 100 * (1 - confidence) / 2
    lo, hi = np.percentile(ok, [tail, 100 - tail])
    return float(lo), float(hi)


def parameter_intervals(samples: Mapping[int, np.ndarray], confidence: float = 0.95, n_boot: int = 2000,
                        seed: int = 0, **exponents) -> dict[str, tuple[float, float]]:
    """Bootstrap percentile intervals of the fit's parameters mu_inf, a, x, b and y."""
    fits = bootstrap_fits(samples, n_boot=n_boot, rng=np.random.default_rng(seed), **exponents)
    names = ("mu_inf", "a", "x", "b", "y")
    table = np.array([[getattr(f, k) for k in names] if f else [np.nan] * 5 for f in fits])
    return {k: _percentiles(table[:, i], confidence, n_boot) for i, k in enumerate(names)}


def predict_edges(samples: Mapping[int, np.ndarray], targets, side: str, method: str = "minmax",
                  sample_size: int | None = None, alpha: float = 0.95, confidence: float = 0.95,
                  shift_exponent: float | None = DEFAULT_EXPONENT, width_exponent: float | None = DEFAULT_EXPONENT,
                  n_boot: int = 2000, seed: int = 0) -> list[EdgePrediction]:
    """Fit :func:`fit_scaling` to ``samples`` and predict one band edge at each N of ``targets`` (``math.inf`` for
    the limit), with percentile intervals from ``n_boot`` bootstrap refits (deterministic for a given ``seed``).

    Without ``sample_size`` (only with ``quantile``) the prediction interval is the confidence interval."""
    _check_side_method(side, method)
    if not 0 < confidence < 1:
        raise InputError(f"confidence={confidence!r}: must be in (0, 1)")
    fit = fit_scaling(samples, shift_exponent, width_exponent)
    rng = np.random.default_rng(seed)
    fits = bootstrap_fits(samples, shift_exponent, width_exponent, n_boot, rng)
    out = []
    for t in (float(t) for t in targets):
        edge = np.full(n_boot, np.nan)
        new_sample = np.full(n_boot, np.nan)
        for i, f in enumerate(fits):
            if f is None:
                continue
            edge[i] = f.edge(t, side, method, sample_size, alpha)
            if math.isinf(t) or sample_size is None:
                new_sample[i] = edge[i]
            else:  # the edge of one new sample of that size, drawn from the refitted distribution
                new_sample[i] = sample_edge(rng.normal(f.mean(t), f.width(t), size=sample_size), side, method, alpha)
        out.append(EdgePrediction(n_particles=t, side=side, method=method, sample_size=sample_size,
                                  value=fit.edge(t, side, method, sample_size, alpha),
                                  interval=_percentiles(edge, confidence, n_boot),
                                  prediction_interval=_percentiles(new_sample, confidence, n_boot)))
    return out


def sample_edge(values: np.ndarray, side: str, method: str, alpha: float = 0.95) -> float:
    """The edge measured on one sample: its minimum/maximum (minmax) or eq. 18's order statistic (quantile)."""
    from .bands import lower_quantile, upper_quantile

    if method == "minmax":
        return float(np.min(values) if side == "low" else np.max(values))
    return (lower_quantile if side == "low" else upper_quantile)(values, alpha)


@dataclass(frozen=True)
class Validation:
    """Leave-the-largest-N-out: the edge at ``n_particles`` predicted from the smaller N alone, against the one
    measured there on ``sample_size`` packings."""

    n_particles: int
    side: str
    method: str
    sample_size: int
    measured: float
    predicted: EdgePrediction

    @property
    def error(self) -> float:
        return self.predicted.value - self.measured

    @property
    def within_prediction_interval(self) -> bool:
        lo, hi = self.predicted.prediction_interval
        return bool(lo <= self.measured <= hi)


def leave_largest_out(samples: Mapping[int, np.ndarray], side: str, method: str = "minmax", alpha: float = 0.95,
                      **options) -> Validation:
    """Predict the band edge of the largest N from the others, and compare it with the edge measured there
    (the sample minimum/maximum for ``minmax``, eq. 18's order statistic for ``quantile``)."""
    data = _samples(samples)
    if len(data) < 3:
        raise InputError(f"leave-one-N-out needs packings at >= 3 values of N, got {len(data)}")
    largest = max(data)
    held = data.pop(largest)
    measured = sample_edge(held, side, method, alpha)
    [prediction] = predict_edges(data, [largest], side, method, sample_size=len(held), alpha=alpha, **options)
    return Validation(n_particles=largest, side=side, method=method, sample_size=len(held), measured=measured,
                      predicted=prediction)


@dataclass(frozen=True)
class Extrapolation:
    """A quantity estimated at a few N with confidence half-widths, extrapolated by y(N) = y_inf - c N^-x."""

    n_particles: float
    value: float
    half_width: float  # of the ``confidence`` interval; NaN: not estimable


def extrapolate(n_particles, values, half_widths, targets, exponent: float = DEFAULT_EXPONENT,
                confidence: float = 0.95) -> list[Extrapolation]:
    """Extrapolate estimates with known confidence half-widths (phi_GCP of Table 2 at each N) to each N of
    ``targets`` (``math.inf`` for the limit) by weighted least squares in t = N^-x, weights 1/se^2 with se the
    half-width over the normal quantile. The interval is the fit's, widened by sqrt(chi^2/dof) when the points
    scatter more than their half-widths allow (3 or more N). Fewer than 2 finite estimates: not estimable."""
    from scipy import stats

    ns = np.asarray(n_particles, dtype=float)
    y = np.asarray(values, dtype=float)
    h = np.asarray(half_widths, dtype=float)
    ok = np.isfinite(ns) & np.isfinite(y) & np.isfinite(h) & (h > 0)
    if len(set(ns[ok].tolist())) < 2:
        return [Extrapolation(float(t), math.nan, math.nan) for t in targets]
    z = float(stats.norm.ppf(0.5 + confidence / 2))
    t, y, w = ns[ok] ** -exponent, y[ok], (z / h[ok]) ** 2
    design = np.column_stack([np.ones_like(t), t])
    cov = np.linalg.inv(design.T @ (w[:, None] * design))
    coef = cov @ design.T @ (w * y)
    dof = len(y) - 2
    if dof > 0:
        chi2 = float(np.sum(w * (y - design @ coef) ** 2))
        cov = cov * max(1.0, chi2 / dof)
    out = []
    for target in (float(x) for x in targets):
        row = np.array([1.0, 0.0 if math.isinf(target) else target ** -exponent])
        out.append(Extrapolation(target, float(row @ coef), z * math.sqrt(float(row @ cov @ row))))
    return out


__all__ = ["DEFAULT_EXPONENT", "EdgePrediction", "Extrapolation", "ScalingFit", "Validation", "bootstrap_fits",
           "expected_extreme", "extrapolate", "fit_scaling", "leave_largest_out", "parameter_intervals",
           "predict_edges", "sample_edge", "standard_edge"]
