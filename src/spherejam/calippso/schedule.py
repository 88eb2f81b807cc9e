"""The schedule of a CALiPPSO run: per iteration, the cutoff l on pair distances, the per-component displacement bound
s_bound and the largest inflation factor Gamma_max, chosen from the previous LP's sqrt(Gamma) - 1
(docs/calippso.md §1.3-§1.6). Lengths are absolute (the caller's units); R is the current largest radius.
"""

from __future__ import annotations

import math

import numpy as np

from ..core.errors import InputError
from ..core.neighbours import pairs_within

#: Default regime thresholds on sqrt(Gamma_prev) - 1 (docs/calippso.md §1.3).
REGIME_THRESHOLDS = (5e-4, 1e-5)
#: s_bound of regimes 2 and 3 in units of the largest radius R (docs/calippso.md §1.3).
REGIME_S_BOUNDS = (0.1, 0.01)
#: Cutoff of regimes 2 and 3 in units of R (docs/calippso.md §1.3).
REGIME_CUTOFFS = (2.7, 2.7)
#: Smallest regime-1 bound sqrt(d) s_bound / R accepted before the cutoff is enlarged instead (docs/calippso.md §1.4).
MIN_FAR_BOUND = 0.1
#: Cap (units of R) of the doubled s_bound after a stable particle hit its bound (docs/calippso.md §1.5).
MAX_ESCALATED_BOUND = 0.1
#: The bounds schedules a run can follow (docs/calippso.md §10): "adaptive" (the default) estimates the first regime
#: from the input's gaps (§1.6) and widens a bound that stops a stable particle (§1.5); "reference" is CALiPPSO.jl's:
#: sqrt(Gamma_prev) = :data:`REFERENCE_INITIAL_SQRT_INFLATION` before the first LP (always regime 1, a loose LP) and
#: the regimes of the previous LP's sqrt(Gamma) alone, no widening.
#: "trust": the adaptive schedule with a trust region tied to the previous LP, s_bound <= TRUST_FACTOR
#: sqrt(sqrt(Gamma_prev) - 1) R in regimes 2 and 3 (docs/calippso.md §10.7).
SCHEDULES = ("adaptive", "reference", "trust")
#: The trust region's bound per sqrt(sqrt(Gamma_prev) - 1), units of R: the largest max |s| / R of a stable sphere
#: measured per unit of sqrt(sqrt(Gamma_prev) - 1) on LS outputs at N = 1024 was ~16 (docs/calippso.md §10.7).
TRUST_FACTOR = 30.0
#: The trust region's smallest bound, units of R (10^4 times the convergence test's max |s| of 10^-9 diameters).
TRUST_MIN = 1e-5
#: CALiPPSO.jl's sqrt(Gamma_prev) before the first LP (its default sqrt(Gamma0)).
REFERENCE_INITIAL_SQRT_INFLATION = 1.01


def cutoff_and_bound(sqrt_inflation_prev: float, radius: float, cutoff0: float, dim: int, box: float,
                     thresholds=REGIME_THRESHOLDS, s_bound: float | None = None, shrink: bool = False):
    """The cutoff l, the per-component bound s_bound and Gamma_max of one iteration (absolute lengths).

    ``radius`` is the current largest radius R, ``cutoff0`` the user cutoff l0, ``s_bound`` an optional fixed
    bound overriding the regimes; ``shrink``: in regimes 2 and 3 the cutoff only as long as that bound needs for
    sqrt(Gamma_max) = 1.1 (the trust region, docs/calippso.md §10.7). Returns ``(l, s_bound, inflation_max,
    regime)`` (inflation_max: Gamma_max); guarantees s_bound > 0, l <= box and Gamma_max > 1 (docs/calippso.md
    §1.4); raises :class:`InputError` for a box not wider than the largest sphere.
    """
    R = radius
    rd = math.sqrt(dim)
    g = sqrt_inflation_prev - 1.0
    if g > thresholds[0]:
        regime = 1
        grow = max(1.5, sqrt_inflation_prev)
        ell = max(cutoff0, 2.0 * (grow * R + MIN_FAR_BOUND * R))
        sb = (ell / 2.0 - grow * R) / rd
    else:
        regime = 2 if g > thresholds[1] else 3
        frac = REGIME_S_BOUNDS[regime - 2]
        sb = frac * R
        ell = min(REGIME_CUTOFFS[regime - 2] * R, cutoff0)
        # keep sqrt(Gamma_max) >= 1.1 (l0 fixed while R grows)
        ell = max(ell, 2.2 * R + 2.0 * rd * sb)
    if s_bound is not None:
        sb = s_bound
        ell = 2.2 * R + 2.0 * rd * sb if shrink and regime > 1 else max(ell, 2.2 * R + 2.0 * rd * sb)
    if ell > box:
        # beyond L a sphere's own images would come within reach; up to L every pair image in reach is a row
        # (docs/calippso.md §1.4). Half the room left between D_max and L keeps sqrt(Gamma_max) D_max < L.
        if 2.0 * R >= box:
            raise InputError(f"box={box!r}: not wider than the largest sphere (diameter {2 * R:.6g}, same units), "
                             "which touches its own image; CALiPPSO needs L > D_max")
        ell = box
        sb = min(sb, (box - 2.0 * R) / (4.0 * rd))
    inflation_max = ((ell - 2.0 * rd * sb) / (2.0 * R)) ** 2
    return ell, sb, inflation_max, regime


