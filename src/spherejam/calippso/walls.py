"""A container's walls in the CALiPPSO linear program: the sphere-wall rows, the margin of a curved wall's row, and the
gauge pins that remove the container's zero modes (docs/containers.md §5).

Every wall is one more node of the LP after the N spheres, whose d columns are fixed at 0 (:class:`~.constraints.Pins`):
a sphere-wall row is then a pair row (i, wall node) like any other, with r_iw the vector from the wall's nearest
point to the centre (the mirror image's half-distance) and sigma_iw = r_i, the sphere's radius:

    |r_iw|^2 + 2 r_iw . s_i >= Gamma r_i^2.

For a plane at distance h (r_iw = h n, n the wall's inward normal) it drops (n . s_i)^2 >= 0 from the exact
(h + n . s_i)^2 >= Gamma r_i^2: conservative, exact along n. Inside a cylinder or a sphere of radius R the exact
condition |p + s| <= R - sqrt(Gamma) r (p the centre's offset from the axis or centre) is convex in s, and its
tangent plane is not conservative; the row takes r_iw = (h - delta) n with the chord margin delta of
:func:`concave_margin`, which makes every step it admits stay inside the wall. The nodes, rows and margins are built
here; the driver (:mod:`.run`) merges the rows with the pair rows and solves them as one LP.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass

import numpy as np

from ..core.container import Container
from .constraints import Pins

#: With a curved wall the s bound is at most this many times the previous LP's largest step of a stable sphere
#: (docs/containers.md §5): the chord margin, ~ s_bound^2 / R, then vanishes as the steps do, quadratically, while a
#: bound that stops a sphere grows by this factor per LP.
TRUST_FACTOR = 4.0
#: Smallest such bound, in units of the largest diameter: ten times the displacement tolerance (docs/calippso.md
#: §2.1), so that a converged LP's steps are below its bound and not stopped by it, while the margin, ~ 1e-16 D^2 / R,
#: stays far below round-off. A smaller floor let a packing whose previous LP had no stable sphere (all steps 0)
#: stop moving and pass the displacement test without being jammed.
TRUST_FLOOR = 1e-8
#: The margin is kept below this fraction of the smallest radius (the bound lowered to it): a larger one deflates a
#: step that much (docs/containers.md §5), which once opened every contact of a small container at once.
MARGIN_MAX = 1e-3


def concave_margin(radius_wall: float, radii, sqrt_inflation_max: float, s_bound: float, across: int):
    """The margin delta_i of the tangent-plane row of spheres of radii ``radii`` inside a curved wall of radius
    ``radius_wall`` (docs/containers.md §5), absolute lengths.

    With R' = R - sqrt(Gamma) r, the row admits p_hat . (p + s) <= R' - delta; the exact condition is |p + s| <= R'.
    Along the wall the step moves by s_perp with |s_perp|^2 <= S^2 = ``across`` s_bound^2 (``across`` = 2 across a
    cylinder's axis, 3 in a sphere), so |p + s|^2 <= (R' - delta)^2 + S^2 <= R'^2 iff
    delta >= R' - sqrt(R'^2 - S^2) = S^2 / (R' + sqrt(R'^2 - S^2)). That decreases with R', so R' at Gamma_max, the
    smallest the LP allows, bounds it for every Gamma <= Gamma_max.
    """
    r_eff = radius_wall - sqrt_inflation_max * np.asarray(radii, dtype=np.float64)
    s2 = across * s_bound * s_bound
    if np.any(r_eff * r_eff <= s2):
        raise ValueError("a curved wall narrower than the step bound: no margin keeps the step inside")
    return s2 / (r_eff + np.sqrt(r_eff * r_eff - s2))


@dataclass(frozen=True)
class LPWalls:
    """The container of a CALiPPSO run in the driver's length unit, with its N spheres: one LP node per wall.

    ``planes`` lists the flat walls as (axis k, side): side 0 is the plane x_k = 0, side 1 the plane x_k = L_k;
    the curved wall, if any, is the last node.
    """

    container: Container
    spheres: int
    planes: tuple

    @classmethod
    def of(cls, container: Container, unit: float, spheres: int) -> LPWalls:
        """The walls of ``container`` (in the packing's unit) in units of ``unit``."""
        c = container.scaled(1.0 / unit)
        planes = tuple((k, side) for k in range(c.dim) if c.planes[k] for side in (0, 1))
        return cls(c, int(spheres), planes)

    @property
    def count(self) -> int:
        return len(self.planes) + (self.container.curved is not None)

    @property
    def nodes(self) -> int:
        """The LP's nodes: spheres, then walls."""
        return self.spheres + self.count

    @property
    def across(self) -> int:
        """Axes along which a step moves a sphere along the curved wall: 2 across a cylinder, 3 in a sphere."""
        return self.container.dim - 1 if self.container.curved == "cylinder" else self.container.dim

    def _offsets(self, x: np.ndarray) -> np.ndarray:
        """p: each centre's offset from the curved wall's axis (cylinder) or centre (sphere)."""
        p = x - self.container.centre
        if self.container.curved == "cylinder":
            p[:, self.container.axis] = 0.0
        return p

    def margins(self, dia: np.ndarray, sqrt_inflation_max: float, s_bound: float) -> np.ndarray:
        """delta_i of every sphere's curved-wall row (:func:`concave_margin`); zeros without a curved wall."""
        if self.container.curved is None:
            return np.zeros(len(dia))
        return concave_margin(self.container.radius, 0.5 * dia, sqrt_inflation_max, s_bound, self.across)

    def capped_bound(self, s_bound: float, previous_step: float | None, dia: np.ndarray,
                     sqrt_inflation_max: float) -> float:
        """``s_bound``, with a curved wall at most :data:`TRUST_FACTOR` times ``previous_step`` (the previous LP's
        largest |s_mu| of a stable sphere, absolute; None before the first LP; never below :data:`TRUST_FLOOR` D_max)
        and low enough that the margin stays below :data:`MARGIN_MAX` r_min (docs/containers.md §5)."""
        if self.container.curved is None:
            return s_bound
        d_max = float(dia.max())
        if previous_step is not None:
            s_bound = min(s_bound, max(TRUST_FACTOR * previous_step, TRUST_FLOOR * d_max))
        # delta <= S^2 / R'_min (concave_margin) <= MARGIN_MAX r_min
        r_eff = self.container.radius - sqrt_inflation_max * 0.5 * d_max
        small = math.sqrt(MARGIN_MAX * 0.5 * float(dia.min()) * max(r_eff, 0.0) / self.across)
        return min(s_bound, max(small, TRUST_FLOOR * d_max))

    def rows(self, x: np.ndarray, dia: np.ndarray, sqrt_inflation_max: float, s_bound: float, margin: bool = True):
        """The sphere-wall rows a step with |s_mu| <= ``s_bound`` and Gamma <= Gamma_max can violate:
        ``(pi, pj, rij, sigma2)``, pj the wall's node. A sphere at distance h from a wall moves towards it by at
        most sqrt(d) s_bound, so the wall is a row iff h < sqrt(Gamma_max) r_i + sqrt(d) s_bound (the pairs' rule
        of docs/calippso.md §1.4 with an immovable partner). ``margin`` False leaves the curved wall's margin out
        (the force LP, which takes no step: docs/containers.md §5)."""
        n, dim = x.shape
        r = 0.5 * dia
        reach = sqrt_inflation_max * r + math.sqrt(dim) * s_bound
        pis, pjs, vecs = [], [], []
        for w, (k, side) in enumerate(self.planes):
            h = x[:, k] if side == 0 else self.container.lengths[k] - x[:, k]
            i = np.flatnonzero(h < reach)
            v = np.zeros((i.size, dim))
            v[:, k] = h[i] if side == 0 else -h[i]  # from the wall to the centre
            pis.append(i)
            pjs.append(np.full(i.size, n + w, dtype=np.int64))
            vecs.append(v)
        if self.container.curved is not None:
            p = self._offsets(x)
            rho = np.sqrt(np.einsum("ij,ij->i", p, p))
            h = self.container.radius - rho
            i = np.flatnonzero((h < reach) & (rho > 0.0))
            delta = self.margins(dia, sqrt_inflation_max, s_bound)[i] if margin else np.zeros(i.size)
            # towards the axis or centre: the inward normal at the wall's nearest point
            v = -(h[i] - delta)[:, None] * p[i] / rho[i, None]
            pis.append(i)
            pjs.append(np.full(i.size, n + len(self.planes), dtype=np.int64))
            vecs.append(v)
        if not pis:
            return (np.empty(0, np.int64), np.empty(0, np.int64), np.empty((0, dim)), np.empty(0))
        pi = np.concatenate(pis).astype(np.int64)
        return pi, np.concatenate(pjs), np.concatenate(vecs), r[pi] ** 2

    def distance_ratio(self, x: np.ndarray, dia: np.ndarray) -> float:
        """min over spheres of (distance to the nearest wall) / r_i: below 1 a sphere penetrates a wall."""
        if not self.container.has_walls:
            return math.inf
        return float(np.min(self.container.wall_distance(x) / (0.5 * dia)))

    # --- zero modes ---------------------------------------------------------------------------------------------
    def zero_modes(self, x: np.ndarray) -> np.ndarray:
        """(z, N, d): the rigid motions of all spheres that no row resists (docs/containers.md §4): a translation
        along each periodic axis, the rotation about a cylinder's axis, the three rotations in a sphere. Every pair
        row is blind to them (r_ij . (omega x r_ij) = 0), and so is every wall row (a plane's normal is along an axis
        they do not move; a curved wall's is radial, the rotation tangential)."""
        c = self.container
        n, dim = x.shape
        modes = []
        for k in range(dim):
            if c.periodic[k]:
                t = np.zeros((n, dim))
                t[:, k] = 1.0
                modes.append(t)
        p = self._offsets(x)
        axes = [c.axis] if c.curved == "cylinder" else list(range(dim)) if c.curved == "sphere" else []
        for a in axes:
            e = np.zeros(dim)
            e[a] = 1.0
            modes.append(np.cross(e, p))
        return np.array(modes).reshape(len(modes), n, dim)

    def gauge(self, x: np.ndarray, pinned: int, rattler: np.ndarray | None = None) -> Pins:
        """The LP's fixed columns: every wall node's, and one sphere component per zero mode, chosen so that the
        zero modes' values on them form the best-conditioned square matrix (largest |det|) among the components of
        the pinned sphere and of the three non-rattlers farthest from the axis or centre. Any s is then a step with
        those components at 0 plus a zero mode, so the pins fix the gauge and take away no true degree of freedom;
        a rotation left free would leave the LP's vertex to push every sphere round to its s bound. In a periodic
        box (translations only) these are the pinned sphere's components along the periodic axes."""
        n, dim = x.shape
        walls = np.arange(n * dim, self.nodes * dim, dtype=np.int64)
        modes = self.zero_modes(x)
        z = modes.shape[0]
        if z == 0:
            return Pins(walls, n, dim)
        candidates = [int(pinned)]
        if self.container.curved is not None:
            p = self._offsets(x)
            far = np.einsum("ij,ij->i", p, p)
            if rattler is not None:
                far = np.where(rattler[:n], -1.0, far)
            candidates += [int(i) for i in np.argsort(-far, kind="stable")[:3] if int(i) != int(pinned)]
        columns = [i * dim + a for i in candidates for a in range(dim)]
        values = modes.reshape(z, n * dim)[:, columns].T  # (columns, z)
        best, best_det = None, 0.0
        for combo in itertools.combinations(range(len(columns)), z):
            det = abs(float(np.linalg.det(values[list(combo)])))
            if det > best_det * (1.0 + 1e-9):
                best, best_det = combo, det
        if best is None:
            raise ValueError("no sphere components fix the container's zero modes")
        gauge = np.sort(np.array([columns[c] for c in best], dtype=np.int64))
        return Pins(np.concatenate([gauge, walls]), n, dim)
