"""Porosity profiles of a packing in a container, computed exactly from sphere-region intersection volumes
(docs/containers_structure.md).

A profile bins the container into shells at fixed distance from a wall (radial: a cylinder's coaxial annuli, a
spherical container's concentric shells) or into slabs along an axis (axial: slabs and boxes, a cylinder along its
axis, any periodic box). The solid fraction of a bin is the volume of every sphere inside the bin divided by the bin's
volume, phi_k = sum_i |B_i cap S_k| / |S_k|, and the porosity is eps_k = 1 - phi_k. No centre histogram: each
sphere's volume is split among the bins it crosses, so the profile is exact at any bin width and sum_k phi_k |S_k| =
phi |V| to round-off.

Intersection volumes (all lengths in the packing's unit)

* sphere (radius r, centre height c) and slab z1 <= z <= z2: the difference of the closed form
  F(t) = pi (r^2 t - t^3 / 3 + 2 r^3 / 3), t = clip(z - c, -r, r) (two spherical caps). Along a periodic axis the
  sphere's periodic images are summed, so a sphere crossing a periodic face is split between the bins at both ends.
* sphere and a ball of radius rho (a spherical container's shells): the closed-form lens volume of two spheres.
* sphere and a solid cylinder of radius rho (a cylinder's annuli), and sphere and a box (the core region of a closed
  box): the integral over the axis of the exact area of the sphere's disc section, radius a(t) = sqrt(r^2 - t^2),
  cut by the disc of radius rho (the lens area of two discs, in the stable atan2 form) or by the rectangle (the
  disc-rectangle area in closed form, piecewise in arcsines). The integrand is smooth except where the section's
  circle becomes tangent to a boundary (a(t) = |rho - delta|, rho + delta; a(t) = the distance to an edge or a
  corner), where it behaves like (t - t0)^(3/2). The integral is split at those kinks, and on each piece the
  substitution t = t0 + (t1 - t0)(1 - cos(pi s))/2 turns every such square-root kink at an end into an analytic
  function of s, so that the 32-point Gauss-Legendre rule on s converges geometrically: the tests compare it with the
  closed forms (a coaxial sphere, a sphere whole inside), with adaptive quadrature, and with 64 points, and find
  agreement to ~1e-14 relative to the sphere's volume (a bound of 1e-12 is tested).

The profile coordinate is in mean diameters <d> (number mean of the actual diameters): radial profiles run from the
wall (0) inwards; axial ones from the wall at x_k = 0 (``fold=True``: the distance from the nearer of the two walls).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numba import njit

from ..core.errors import InputError, require
from ..core.packing import Packing, ball_volume

#: Gauss-Legendre points per smooth piece of the cylinder and box integrals (module docstring).
QUADRATURE_POINTS = 32
#: Default bin width of a profile, in mean diameters.
DEFAULT_BIN_WIDTH = 0.05
#: Default distance of the core region from every wall, in mean diameters.
DEFAULT_CORE_DISTANCE = 5.0


def _rule(points: int) -> tuple[np.ndarray, np.ndarray]:
    """Nodes s in (0, 1) and weights of the cosine-substituted Gauss-Legendre rule: int_0^1 f(t) dt ~
    sum_j w_j f(t_j), t = (1 - cos(pi s)) / 2 (so dt = pi sin(pi s) / 2 ds is folded into the weights)."""
    x, w = np.polynomial.legendre.leggauss(points)
    s = 0.5 * (x + 1.0)
    t = 0.5 * (1.0 - np.cos(math.pi * s))
    return np.ascontiguousarray(t), np.ascontiguousarray(0.5 * w * 0.5 * math.pi * np.sin(math.pi * s))


_NODES, _WEIGHTS = _rule(QUADRATURE_POINTS)


# --- closed forms --------------------------------------------------------------------------------------------------


def slab_volume(centre: np.ndarray, radius: np.ndarray, z1, z2) -> np.ndarray:
    """Volume of the spheres (centre heights ``centre``, radii ``radius``) between the planes z = z1 and z = z2
    (z1 <= z2; either may be infinite): the difference of two spherical caps."""
    c, r = np.asarray(centre, dtype=np.float64), np.asarray(radius, dtype=np.float64)

    def below(z):
        t = np.clip(z - c, -r, r)
        return math.pi * (r * r * t - t**3 / 3.0 + 2.0 * r**3 / 3.0)

    return below(z2) - below(z1)


def lens_volume(radius: np.ndarray, rho: float, delta: np.ndarray) -> np.ndarray:
    """Volume of the spheres of radii ``radius`` at distances ``delta`` from the centre of a ball of radius ``rho``
    that lies inside that ball (the lens of two spheres)."""
    r = np.asarray(radius, dtype=np.float64)
    d = np.asarray(delta, dtype=np.float64)
    r, d = np.broadcast_arrays(r, d)
    out = np.zeros(r.shape)
    inside = d <= np.abs(rho - r)
    out[inside] = 4.0 / 3.0 * math.pi * np.minimum(r[inside], rho) ** 3
    cut = ~inside & (d < r + rho)
    rc, dc = r[cut], d[cut]
    out[cut] = (math.pi * (rc + rho - dc) ** 2
                * (dc * dc + 2.0 * dc * rho - 3.0 * rho * rho + 2.0 * dc * rc + 6.0 * rho * rc - 3.0 * rc * rc)
                / (12.0 * dc))
    return out


# --- exact areas and the 1D integrals (numba) ----------------------------------------------------------------------


@njit(cache=True, inline="always")
def _lens_area(a, rho, delta):
    """Area of the disc of radius a, centred at distance delta from the centre of the disc of radius rho, inside
    the latter (stable form: the two circular segments from atan2 half-angles)."""
    if a <= 0.0 or rho <= 0.0 or delta >= a + rho:
        return 0.0
    if delta <= abs(rho - a):
        m = min(a, rho)
        return math.pi * m * m
    xa = (delta * delta + a * a - rho * rho) / (2.0 * delta)  # from a's centre to the common chord
    xb = delta - xa
    q = (-delta + a + rho) * (delta + a - rho) * (delta - a + rho) * (delta + a + rho)
    h = math.sqrt(max(q, 0.0)) / (2.0 * delta)  # half the common chord
    return a * a * math.atan2(h, xa) + rho * rho * math.atan2(h, xb) - delta * h


@njit(cache=True, inline="always")
def _chord_integral(a, t):
    """int_{-a}^{t} sqrt(a^2 - u^2) du for -a <= t <= a."""
    s = math.sqrt(max(a * a - t * t, 0.0))
    return 0.5 * (t * s + a * a * math.asin(max(-1.0, min(1.0, t / a)))) + 0.25 * math.pi * a * a


@njit(cache=True)
def _disc_rect_area(a, x1, x2, y1, y2):
    """Area of the disc of radius a at the origin inside the rectangle [x1, x2] x [y1, y2] (bounds may be
    infinite): the integral over x of the overlap of [y1, y2] with the chord [-s, s], s = sqrt(a^2 - x^2), exact
    piece by piece between the x where s = |y1| or s = |y2|."""
    lo = max(-a, x1)
    hi = min(a, x2)
    if a <= 0.0 or hi <= lo or y2 <= -a or y1 >= a:
        return 0.0
    cuts = np.empty(6)
    m = 0
    cuts[m] = lo
    m += 1
    for y in (y1, y2):
        if abs(y) < a:
            x = math.sqrt(a * a - y * y)
            for b in (-x, x):
                if lo < b < hi:
                    cuts[m] = b
                    m += 1
    cuts[m] = hi
    m += 1
    cuts[:m].sort()
    area = 0.0
    for k in range(m - 1):
        u0, u1 = cuts[k], cuts[k + 1]
        if u1 <= u0:
            continue
        mid = 0.5 * (u0 + u1)
        s = math.sqrt(max(a * a - mid * mid, 0.0))
        if min(y2, s) - max(y1, -s) <= 0.0:
            continue
        chord = _chord_integral(a, u1) - _chord_integral(a, u0)  # int s
        # top: y2 if y2 < s else s; bottom: y1 if y1 > -s else -s
        area += (y2 * (u1 - u0) if y2 < s else chord) - (y1 * (u1 - u0) if y1 > -s else -chord)
    return area


@njit(cache=True)
def _sorted_breaks(t_lo, t_hi, r, values, m):
    """The interval [t_lo, t_hi] cut where the section radius a(t) = sqrt(r^2 - t^2) equals one of ``values[:m]``."""
    out = np.empty(2 * m + 2)
    k = 0
    out[k] = t_lo
    k += 1
    for q in range(m):
        v = values[q]
        if 0.0 <= v < r:
            t = math.sqrt(r * r - v * v)
            for b in (-t, t):
                if t_lo < b < t_hi:
                    out[k] = b
                    k += 1
    out[k] = t_hi
    k += 1
    out[:k].sort()
    return out[:k]


@njit(cache=True)
def _sphere_cylinder(r, delta, rho, t_lo, t_hi, nodes, weights):
    """Volume of the sphere of radius r, its centre at distance delta from the axis of a solid cylinder of radius
    rho, between the heights t_lo <= t <= t_hi relative to its centre (within [-r, r])."""
    t_lo = max(t_lo, -r)
    t_hi = min(t_hi, r)
    if t_hi <= t_lo:
        return 0.0
    if rho >= delta + r:  # the whole section is inside at every height: two caps
        return math.pi * ((r * r * t_hi - t_hi**3 / 3.0) - (r * r * t_lo - t_lo**3 / 3.0))
    if rho <= delta - r:
        return 0.0
    kinks = np.empty(2)
    kinks[0] = abs(rho - delta)
    kinks[1] = rho + delta
    breaks = _sorted_breaks(t_lo, t_hi, r, kinks, 2)
    total = 0.0
    for k in range(breaks.shape[0] - 1):
        u0, u1 = breaks[k], breaks[k + 1]
        span = u1 - u0
        if span <= 0.0:
            continue
        for j in range(nodes.shape[0]):
            t = u0 + span * nodes[j]
            a = math.sqrt(max(r * r - t * t, 0.0))
            total += span * weights[j] * _lens_area(a, rho, delta)
    return total


@njit(cache=True)
def _sphere_box(r, lo, hi, nodes, weights):
    """Volume of the sphere of radius r at the origin inside the box lo <= x <= hi (3 axes; the integral runs along
    the last axis; bounds may be infinite)."""
    t_lo = max(-r, lo[2])
    t_hi = min(r, hi[2])
    if t_hi <= t_lo:
        return 0.0
    if lo[0] <= -r and hi[0] >= r and lo[1] <= -r and hi[1] >= r:  # cut by the last axis only: two caps
        return math.pi * ((r * r * t_hi - t_hi**3 / 3.0) - (r * r * t_lo - t_lo**3 / 3.0))
    kinks = np.empty(8)
    kinks[0], kinks[1], kinks[2], kinks[3] = abs(lo[0]), abs(hi[0]), abs(lo[1]), abs(hi[1])
    m = 4
    for x in (lo[0], hi[0]):
        for y in (lo[1], hi[1]):
            kinks[m] = math.sqrt(x * x + y * y)
            m += 1
    breaks = _sorted_breaks(t_lo, t_hi, r, kinks, m)
    total = 0.0
    for k in range(breaks.shape[0] - 1):
        u0, u1 = breaks[k], breaks[k + 1]
        span = u1 - u0
        if span <= 0.0:
            continue
        for j in range(nodes.shape[0]):
            t = u0 + span * nodes[j]
            a = math.sqrt(max(r * r - t * t, 0.0))
            total += span * weights[j] * _disc_rect_area(a, lo[0], hi[0], lo[1], hi[1])
    return total


@njit(cache=True)
def _cylinder_cumulative(delta, height, radius, rhos, t_lo, t_hi, nodes, weights):
    """cum[e] = sum_i |B_i cap {distance from the axis < rhos[e], t_lo - height_i <= t <= t_hi - height_i}|."""
    n = delta.shape[0]
    e_count = rhos.shape[0]
    cum = np.zeros(e_count)
    for i in range(n):
        r, d = radius[i], delta[i]
        lo, hi = t_lo - height[i], t_hi - height[i]
        for e in range(e_count):
            rho = rhos[e]
            if rho <= d - r:
                continue
            cum[e] += _sphere_cylinder(r, d, rho, lo, hi, nodes, weights)
    return cum


@njit(cache=True)
def _box_volumes(positions, radius, lo, hi, nodes, weights):
    """|B_i cap [lo, hi]| for each sphere (the integral runs along the last axis)."""
    n = positions.shape[0]
    out = np.empty(n)
    rel_lo = np.empty(3)
    rel_hi = np.empty(3)
    for i in range(n):
        for k in range(3):
            rel_lo[k] = lo[k] - positions[i, k]
            rel_hi[k] = hi[k] - positions[i, k]
        out[i] = _sphere_box(radius[i], rel_lo, rel_hi, nodes, weights)
    return out


def sphere_cylinder_volume(radius: float, delta: float, rho: float, t_lo: float = -math.inf,
                           t_hi: float = math.inf, points: int = QUADRATURE_POINTS) -> float:
    """Volume of a sphere of radius ``radius`` (centre at distance ``delta`` from the axis) inside the solid cylinder
    of radius ``rho``, between the heights ``t_lo`` and ``t_hi`` relative to the sphere's centre."""
    nodes, weights = (_NODES, _WEIGHTS) if points == QUADRATURE_POINTS else _rule(points)
    return float(_sphere_cylinder(float(radius), float(delta), float(rho), float(t_lo), float(t_hi), nodes, weights))