def nearest_gap_median(positions: np.ndarray, diameters: np.ndarray, box: float, scale: float = 1.5) -> float:
    """Median over particles of the nearest-neighbour gap h = r/sigma - 1 (capped at scale - 1): the first
    iteration's estimate of sqrt(Gamma_prev) - 1 (docs/calippso.md §1.6)."""
    i, j, r = pairs_within(positions, diameters, box, scale)
    h = r / (0.5 * (diameters[i] + diameters[j])) - 1.0
    best = np.full(len(positions), scale - 1.0)
    np.minimum.at(best, i, h)
    np.minimum.at(best, j, h)
    return float(np.median(best))


def step_limits(sqrt_inflation_prev: float, radius: float, cutoff0: float, dim: int, box: float, thresholds,
                fixed_s_bound: float | None, prev_s_bound: float, bound_hit: bool, widen: bool = True,
                trust: bool = False):
    """:func:`cutoff_and_bound` of one iteration, with the bound adapted to the previous LP (docs/calippso.md §1.5).

    ``fixed_s_bound`` is the user's fixed bound (absolute, None: the regimes), ``prev_s_bound`` the previous LP's
    bound (0 before the first LP) and ``bound_hit`` whether a stable particle ended that LP at it. Without a fixed
    bound, a hit doubles the previous bound (up to :data:`MAX_ESCALATED_BOUND` R), no hit halves it; the result is
    used while it exceeds the regime's own bound. ``widen`` False (the reference's schedule, docs/calippso.md §10):
    the regime's own bound, whatever the previous LP did. ``trust`` (docs/calippso.md §10.7): in regimes 2 and 3 the
    regime's bound from the second LP on is capped at TRUST_FACTOR sqrt(sqrt(Gamma_prev) - 1) R (not below
    TRUST_MIN R), a hit doubles the previous bound as above, no hit returns to the cap at once, and the cutoff
    shrinks with the bound.
    """
    R = radius
    shrink = False
    if fixed_s_bound is None:
        regime_sb = cutoff_and_bound(sqrt_inflation_prev, R, cutoff0, dim, box, thresholds)[1]
        if trust and prev_s_bound > 0 and sqrt_inflation_prev - 1.0 <= thresholds[0]:
            trusted = max(TRUST_FACTOR * math.sqrt(max(sqrt_inflation_prev - 1.0, 0.0)), TRUST_MIN) * R
            if trusted < regime_sb:
                regime_sb = fixed_s_bound = trusted
                shrink = True
        if widen and prev_s_bound > 0:
            # a stable particle stopped by its bound means the regime's bound is too tight for this packing:
            # double it (up to 0.1 R); once no bound stops anyone, relax back towards the regime's value (the
            # trust region's at once)
            grown = 0.0 if trust and not bound_hit else 0.5 * prev_s_bound
            if bound_hit:
                grown = min(2.0 * prev_s_bound, MAX_ESCALATED_BOUND * R)
            if grown > regime_sb:
                fixed_s_bound = grown
    return cutoff_and_bound(sqrt_inflation_prev, R, cutoff0, dim, box, thresholds, fixed_s_bound, shrink)
