"""The packing model: N spheres with actual diameters in a container (a periodic cube of side L unless said
otherwise: core/container), in d dimensions.

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
from .container import Container
from .errors import InputError, OverlapError

DEFAULT_OVERLAP_TOLERANCE = 1e-10


def ball_volume(diameters: np.ndarray | float, dim: int) -> np.ndarray | float:
    """Volume of d-balls of the given diameters: pi^(d/2) / Gamma(d/2 + 1) * (D/2)^d."""
    return math.pi ** (dim / 2) / math.gamma(dim / 2 + 1) * (np.asarray(diameters) / 2.0) ** dim


@dataclass(frozen=True)
class OverlapReport:
    """Result of :meth:`Packing.check`.

    ``worst_overlap`` is max over pairs of 1 - r_ij / D_ij (relative to the pair's contact distance; <= 0 means no
    overlap), or of a sphere's relative penetration into a wall (the pair (i, -1)), attained by ``pair``;
    ``n_overlaps`` counts pairs beyond ``tolerance``.
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
        other = "a wall" if j < 0 else f"sphere {j}"
        return f"{state}; worst relative overlap {self.worst_overlap:.3e} between sphere {i} and {other}"


@dataclass(eq=False)
class Packing:
    """Spheres in a periodic cube, or in any :class:`~spherejam.core.container.Container`.

    Parameters
    ----------
    positions : (N, d) float64
        Centres, wrapped into [0, L_k) along periodic axes; inside the walls otherwise.
    diameters : (N,) float64
        Actual diameters (same length unit as L).
    box : float
        Side L of the periodic cube; for another container, NaN (pass ``container`` instead, and use
        ``container.lengths``): code that knows only the cube refuses such a packing (:meth:`require_cube`).
    metadata : dict
        JSON-serialisable facts: ``algorithm``, ``parameters``, ``seed``, ``reduced_pressure``, ``counters``, ...
    container : Container, optional
        The container; None is the periodic cube of side ``box``.
    """

    positions: np.ndarray
    diameters: np.ndarray
    box: float
    metadata: dict[str, Any] = field(default_factory=dict)
    container: Container | None = None

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
        container = self.container
        if container is not None and container.is_periodic_cube and self.box is not None \
                and not math.isnan(float(self.box)) and float(self.box) != container.side:
            raise InputError(f"box={self.box!r}: differs from the side of container {container.spec} "
                             f"({container.side!r}); give one of them")
        if container is None or container.is_periodic_cube:
            box = float(container.side if container is not None else self.box)
            if not (math.isfinite(box) and box > 0):
                raise InputError(f"box={self.box!r}: must be a finite number > 0")
            container = Container.cube(box, dim) if container is None else container
        else:
            box = math.nan
        if container.dim != dim:
            raise InputError(f"container {container.spec}: has {container.dim} axes, positions have {dim}")
        if not np.all(np.isfinite(pos)):
            raise InputError("positions: contain NaN or infinity")
        if not (np.all(np.isfinite(dia)) and np.all(dia > 0)):
            raise InputError("diameters: must all be finite and > 0")
        if container.is_periodic_cube:
            pos = np.mod(pos, box)
            pos[pos >= box] = 0.0  # np.mod can round up to box for tiny negatives
        else:
            pos = container.wrap(pos)
            outside = ~np.all((pos >= 0) & (pos < np.asarray(container.lengths)), axis=1)
            outside |= container.wall_distance(pos) < 0
            if np.any(outside):
                i = int(np.flatnonzero(outside)[0])
                raise InputError(f"positions: sphere {i} at {pos[i].tolist()} lies outside container {container.spec}")
        self.positions = pos
        self.diameters = dia
        self.box = box
        self.container = container
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
        """Volume of the container: the box volume L^d of a periodic cube."""
        return self.box**self.dim if self.container.is_periodic_cube else self.container.volume

    @property
    def phi(self) -> float:
        """Packing fraction phi = sum of ball volumes / container volume (dimensionless)."""
        return float(np.sum(ball_volume(self.diameters, self.dim)) / self.volume)

    def require_cube(self, what: str) -> float:
        """The side L of this packing's periodic cube; :class:`InputError` naming ``what`` for any other container
        (the parts of spherejam that handle only the periodic cube call it first)."""
        if not self.container.is_periodic_cube:
            raise InputError(f"container={self.container.spec}: {what} handles only a periodic cube so far "
                             f"(docs/containers.md lists what handles containers)")
        return self.box

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
    @property
    def frame(self):
        """The box argument of the pair searches of :mod:`~spherejam.core.neighbours`: the cube side L, or the
        container's frame lengths and periodicity."""
        return self.box if self.container.is_periodic_cube else neighbours.Frame.of(self.container)

    def closest_pair(self) -> tuple[int, int, float]:
        """``(i, j, h)`` with the smallest normalised distance h = r_ij / D_ij."""
        return neighbours.closest_pair(self.positions, self.diameters, self.frame)

    def min_gap(self) -> float:
        """Smallest normalised gap h - 1 over all pairs (negative if anything overlaps)."""
        return self.closest_pair()[2] - 1.0

    def pairs_within(self, scale: float = 1.0):
        """Pairs with r_ij < scale * D_ij, as ``(i, j, r)`` arrays."""
        return neighbours.pairs_within(self.positions, self.diameters, self.frame, scale)

    def check(self, tolerance: float = DEFAULT_OVERLAP_TOLERANCE) -> OverlapReport:
        """Report the worst overlap 1 - r_ij/D_ij over all pairs, in any box (the closest image of a pair is its
        minimum image; a sphere wider than L overlaps its own image), and the worst relative penetration of a sphere
        into a wall (reported as the pair (i, -1)); pairs beyond ``tolerance`` count as failures."""
        i, j, r = self.pairs_within(1.0 + 1e-9)  # include exactly touching pairs in the report
        # a sphere as wide as a periodic length touches its own image (r = L); pairs_within leaves those out
        c = self.container
        period = min((L for L, p in zip(c.lengths, c.periodic) if p), default=math.inf)
        own = np.flatnonzero(self.diameters * (1.0 + 1e-9) > period)
        i, j = np.concatenate([i, own]), np.concatenate([j, own])
        r = np.concatenate([r, np.full(len(own), period)])
        overlap = 1.0 - r / (0.5 * (self.diameters[i] + self.diameters[j]))
        if c.has_walls:  # a sphere touching a wall is a contact with it, of overlap = its relative penetration
            pen = (0.5 * self.diameters - c.wall_distance(self.positions)) / (0.5 * self.diameters)
            touching = np.flatnonzero(pen > -1e-9)
            i, j = np.concatenate([i, touching]), np.concatenate([j, np.full(len(touching), -1)])
            overlap = np.concatenate([overlap, pen[touching]])
        if len(overlap) == 0:
            return OverlapReport(worst_overlap=-math.inf, pair=None, n_overlaps=0, tolerance=tolerance)
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
        """A new packing with some fields replaced (metadata is copied, not shared). A new ``box`` without a new
        ``container`` is the periodic cube of that side."""
        changes.setdefault("metadata", dict(self.metadata))
        if "box" in changes and "container" not in changes:
            changes["container"] = None
        return dataclasses.replace(self, **changes)

    def scaled_to_contact(self) -> Packing:
        """Diameters scaled by one factor so that the closest pair just touches (h_min = 1), or a sphere just
        touches a wall if that comes first; a sphere and its own image (r = L_k along a periodic axis) count as a
        pair, so that in a tiny box the largest sphere is at most as wide as the box."""
        c = self.container
        period = min((L for L, p in zip(c.lengths, c.periodic) if p), default=math.inf)
        h = min(self.closest_pair()[2], period / float(self.diameters.max()),
                c.max_scale(self.positions, self.diameters))
        return self.replace(diameters=self.diameters * h)

    def __repr__(self) -> str:
        alg = self.metadata.get("algorithm", "?")
        where = f"L={self.box:.6g}" if self.container.is_periodic_cube else f"container={self.container.spec!r}"
        return f"Packing(N={self.n}, d={self.dim}, {where}, phi={self.phi:.6f}, algorithm={alg!r})"