def sphere_box_volume(centre, radius: float, lo, hi, points: int = QUADRATURE_POINTS) -> float:
    """Volume of a sphere inside the box ``lo <= x <= hi`` (3 axes; bounds may be infinite)."""
    nodes, weights = (_NODES, _WEIGHTS) if points == QUADRATURE_POINTS else _rule(points)
    c = np.asarray(centre, dtype=np.float64)
    return float(_sphere_box(float(radius), np.asarray(lo, dtype=np.float64) - c, np.asarray(hi, dtype=np.float64) - c,
                             nodes, weights))


def disc_rectangle_area(a: float, x1: float, x2: float, y1: float, y2: float) -> float:
    """Area of the disc of radius ``a`` at the origin inside the rectangle [x1, x2] x [y1, y2]."""
    return float(_disc_rect_area(float(a), float(x1), float(x2), float(y1), float(y2)))


def lens_area(a: float, rho: float, delta: float) -> float:
    """Area of the disc of radius ``a`` (centre at distance ``delta``) inside the disc of radius ``rho``."""
    return float(_lens_area(float(a), float(rho), float(delta)))


# --- profiles ------------------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class Profile:
    """A porosity profile: bins [edges[k], edges[k+1]] of the profile coordinate (mean diameters), the solid volume
    and the bin volume of each (the packing's length unit cubed)."""

    kind: str  #: "radial" (distance from the curved wall) or "axial" (position along ``axis``)
    axis: int | None  #: the axis of an axial profile
    folded: bool  #: an axial profile folded onto the distance from the nearer wall
    edges: np.ndarray
    solid: np.ndarray
    volume: np.ndarray
    mean_diameter: float  #: <d>, the unit of ``edges``

    @property
    def centres(self) -> np.ndarray:
        return 0.5 * (self.edges[1:] + self.edges[:-1])

    @property
    def phi(self) -> np.ndarray:
        """Solid fraction of each bin."""
        return self.solid / self.volume

    @property
    def porosity(self) -> np.ndarray:
        """Porosity eps = 1 - phi of each bin."""
        return 1.0 - self.phi

    def mean_phi(self) -> float:
        """The solid fraction of all bins together (the packing's phi when the bins cover the container)."""
        return float(self.solid.sum() / self.volume.sum())

    def as_dict(self) -> dict:
        return {"kind": self.kind, "axis": self.axis, "folded": self.folded, "mean_diameter": self.mean_diameter,
                "edges": self.edges.tolist(), "porosity": self.porosity.tolist()}


