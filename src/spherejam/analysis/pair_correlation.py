"""The radial distribution function g(r) of a periodic packing, any d."""

from __future__ import annotations

import math

import numpy as np

from ..core import neighbours
from ..core.errors import require
from ..core.packing import Packing, ball_volume


def pair_correlation(packing: Packing, r_max: float = 5.0, bins: int = 500) -> tuple[np.ndarray, np.ndarray]:
    """Radial distribution g(r), any d; r in units of the mean diameter ā, up to min(``r_max``, L/2ā).

    Returns ``(r_centres, g)``, normalised so that g -> 1 for an ideal gas of N points: g = counts /
    (N (N - 1)/(2 V) * shell volume).
    """
    require(math.isfinite(r_max) and r_max > 0, "r_max", r_max, "must be a finite number > 0")
    require(int(bins) == bins and bins >= 1, "bins", bins, "must be an integer >= 1")
    abar = packing.mean_diameter
    r_cut = min(r_max * abar, 0.5 * packing.require_cube("g(r)"))
    unit = np.full(packing.n, r_cut)
    _, _, r = neighbours.pairs_within(packing.positions, unit, packing.box, 1.0)
    edges = np.linspace(0.0, r_cut, int(bins) + 1)
    counts = np.histogram(r, bins=edges)[0]
    shell = np.diff(ball_volume(2.0 * edges, packing.dim))
    ideal = 0.5 * packing.n * (packing.n - 1) / packing.volume * shell
    return 0.5 * (edges[1:] + edges[:-1]) / abar, counts / ideal
