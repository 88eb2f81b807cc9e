"""Force and gap distributions of a certified (CALiPPSO-jammed) packing and the power-law fits of their small-argument
tails (docs/calippso.md §4).

Two exponents are fitted: the gap exponent gamma of g(h) ~ h^-gamma (h = r/sigma - 1 of non-contacting near
neighbours; not the CALiPPSO inflation factor Gamma, nor the LS compression rate) and the force exponent theta of
P(f) ~ f^theta (f in units of the mean contact force).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from ..core.errors import require

if TYPE_CHECKING:
    from ..calippso.run import CalippsoResult

#: Mean-field exponents (Charbonneau, Kurchan, Parisi, Urbani, Zamponi 2014): the gap exponent gamma of
#: g(h) ~ h^-gamma and the extended-force exponent theta_e of P(f) ~ f^theta_e.
MEAN_FIELD_GAMMA = 0.41269
MEAN_FIELD_THETA_E = 0.42311


@dataclass(frozen=True)
class PowerLawFit:
    """Maximum-likelihood fit of a density p(x) ∝ x^(a-1) on [lo, hi] (i.e. a cumulative C(x) ∝ x^a there).

    ``exponent`` is the derived physical exponent (gaps: gamma = 1 - a; forces: theta = a - 1), ``stderr`` its
    asymptotic standard error (Fisher information), ``n`` the number of samples in [lo, hi] out of ``n_total``.
    """

    cumulative_exponent: float
    exponent: float
    stderr: float
    lo: float
    hi: float
    n: int
    n_total: int


def fit_cumulative_power_law(values: np.ndarray, lo: float, hi: float) -> tuple[float, float, int]:
    """MLE of a in p(x) ∝ x^(a-1) on [lo, hi] from the samples inside; returns ``(a, stderr, n)``."""
    from scipy.optimize import minimize_scalar

    require(0 <= lo < hi, "fit range", (lo, hi), "must satisfy 0 <= lo < hi")
    v = np.asarray(values, dtype=float)
    v = v[(v >= lo) & (v <= hi) & (v > 0)]
    k = v.size
    if k < 5:
        return math.nan, math.nan, k
    u = np.log(v / hi)  # <= 0
    mean_u = float(u.mean())
    rho = lo / hi

    def negloglik(a):
        # -(1/k) log L, with normaliser (1 - rho^a)/a of x^(a-1) on [rho, 1] after scaling by hi
        norm = -math.expm1(a * math.log(rho)) if rho > 0 else 1.0
        return -(math.log(a) + (a - 1.0) * mean_u - math.log(norm))

    res = minimize_scalar(negloglik, bounds=(1e-3, 20.0), method="bounded", options={"xatol": 1e-10})
    a = float(res.x)
    # Fisher information per sample: 1/a^2 - rho^a (ln rho)^2 / (1 - rho^a)^2
    info = 1.0 / a**2
    if rho > 0:
        ra = rho**a
        info -= ra * math.log(rho) ** 2 / (1.0 - ra) ** 2
    stderr = 1.0 / math.sqrt(k * info) if info > 0 else math.nan
    return a, stderr, k


def gap_exponent(gaps: np.ndarray, lo: float = 1e-8, hi: float = 1e-2) -> PowerLawFit:
    """Fit g(h) ~ h^-gamma at small h: the cumulative count of gaps below h grows as h^(1-gamma) on [lo, hi].

    gamma is the gap exponent (``exponent`` of the result), not CALiPPSO's inflation factor Gamma.

    Default range: h from 1e-8 (below, gaps are not resolved by a 1e-9 displacement tolerance) to 1e-2 (above,
    the distribution leaves the power law). Compare with the mean-field gamma = 0.41269.
    """
    a, se, k = fit_cumulative_power_law(gaps, lo, hi)
    return PowerLawFit(a, 1.0 - a, se, lo, hi, k, int(np.size(gaps)))


def force_exponent(forces: np.ndarray, lo: float = 1e-6, hi: float = 0.2) -> PowerLawFit:
    """Fit P(f) ~ f^theta at small f (forces in units of their mean): cumulative ∝ f^(1+theta) on [lo, hi].

    Compare with theta_e = 0.42311 for extended forces (use :func:`extended_forces`) or theta_l = 0.17462 when
    buckler forces are included.
    """
    a, se, k = fit_cumulative_power_law(forces, lo, hi)
    return PowerLawFit(a, a - 1.0, se, lo, hi, k, int(np.size(forces)))


def extended_forces(result: CalippsoResult) -> np.ndarray:
    """Forces (units of the mean) of contacts whose two particles both have more than d + 1 contacts.

    Bucklers -- stable particles with exactly d + 1 contacts -- carry the localised weak forces (theta_l); leaving
    out every contact that touches one isolates the extended ones (theta_e). This is our operational split, not a
    quote of the paper's.
    """
    return result.forces[contact_arrays(result)["extended"]]


def contact_arrays(result: CalippsoResult) -> dict[str, np.ndarray]:
    """The contact network, forces and near-contact gaps of a result, as arrays for the packing file; in a container
    also its wall contacts (docs/containers.md §5), which count towards a sphere's contacts (a buckler has d + 1,
    walls included)."""
    n = result.rattlers.size
    z = np.bincount(result.pairs.ravel(), minlength=n) + np.bincount(result.wall_contacts, minlength=n)
    buckler = z == result.packing.dim + 1
    extended = ~buckler[result.pairs[:, 0]] & ~buckler[result.pairs[:, 1]]
    out = {
        "pairs": result.pairs, "forces": result.forces, "extended": extended,
        "contact_vectors": result.contact_vectors, "rattlers": result.rattlers,
        "gaps": result.gaps, "gap_pairs": result.gap_pairs,
    }
    if not result.packing.container.is_periodic_cube:
        out.update(wall_contacts=result.wall_contacts, walls=result.walls, wall_forces=result.wall_forces,
                   wall_vectors=result.wall_vectors)
    return out


#: name -> (long_name, units) of the fitted exponents of :func:`distributions` (a CALiPPSO summary file carries them;
#: the dataset prefixes them with ``calippso_``).
VARIABLES: dict[str, tuple[str, str]] = {
    "gap_gamma": ("small-gap power-law exponent gamma of P(h) ~ h^-gamma (mean field 0.41269)", "1"),
    "force_theta_all": ("small-force exponent theta of P(f) ~ f^theta, all contacts", "1"),
    "force_theta_extended": ("small-force exponent theta_e, extended contacts (mean field 0.42311)", "1"),
}


def distributions(result: CalippsoResult) -> dict[str, float]:
    """Flat scalars of the small-argument fits of one jammed packing (for the results dataset)."""
    g = gap_exponent(result.gaps)
    f_all = force_exponent(result.forces)
    f_ext = force_exponent(extended_forces(result))
    return {
        "gap_gamma": g.exponent, "gap_gamma_stderr": g.stderr, "gap_fit_n": float(g.n),
        "gap_fit_lo": g.lo, "gap_fit_hi": g.hi,
        "force_theta_all": f_all.exponent, "force_theta_all_stderr": f_all.stderr, "force_fit_n": float(f_all.n),
        "force_theta_extended": f_ext.exponent, "force_theta_extended_stderr": f_ext.stderr,
        "force_extended_fit_n": float(f_ext.n), "force_fit_lo": f_all.lo, "force_fit_hi": f_all.hi,
    }
