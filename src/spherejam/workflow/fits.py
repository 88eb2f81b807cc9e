"""GCP extrapolation (the paper's Table 2): cubic least squares in sqrt(gamma) on the slowest packings.

phi(gamma) = c0 + c1 gamma^(1/2) + c2 gamma + c3 gamma^(3/2); phi_GCP = c0 (the density at infinite generation
time), with a confidence half-width t_{(1+conf)/2, n-4} * SE(c0), SE from the OLS covariance s^2 (X^T X)^-1 with
s^2 = RSS / (n - 4).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..core.errors import InputError

N_COEFFICIENTS = 4
#: The ``fits`` config section's defaults: how many of the slowest packings each Table 2 curve fits, the confidence,
#: and when a cell is "not estimable" (docs/statistics.md).
FIT_DEFAULTS = {"ls_initial": 125, "ls_densified": 80, "fb_initial": 300, "fb_densified": 300, "confidence": 0.95,
                "min_points": 8, "max_half_width": 0.005}
#: The paper's monodisperse phi_GCP (taken, not fitted).
GCP_MONODISPERSE = 0.65


@dataclass(frozen=True)
class GCPFit:
    """A cubic fit in sqrt(gamma). ``phi_gcp`` = c0 and ``half_width`` its confidence half-width (NaN if the
    fit has no residual degrees of freedom)."""

    coefficients: np.ndarray
    covariance: np.ndarray
    n_points: int
    confidence: float
    phi_gcp: float
    half_width: float
    min_inverse_rate: float

    def predict(self, rate) -> np.ndarray:
        return design_matrix(np.asarray(rate, dtype=float)) @ self.coefficients


def design_matrix(rate: np.ndarray) -> np.ndarray:
    """Columns 1, gamma^(1/2), gamma, gamma^(3/2)."""
    s = np.sqrt(rate)
    return np.column_stack([np.ones_like(s), s, s**2, s**3])


def slowest(rate: np.ndarray, n_points: int) -> np.ndarray:
    """Indices of the ``n_points`` packings with the largest 1/gamma (all of them if fewer)."""
    order = np.argsort(rate, kind="stable")
    return order[: min(n_points, len(rate))]


def fit_gcp(rate, phi, n_points: int | None = None, confidence: float = 0.95) -> GCPFit:
    """Fit phi(gamma) on the ``n_points`` slowest packings (all if None); NaN values are dropped first."""
    from scipy import stats

    rate = np.asarray(rate, dtype=float)
    phi = np.asarray(phi, dtype=float)
    if rate.shape != phi.shape:
        raise InputError(f"rate/phi: shapes {rate.shape} and {phi.shape} differ")
    if not 0 < confidence < 1:
        raise InputError(f"confidence={confidence!r}: must be in (0, 1)")
    ok = np.isfinite(rate) & np.isfinite(phi) & (rate > 0)
    rate, phi = rate[ok], phi[ok]
    if n_points is not None:
        idx = slowest(rate, n_points)
        rate, phi = rate[idx], phi[idx]
    n = len(rate)
    if n < N_COEFFICIENTS:
        raise InputError(f"n_points={n}: a cubic fit in sqrt(gamma) needs at least {N_COEFFICIENTS} packings")
    X = design_matrix(rate)
    q, r = np.linalg.qr(X)
    coef = np.linalg.solve(r, q.T @ phi)
    dof = n - N_COEFFICIENTS
    rinv = np.linalg.inv(r)
    xtx_inv = rinv @ rinv.T
    if dof > 0:
        s2 = float(np.sum((phi - X @ coef) ** 2) / dof)
        cov = s2 * xtx_inv
        half = float(stats.t.ppf(0.5 + confidence / 2, dof) * math.sqrt(cov[0, 0]))
    else:
        cov = np.full((N_COEFFICIENTS, N_COEFFICIENTS), math.nan)
        half = math.nan
    return GCPFit(
        coefficients=coef,
        covariance=cov,
        n_points=n,
        confidence=confidence,
        phi_gcp=float(coef[0]),
        half_width=half,
        min_inverse_rate=float(1.0 / rate.max()),
    )