def _edges(extent: float, bin_width: float) -> np.ndarray:
    """Bin edges from 0 to ``extent`` (mean diameters) of width ``bin_width``; the last bin ends at ``extent``."""
    require(isinstance(bin_width, (int, float, np.floating)) and math.isfinite(bin_width) and bin_width > 0,
            "bin_width", bin_width, "must be a finite number > 0 (mean diameters)")
    m = max(1, int(math.ceil(extent / bin_width - 1e-9)))
    edges = np.minimum(np.arange(m + 1) * float(bin_width), extent)
    edges[-1] = extent
    return edges


def _container_3d(packing: Packing, what: str):
    require(packing.dim == 3, "dimension d", packing.dim, f"{what} is implemented for d = 3")
    return packing.container


def radial_profile(packing: Packing, bin_width: float = DEFAULT_BIN_WIDTH) -> Profile:
    """The radial porosity profile of a packing in a cylinder or a sphere: bins of ``bin_width`` mean diameters
    of the distance from the curved wall, from the wall (0) to the axis or centre (R / <d>)."""
    c = _container_3d(packing, "the radial profile")
    if c.curved is None:
        raise InputError(f"container={c.spec}: a radial profile needs a cylinder or a sphere (use the axial profile)")
    dbar = packing.mean_diameter
    edges = _edges(c.radius / dbar, bin_width)
    rhos = np.maximum(c.radius - edges * dbar, 0.0)  # radius of the region inside each edge (decreasing)
    radius = 0.5 * packing.diameters
    p = packing.positions - c.centre
    if c.curved == "cylinder":
        perp = np.delete(p, c.axis, axis=1)
        delta = np.sqrt(np.einsum("ij,ij->i", perp, perp))
        height = np.ascontiguousarray(p[:, c.axis])
        inside = _cylinder_cumulative(delta, height, radius, np.ascontiguousarray(rhos), -math.inf, math.inf,
                                      _NODES, _WEIGHTS)
        length = c.lengths[c.axis]
        region = math.pi * rhos**2 * length
    else:
        delta = np.sqrt(np.einsum("ij,ij->i", p, p))
        inside = np.array([lens_volume(radius, rho, delta).sum() for rho in rhos])
        region = 4.0 / 3.0 * math.pi * rhos**3
    return Profile("radial", None, False, edges, inside[:-1] - inside[1:], region[:-1] - region[1:], dbar)


