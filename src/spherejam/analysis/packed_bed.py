"""Packed-bed correlations: the mean porosity of spheres packed in a cylinder against D/d, the radial porosity profile,
and the excess porosity over bulk that compares them with jammed packings (docs/containers_structure.md §4).

Every correlation records where its formula was read. A formula that could not be read in its paper or in a cited
implementation is **unverified**: it is kept here, marked, so that it can be checked and switched on, but it is
excluded from every comparison (:func:`mean_porosity` and :func:`radial_porosity` refuse it unless
``allow_unverified=True``, and :func:`comparison` leaves it out).

Verified
    Benyahia & O'Neill (2005), Particulate Science and Technology 23, 169-177, spheres:
    eps = 0.390 + 1.740 / (D/d + 1.140)^2, for 1.5 < D/d < 50, average error 1.5 %. Read in CalebBell/fluids,
    ``fluids/packed_bed.py``, ``voidage_Benyahia_Oneil_spherical`` (which cites the paper and gives the example
    eps = 0.3906653157443224 at D/d = 50, a test here).

Unverified (from the project's notes, not read in the papers; excluded from comparisons)
    Dixon (1988): eps = 0.4 + 0.05 (d/D) + 0.412 (d/D)^2.
    Zou & Yu (1995), dense packing: eps = 0.372 + 0.002 [exp(15.306 d/D) - 1].
    de Klerk (2003), z the distance from the wall in d: eps = 2.14 z^2 - 2.53 z + 1 for z <= 0.637, else
    eps_b + 0.29 exp(-0.6 z) cos[2.3 pi (z - 0.16)] + 0.15 exp(-0.9 z).
    Mueller (1992): eps = eps_b + (1 - eps_b) J0(a z) exp(-b z), with a = 7.45 - 3.15/(D/d) for 2.02 <= D/d <= 13,
    a = 7.45 - 11.25/(D/d) for D/d > 13, b = 0.315 - 0.725/(D/d), eps_b = 0.365 + 0.220/(D/d).

Frictionless jammed packings are denser than poured or slurry-packed beds, so compare the **excess** porosity over
bulk, Delta eps(D/d) = eps(D/d) - eps_bulk, each with its own bulk: the correlation's limit D/d -> infinity, and
for spherejam the periodic packings of the same protocol (:func:`excess_porosity`).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from ..core.errors import InputError, require


@dataclass(frozen=True)
class Correlation:
    """A published packed-bed correlation: ``function(ratio)`` (mean porosity) or ``function(z, ratio)`` (radial
    porosity at the distance z from the wall, in d) with ratio = D/d."""

    name: str
    kind: str  #: "mean" or "radial"
    reference: str
    read_in: str | None  #: where the formula was read; None: unverified (excluded from comparisons)
    ratio_range: tuple[float, float]  #: the D/d range the paper gives
    function: Callable
    bulk: float | None = None  #: the mean porosity as D/d -> infinity (mean correlations)

    @property
    def verified(self) -> bool:
        return self.read_in is not None


def _benyahia_oneill(ratio):
    return 0.390 + 1.740 / (ratio + 1.140) ** 2


def _dixon(ratio):
    x = 1.0 / ratio
    return 0.4 + 0.05 * x + 0.412 * x * x


def _zou_yu(ratio):
    return 0.372 + 0.002 * (np.exp(15.306 / ratio) - 1.0)


def _mueller_bulk(ratio):
    return 0.365 + 0.220 / ratio


def _mueller(z, ratio):
    from scipy.special import j0

    a = np.where(ratio <= 13.0, 7.45 - 3.15 / ratio, 7.45 - 11.25 / ratio)
    b = 0.315 - 0.725 / ratio
    eb = _mueller_bulk(ratio)
    return eb + (1.0 - eb) * j0(a * z) * np.exp(-b * z)


def _de_klerk(z, ratio, bulk=None):
    eb = _benyahia_oneill(ratio) if bulk is None else bulk
    near = 2.14 * z * z - 2.53 * z + 1.0
    far = eb + 0.29 * np.exp(-0.6 * z) * np.cos(2.3 * math.pi * (z - 0.16)) + 0.15 * np.exp(-0.9 * z)
    return np.where(z <= 0.637, near, far)


CORRELATIONS: dict[str, Correlation] = {
    c.name: c for c in (
        Correlation("benyahia_oneill", "mean",
                    "Benyahia & O'Neill, Part. Sci. Technol. 23, 169 (2005), spheres",
                    "CalebBell/fluids, fluids/packed_bed.py, voidage_Benyahia_Oneil_spherical",
                    (1.5, 50.0), _benyahia_oneill, bulk=0.390),
        Correlation("dixon", "mean", "Dixon, Can. J. Chem. Eng. 66, 705 (1988), spheres", None,
                    (1.0, math.inf), _dixon, bulk=0.4),
        Correlation("zou_yu", "mean", "Zou & Yu, Chem. Eng. Sci. 50, 1504 (1995), dense packing", None,
                    (1.0, math.inf), _zou_yu, bulk=0.372),
        Correlation("de_klerk", "radial", "de Klerk, AIChE J. 49, 2022 (2003)", None, (1.0, math.inf), _de_klerk),
        Correlation("mueller", "radial", "Mueller, Powder Technol. 72, 269 (1992)", None, (2.02, math.inf),
                    _mueller),
    )
}


def _get(name: str, kind: str, allow_unverified: bool) -> Correlation:
    c = CORRELATIONS.get(name)
    names = sorted(k for k, v in CORRELATIONS.items() if v.kind == kind)
    if c is None or c.kind != kind:
        raise InputError(f"correlation={name!r}: not a {kind}-porosity correlation (one of {', '.join(names)})")
    if not (c.verified or allow_unverified):
        raise InputError(f"correlation={name!r}: its formula is unverified (not read in {c.reference}); "
                         f"it is excluded from comparisons")
    return c


def _ratio(ratio, c: Correlation) -> np.ndarray:
    r = np.asarray(ratio, dtype=np.float64)
    lo, hi = c.ratio_range
    bad = ~(np.isfinite(r) & (r > lo) & (r <= hi)) if math.isfinite(hi) else ~(np.isfinite(r) & (r >= lo))
    if np.any(bad):
        raise InputError(f"D/d={float(r[bad].flat[0])!r}: outside the range of {c.name} ({lo:g} ... {hi:g})")
    return r


def mean_porosity(name: str, ratio, allow_unverified: bool = False) -> np.ndarray:
    """The mean porosity eps(D/d) of a packed cylinder by correlation ``name`` at tube-to-sphere ratio ``ratio``."""
    c = _get(name, "mean", allow_unverified)
    return c.function(_ratio(ratio, c))


def radial_porosity(name: str, distance, ratio: float, allow_unverified: bool = False) -> np.ndarray:
    """The porosity at ``distance`` sphere diameters from the wall of a cylinder of D/d = ``ratio`` by the radial
    correlation ``name``."""
    c = _get(name, "radial", allow_unverified)
    z = np.asarray(distance, dtype=np.float64)
    require(bool(np.all(np.isfinite(z) & (z >= 0))), "distance", distance, "must be finite and >= 0 (diameters)")
    return c.function(z, _ratio(ratio, c))


def excess_porosity(eps, eps_bulk) -> np.ndarray:
    """Delta eps = eps(D/d) - eps_bulk: the porosity a wall adds over the bulk of the same protocol."""
    return np.asarray(eps, dtype=np.float64) - np.asarray(eps_bulk, dtype=np.float64)


def correlation_excess(name: str, ratio, allow_unverified: bool = False) -> np.ndarray:
    """A mean-porosity correlation's own excess over its bulk limit, eps(D/d) - eps(D/d -> infinity)."""
    c = _get(name, "mean", allow_unverified)
    return excess_porosity(mean_porosity(name, ratio, allow_unverified), c.bulk)


def comparison(ratios, eps, eps_bulk: float) -> list[dict]:
    """One row per D/d: spherejam's porosity ``eps`` and excess over ``eps_bulk``, beside the excess of every
    verified mean-porosity correlation (None outside its range). Unverified correlations are left out."""
    rows = []
    for ratio, e in zip(np.atleast_1d(ratios), np.atleast_1d(eps)):
        row = {"ratio": float(ratio), "eps": float(e), "excess": float(excess_porosity(e, eps_bulk))}
        for name, c in CORRELATIONS.items():
            if c.kind != "mean" or not c.verified:
                continue
            try:
                row[f"excess_{name}"] = float(correlation_excess(name, ratio))
            except InputError:
                row[f"excess_{name}"] = None
        rows.append(row)
    return rows
