"""The MLS rate ladder: the compression rates gamma_k = gamma_0 / f^k of the closest-jamming search's stages, from
the initial rate gamma_0 down to the first rate <= the final rate (paper §III.B, docs/algorithms.md §3).

The engine compresses at these rates, the cost model sums their costs and the config check bounds the last one; all
take them from here. Standard library only: Snakemake imports the cost model for every job.
"""

from __future__ import annotations

import math


def stage_rate(initial_rate: float, decrease_factor: float, k: int) -> float:
    """gamma_k = gamma_0 / f^k, the rate after k decreases (k = 0: gamma_0).

    Computed from gamma_0 each time, not as a running product, so no round-off accumulates."""
    return initial_rate / decrease_factor**k


def final_stage(initial_rate: float, decrease_factor: float, final_rate: float) -> int:
    """K, the first k with gamma_k <= the final rate: the ladder has K + 1 rates (f > 1, rates > 0)."""
    k = 0
    while stage_rate(initial_rate, decrease_factor, k) > final_rate:
        k += 1
    return k


def ladder_rates(initial_rate: float, decrease_factor: float, final_rate: float) -> list[float]:
    """gamma_0, gamma_1, ..., gamma_K: every rate the search may compress at, in order."""
    last = final_stage(initial_rate, decrease_factor, final_rate)
    return [stage_rate(initial_rate, decrease_factor, k) for k in range(last + 1)]


def last_rate_floor(decrease_factor: float, final_rate: float) -> float:
    """A lower bound of gamma_K without walking the ladder: gamma_K ~ gamma_{K-1} / f > final_rate / f."""
    return final_rate / decrease_factor


def stage_count(initial_rate: float, decrease_factor: float, final_rate: float) -> int:
    """K + 1, the number of rates of the ladder, without walking it: the smallest K with f^K >= gamma_0 / gamma_f.

    Within one of final_stage, whose loop this replaces where the ladder may be long (f near 1)."""
    if final_rate >= initial_rate:
        return 1
    return math.ceil(math.log(initial_rate / final_rate) / math.log(decrease_factor)) + 1