def _axial_axis(c, axis):
    if axis is None:
        walled = [k for k in range(c.dim) if c.planes[k]]
        if c.curved == "cylinder":
            return c.axis
        if len(walled) == 1:
            return walled[0]
        return c.dim - 1  # a closed box or a periodic box: along z unless told
    require(isinstance(axis, (int, np.integer)) and 0 <= axis < c.dim, "axis", axis, f"must be 0 ... {c.dim - 1}")
    return int(axis)


def axial_profile(packing: Packing, axis: int | None = None, bin_width: float = DEFAULT_BIN_WIDTH,
                  fold: bool = False) -> Profile:
    """The axial porosity profile along ``axis`` (default: a slab's walled axis, a cylinder's axis, else z): bins
    of ``bin_width`` mean diameters of the position x_k / <d> from 0 to L_k / <d>, or, with ``fold``, of the distance
    from the nearer of the planes x_k = 0 and x_k = L_k, from 0 to L_k / (2 <d>). Along a periodic axis each sphere's
    periodic images are summed (a sphere crossing a periodic face counts in the bins at both ends)."""
    c = _container_3d(packing, "the axial profile")
    k = _axial_axis(c, axis)
    if c.curved == "sphere" or (c.curved == "cylinder" and k != c.axis):
        raise InputError(f"container={c.spec}: an axial profile along {'xyz'[k]} needs a constant cross-section "
                         f"(a box, a slab, or a cylinder along its axis)")
    dbar = packing.mean_diameter
    length = c.lengths[k]
    edges = _edges((0.5 if fold else 1.0) * length / dbar, bin_width)
    z = edges * dbar
    centre, radius = packing.positions[:, k], 0.5 * packing.diameters
    shifts = [0.0]
    if c.periodic[k]:
        reach = int(math.ceil(float(radius.max()) / length))
        shifts = [m * length for m in range(-reach, reach + 1)]

    def volume_between(z1, z2):
        return sum(float(slab_volume(centre + s, radius, z1, z2).sum()) for s in shifts)

    solid = np.array([volume_between(a, b) for a, b in zip(z[:-1], z[1:])])
    if fold:
        solid += np.array([volume_between(length - b, length - a) for a, b in zip(z[:-1], z[1:])])
    area = c.volume / length
    volume = area * np.diff(z) * (2.0 if fold else 1.0)
    return Profile("axial", k, bool(fold), edges, solid, volume, dbar)


