"""The packing model: N spheres with actual diameters in a periodic cube of side L, in d dimensions.

Diameters are always the **actual** diameters (no hidden scale factor): two spheres overlap iff their distance is
below (D_i + D_j)/2. Nominal diameters (relative sizes, mean 1) are derived.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from . import neighbours
from .errors import InputError, OverlapError

DEFAULT_OVERLAP_TOLERANCE = 1e-10


def ball_volume(diameters: np.ndarray | float, dim: int) -> np.ndarray | float:
    """Volume of d-balls of the given diameters: pi^(d/2) / Gamma(d/2 + 1) * (D/2)^d."""
    return math.pi ** (dim / 2) / math.gamma(dim / 2 + 1) * (np.asarray(diameters) / 2.0) ** dim


@dataclass(frozen=True)
class OverlapReport:
    """Result of :meth:`Packing.check`.

    ``worst_overlap`` is max over pairs of 1 - r_ij / D_ij (relative to the pair's contact distance; <= 0 means no
    overlap), attained by ``pair``; ``n_overlaps`` counts pairs beyond ``tolerance``.
    """

    worst_overlap: float
    pair: tuple[int, int] | None
    n_overlaps: int
    tolerance: float

    @property
    def ok(self) -> bool:
        return self.n_overlaps == 0

    def __str__(self) -> str:
        if self.pair is None:
            return f"no touching or overlapping pairs (tolerance {self.tolerance:g})"
        i, j = self.pair
        state = "OK" if self.ok else f"FAIL: {self.n_overlaps} pair(s) overlap beyond {self.tolerance:g}"
        return f"{state}; worst relative overlap {self.worst_overlap:.3e} between spheres {i} and {j}"


@dataclass(eq=False)
class Packing:
    """Spheres in a periodic cube.

    Parameters
    ----------
    positions : (N, d) float64
        Centres, wrapped into [0, L).
    diameters : (N,) float64
        Actual diameters (same length unit as L).
    box : float
        Side L of the periodic cube.
    metadata : dict
        JSON-serialisable facts: ``algorithm``, ``parameters``, ``seed``, ``reduced_pressure``, ``counters``, ...
    """

    positions: np.ndarray
    diameters: np.ndarray
    box: float
    metadata: dict[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        pos = np.array(self.positions, dtype=np.float64, copy=True)
        dia = np.array(self.diameters, dtype=np.float64, copy=True)
        if pos.ndim != 2:
            raise InputError(f"positions: shape {pos.shape}: must be (N, d)")
        n, dim = pos.shape
        if not 2 <= dim <= 5:
            raise InputError(f"dimension d={dim}: must be between 2 and 5")
        if dia.shape != (n,):
            raise InputError(f"diameters: shape {dia.shape}: must be ({n},) to match positions")
        if n < 2:
            raise InputError(f"N={n}: a packing needs at least 2 spheres")
        box = float(self.box)
        if not (math.isfinite(box) and box > 0):
            raise InputError(f"box={self.box!r}: must be a finite number > 0")
        if not np.all(np.isfinite(pos)):
            raise InputError("positions: contain NaN or infinity")
        if not (np.all(np.isfinite(dia)) and np.all(dia > 0)):
            raise InputError("diameters: must all be finite and > 0")
        pos = np.mod(pos, box)
        pos[pos >= box] = 0.0  # np.mod can round up to box for tiny negatives
        self.positions = pos
        self.diameters = dia
        self.box = box
        self.metadata = dict(self.metadata)

    # --- basic properties -------------------------------------------------------------------------------------
    @property
    def n(self) -> int:
        return self.positions.shape[0]

    @property
    def dim(self) -> int:
        return self.positions.shape[1]

    @property
    def volume(self) -> float:
        """Box volume L^d."""
        return self.box**self.dim

    @property
    def phi(self) -> float:
        """Packing fraction phi = sum of ball volumes / L^d (dimensionless)."""
        return float(np.sum(ball_volume(self.diameters, self.dim)) / self.volume)

    @property
    def mean_diameter(self) -> float:
        return float(np.mean(self.diameters))

    @property
    def nominal_diameters(self) -> np.ndarray:
        """Relative sizes D_i / <D> (mean exactly 1)."""
        return self.diameters / self.mean_diameter

    @property
    def polydispersity(self) -> float:
        """Relative standard deviation of the diameters, std(D)/<D> (the paper's sigma)."""
        return float(np.std(self.diameters) / self.mean_diameter)

    # --- geometry -----------------------------------------------------------------------------------------------
    def closest_pair(self) -> tuple[int, int, float]:
        """``(i, j, h)`` with the smallest normalised distance h = r_ij / D_ij."""
        return neighbours.closest_pair(self.positions, self.diameters, self.box)

    def min_gap(self) -> float:
        """Smallest normalised gap h - 1 over all pairs (negative if anything overlaps)."""
        return self.closest_pair()[2] - 1.0

    def pairs_within(self, scale: float = 1.0):
        """Pairs with r_ij < scale * D_ij, as ``(i, j, r)`` arrays."""
        return neighbours.pairs_within(self.positions, self.diameters, self.box, scale)

    def check(self, tolerance: float = DEFAULT_OVERLAP_TOLERANCE) -> OverlapReport:
        """Report the worst overlap 1 - r_ij/D_ij over all pairs, in any box (the closest image of a pair is its
        minimum image; a sphere wider than L overlaps its own image); pairs beyond ``tolerance`` count as failures."""
        i, j, r = self.pairs_within(1.0 + 1e-9)  # include exactly touching pairs in the report
        # a sphere as wide as the box touches its own image (r = L) in any box; pairs_within leaves those out
        own = np.flatnonzero(self.diameters * (1.0 + 1e-9) > self.box)
        i, j = np.concatenate([i, own]), np.concatenate([j, own])
        r = np.concatenate([r, np.full(len(own), self.box)])
        if len(r) == 0:
            return OverlapReport(worst_overlap=-math.inf, pair=None, n_overlaps=0, tolerance=tolerance)
        overlap = 1.0 - r / (0.5 * (self.diameters[i] + self.diameters[j]))
        k = int(np.argmax(overlap))
        return OverlapReport(
            worst_overlap=float(overlap[k]),
            pair=(int(i[k]), int(j[k])),
            n_overlaps=int(np.count_nonzero(overlap > tolerance)),
            tolerance=tolerance,
        )

    def validate(self, tolerance: float = DEFAULT_OVERLAP_TOLERANCE, what: str = "packing") -> OverlapReport:
        """Like :meth:`check`, but raise :class:`OverlapError` if any pair overlaps beyond ``tolerance``."""
        report = self.check(tolerance)
        if not report.ok:
            raise OverlapError(f"{what}: {report}")
        return report

    # --- derived packings ---------------------------------------------------------------------------------------
    def replace(self, **changes) -> Packing:
        """A new packing with some fields replaced (metadata is copied, not shared)."""
        changes.setdefault("metadata", dict(self.metadata))
        return dataclasses.replace(self, **changes)

    def scaled_to_contact(self) -> Packing:
        """Diameters scaled by one factor so that the closest pair just touches (h_min = 1); a sphere and its own
        image (r = L) count as a pair, so that in a tiny box the largest sphere is at most as wide as the box."""
        h = min(self.closest_pair()[2], self.box / float(self.diameters.max()))
        return self.replace(diameters=self.diameters * h)

    def __repr__(self) -> str:
        alg = self.metadata.get("algorithm", "?")
        return f"Packing(N={self.n}, d={self.dim}, L={self.box:.6g}, phi={self.phi:.6f}, algorithm={alg!r})"