def profile(packing: Packing, bin_width: float = DEFAULT_BIN_WIDTH) -> Profile | None:
    """The natural profile of a container: radial for a cylinder or a sphere, folded axial for a slab, axial along
    z for a closed box; None for a periodic box (no wall)."""
    c = packing.container
    if not c.has_walls or packing.dim != 3:
        return None
    if c.curved is not None:
        return radial_profile(packing, bin_width)
    return axial_profile(packing, None, bin_width, fold=True)


# --- the core ------------------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class Core:
    """The region at least ``distance`` mean diameters from every wall, and the solid fraction inside it."""

    distance: float  #: k, in mean diameters
    volume: float  #: the region's volume (0: empty)
    solid: float  #: the spheres' volume inside it
    fraction_of_container: float  #: the region's share of the container's volume

    @property
    def phi(self) -> float:
        return self.solid / self.volume if self.volume > 0 else math.nan


def core(packing: Packing, distance: float = DEFAULT_CORE_DISTANCE) -> Core:
    """phi in the core: the region at least ``distance`` mean diameters from every wall (NaN when the container has
    no such region), with exact sphere-region volumes. A periodic box is all core."""
    require(isinstance(distance, (int, float, np.floating)) and math.isfinite(distance) and distance >= 0,
            "core_distance", distance, "must be a finite number >= 0 (mean diameters)")
    c = packing.container
    total = packing.volume
    if not c.has_walls:
        solid = float(np.sum(ball_volume(packing.diameters, packing.dim)))
        return Core(float(distance), total, solid, 1.0)
    _container_3d(packing, "the core phi")
    w = float(distance) * packing.mean_diameter
    radius = 0.5 * packing.diameters
    lengths = np.asarray(c.lengths)
    lo = np.where(c.planes, w, -math.inf)
    hi = np.where(c.planes, lengths - w, math.inf)
    if np.any(hi <= lo):
        return Core(float(distance), 0.0, 0.0, 0.0)
    if c.curved == "sphere":
        rho = c.radius - w
        if rho <= 0:
            return Core(float(distance), 0.0, 0.0, 0.0)
        delta = np.linalg.norm(packing.positions - c.centre, axis=1)
        volume = 4.0 / 3.0 * math.pi * rho**3
        solid = float(lens_volume(radius, rho, delta).sum())
    elif c.curved == "cylinder":
        rho = c.radius - w
        if rho <= 0:
            return Core(float(distance), 0.0, 0.0, 0.0)
        p = packing.positions - c.centre
        perp = np.delete(p, c.axis, axis=1)
        delta = np.sqrt(np.einsum("ij,ij->i", perp, perp))
        t_lo, t_hi = lo[c.axis] - c.centre[c.axis], hi[c.axis] - c.centre[c.axis]
        height = np.ascontiguousarray(p[:, c.axis])
        solid = float(_cylinder_cumulative(delta, height, radius, np.array([rho]), t_lo, t_hi, _NODES, _WEIGHTS)[0])
        span = min(t_hi, lengths[c.axis] / 2) - max(t_lo, -lengths[c.axis] / 2)
        volume = math.pi * rho**2 * span
    else:
        walled = [k for k in range(3) if c.planes[k]]
        order = [k for k in range(3) if k != walled[-1]] + [walled[-1]]  # integrate along a walled axis
        x = np.ascontiguousarray(packing.positions[:, order])
        solid = float(_box_volumes(x, radius, np.ascontiguousarray(lo[order]), np.ascontiguousarray(hi[order]),
                                   _NODES, _WEIGHTS).sum())
        volume = float(np.prod(np.minimum(hi, lengths) - np.maximum(lo, 0.0)))
    return Core(float(distance), float(volume), solid, float(volume / total))
