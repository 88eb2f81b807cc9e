"""Contacts, rattlers, coordination number and isostaticity of a (nearly) jammed packing, in any dimension d.

A hard-sphere packing at finite reduced pressure p = PV/(N k_B T) has no exact contacts: a pair that is "in contact"
carries a small gap h_ij = r_ij / D_ij - 1 (relative to the contact distance D_ij = (D_i + D_j)/2 of the ACTUAL
diameters). Contacts are therefore the pairs with h_ij < g for a gap tolerance g that must fit the pressure.

**Tolerance rule** (:func:`choose_tolerance`). Near jamming the free-volume gap of a load-bearing contact is of order
1/p (a contact carrying force f has gap ~ <f>/(f p)), while the gaps of the closest non-contacts grow like
h^0.6 from 0 (Donev, Torquato & Stillinger, PRE 71, 011105 (2005)): the number of pairs with gap < g,
N(g), has a plateau between the two populations. We scan g on a log grid (4 points per decade) from 10/p up to
1e-3 and pick the grid point where N(g) is flattest, i.e. where the fewest gaps fall within half a decade either
side; ties go to the centre of the flattest stretch. At p = 1e12 this lands around 1e-9 ... 1e-7, consistent with
the reference code's 1e-7 (docs/algorithms.md §6.1). Without a pressure the scan starts at 1e-12.
:func:`tolerance_scan` gives the coordination over the whole grid, to show the plateau.

**Rattlers** (:func:`rattler_mask`, from :mod:`spherejam.core.rattlers`): a particle with fewer than
``min_contacts`` (default d + 1) contacts with non-rattlers is a rattler, recursively. The fixed point is the k-core
of the contact graph, k = d + 1, computed by peeling in O(N + K). By the rank rule of that module, a particle whose
contacts span only s < d dimensions needs s + 1 of them (a partial rattler: on a flat wall of a monodisperse
packing, three contacts within the wall layer); its d - s free directions, F in all, come off the isostatic count
(docs/containers.md §4). In a generic packing F = 0 and the rule is the k-core's.

**Isostaticity** (paper, Appendix E): the N' non-rattlers of a jammed periodic packing need at least
K_0 = d(N' - 1) + 1 contacts among themselves; a random jammed packing has exactly K_0, so Z = 2K'/N' -> 2d.

**Containers** (docs/containers_structure.md): a sphere whose relative gap to a wall, h_iw = dist_iw / r_i - 1
(dist_iw from its centre to the wall), is below the tolerance touches that wall, and each wall it touches is one
contact (a sphere in a box corner touches three). Wall gaps join the tolerance scan. A wall is never a rattler: its
contacts count toward a sphere's contacts in the k-core rule (``fixed`` of :func:`~spherejam.core.rattlers
.rattler_mask`). K and K' then count sphere-sphere and sphere-wall contacts, Z = (2 K_ss + K_sw) / N is the mean
number of contacts of a sphere, and K_0 is the container's own count, ``container.isostatic_contacts(N')`` (equal
to d(N' - 1) + 1 for the periodic box).
"""

from __future__ import annotations

import itertools
import math
from dataclasses import asdict, dataclass, field

import numpy as np

from ..core import neighbours
from ..core.errors import InputError, require
from ..core.packing import Packing
from ..core.rattlers import rattler_mask, spanned_dimensions

#: Largest gap examined by the tolerance scan (relative to D_ij).
MAX_SCAN_GAP = 1e-3
#: Smallest gap examined when the pressure is unknown (below this, float64 positions in a box of ~20 diameters
#: cannot resolve a gap reliably).
MIN_SCAN_GAP = 1e-12
#: Grid density of the tolerance scan (points per decade).
SCAN_POINTS_PER_DECADE = 4


def packing_pressure(packing: Packing, pressure: float | None = None) -> float | None:
    """The reduced pressure p to use: ``pressure`` if given, else ``metadata["reduced_pressure"]`` if finite > 0."""
    if pressure is None:
        pressure = packing.metadata.get("reduced_pressure")
        if pressure is None:
            return None
        try:
            pressure = float(pressure)
        except (TypeError, ValueError):
            return None
        return pressure if math.isfinite(pressure) and pressure > 0 else None
    pressure = float(pressure)
    require(math.isfinite(pressure) and pressure > 0, "pressure", pressure, "must be a finite number > 0")
    return pressure


def near_pairs(packing: Packing, max_gap: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """All pairs i < j with relative gap h_ij = r_ij/D_ij - 1 < ``max_gap`` (overlaps give h < 0), once per periodic
    image within reach: in a box smaller than two contact distances a pair may touch through several images.

    Returns ``(i, j, h)`` sorted by (i, j, h).
    """
    require(math.isfinite(max_gap) and max_gap > -1, "max_gap", max_gap, "must be a finite number > -1")
    i, j, h, _ = _near_pairs(packing, max_gap)
    return i, j, h


def _near_pairs(packing: Packing, max_gap: float):
    """:func:`near_pairs` and each image's separation vector: ``(i, j, h, vectors)``."""
    i, j, d = neighbours.pair_images(packing.positions, packing.diameters, packing.frame, 1.0 + max_gap)
    dij = 0.5 * (packing.diameters[i] + packing.diameters[j])
    return i, j, np.sqrt(np.einsum("ij,ij->i", d, d)) / dij - 1.0, d


def wall_directions(packing: Packing, wall_i: np.ndarray, wall: np.ndarray) -> np.ndarray:
    """(K, d): the unit normal of each sphere-wall contact (sphere ``wall_i``, wall ``wall`` numbered as in
    :func:`wall_gaps`), from the wall towards the sphere."""
    c, dim = packing.container, packing.dim
    out = np.zeros((len(wall_i), dim))
    plane = wall < 2 * dim
    out[plane, wall[plane] // 2] = np.where(wall[plane] % 2 == 0, 1.0, -1.0)
    if np.any(~plane):
        p = c.centre - packing.positions[wall_i[~plane]]  # inwards, from the curved wall towards the centre
        if c.curved == "cylinder":
            p[:, c.axis] = 0.0
        out[~plane] = p / np.linalg.norm(p, axis=1)[:, None]
    return out


def _rattlers(packing: Packing, i, j, vectors, wall_i, wall, k):
    """Rattlers by the rank rule (module docstring), walls as nodes that never peel, and F, the free directions of
    the partial rattlers."""
    n, dim = packing.n, packing.dim
    walls = n + 2 * dim + 1  # the wall numbers of wall_gaps after the spheres
    fixed = np.zeros(walls, dtype=np.int64)
    fixed[n:] = k
    pair_i, pair_j = np.concatenate([i, wall_i]), np.concatenate([j, n + wall])
    vec = np.concatenate([np.reshape(vectors, (-1, dim)), wall_directions(packing, wall_i, wall)])
    rattler = rattler_mask(walls, pair_i, pair_j, k, fixed, vec)
    live = ~rattler[pair_i] & ~rattler[pair_j]  # pair_i is always a sphere
    span = spanned_dimensions(n, np.concatenate([pair_i[live], pair_j[live][pair_j[live] < n]]),
                              np.concatenate([vec[live], vec[live][pair_j[live] < n]]))
    return rattler[:n], int(np.sum(dim - span[~rattler[:n]]))


def wall_gaps(packing: Packing) -> tuple[np.ndarray, np.ndarray]:
    """``(wall, h)``, each (N, W): the walls of the packing's container and the relative gap h_iw = dist_iw / r_i - 1
    of every sphere to each (W = 0 in a periodic box). Wall w is the plane x_k = 0 for w = 2k, x_k = L_k for
    w = 2k + 1 (walled axes only), and 2d for the curved wall; ``wall`` holds those numbers."""
    c = packing.container
    x, r = packing.positions, 0.5 * packing.diameters
    ids, dist = [], []
    for k in range(packing.dim):
        if c.planes[k]:
            ids += [2 * k, 2 * k + 1]
            dist += [x[:, k], c.lengths[k] - x[:, k]]
    if c.curved is not None:
        p = x - c.centre
        if c.curved == "cylinder":
            p = np.delete(p, c.axis, axis=1)
        ids.append(2 * packing.dim)
        dist.append(c.radius - np.sqrt(np.einsum("ij,ij->i", p, p)))
    if not ids:
        return np.empty((packing.n, 0), dtype=np.int64), np.empty((packing.n, 0))
    h = np.stack(dist, axis=1) / r[:, None] - 1.0
    return np.broadcast_to(np.asarray(ids, dtype=np.int64), h.shape).copy(), h


def wall_contacts(packing: Packing, tolerance: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Sphere-wall contacts: ``(i, wall, h)`` with h_iw < ``tolerance`` (:func:`wall_gaps`), sorted by (i, wall)."""
    wall, h = wall_gaps(packing)
    i, w = np.nonzero(h < tolerance)
    return i.astype(np.int64), wall[i, w], h[i, w]


def contact_pairs(packing: Packing, tolerance: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Contacts: pairs with gap h_ij < ``tolerance`` (relative to D_ij). Returns ``(i, j, h)``."""
    _check_tolerance(tolerance)
    return near_pairs(packing, tolerance)


def _check_tolerance(tolerance) -> None:
    require(
        isinstance(tolerance, (int, float, np.floating)) and math.isfinite(tolerance) and 0 < tolerance < 1,
        "contact_tolerance", tolerance, "must be a number with 0 < tolerance < 1 (relative gap)",
    )


def scan_grid(pressure: float | None) -> np.ndarray:
    """The log grid of tolerances scanned by :func:`choose_tolerance`: from 10/p (or 1e-12) to 1e-3."""
    lo = MIN_SCAN_GAP if pressure is None else 10.0 / pressure
    lo = min(max(lo, MIN_SCAN_GAP), MAX_SCAN_GAP / 10.0)  # an unjammed packing (p < 1e4) still gets a decade
    decades = math.log10(MAX_SCAN_GAP / lo)
    return np.logspace(math.log10(lo), math.log10(MAX_SCAN_GAP), round(decades * SCAN_POINTS_PER_DECADE) + 1)


def choose_tolerance(gaps: np.ndarray, pressure: float | None = None) -> float:
    """The contact tolerance g where N(g) = #{pairs with gap < g} is flattest (module docstring).

    ``gaps`` are the relative gaps h_ij of (at least) all pairs with h_ij < 1e-3 * sqrt(10).
    """
    grid = scan_grid(pressure)
    h = np.sort(np.asarray(gaps, dtype=np.float64))
    half = 10.0**0.5
    density = np.searchsorted(h, grid * half) - np.searchsorted(h, grid / half)
    flattest = density == density.min()
    # centre of the longest run of minimal density (on the log grid)
    best_len, best_mid, k = 0, 0, 0
    while k < len(grid):
        if flattest[k]:
            start = k
            while k < len(grid) and flattest[k]:
                k += 1
            if k - start > best_len:
                best_len, best_mid = k - start, (start + k - 1) / 2.0
        else:
            k += 1
    lo, hi = math.floor(best_mid), math.ceil(best_mid)
    return float(math.sqrt(grid[lo] * grid[hi]))


# --- coordination ----------------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class Coordination:
    """Contact statistics at one tolerance (all counts are of unordered pairs)."""

    contact_tolerance: float  #: gap tolerance g (relative to D_ij)
    n_contacts: int  #: K, contacts among all particles
    z_mean: float  #: 2K/N
    n_nonrattlers: int  #: N'
    n_contacts_nonrattler: int  #: K', contacts among non-rattlers
    z_nonrattler: float  #: 2K'/N' (NaN if N' = 0)
    rattler_fraction: float  #: 1 - N'/N
    isostatic_contacts: int  #: K_0 = d(N'-1) + 1, or the container's count (0 if N' = 0)
    isostatic_excess: int  #: K' - K_0
    #: 1 if K' == K_0 and N' > 0, else 0: a count at one gap tolerance, not a verdict on jamming (a few contacts
    #: open or close with the tolerance; CALiPPSO's ``is_isostatic`` certifies, docs/algorithms.md §6.3)
    isostatic_at_tolerance: int

    def as_dict(self) -> dict[str, float]:
        return {k: float(v) for k, v in asdict(self).items()}


def _coordination(n, dim, tolerance, pair_i, pair_j, rattler, container=None, wall_i=None, free=0) -> Coordination:
    keep = ~(rattler[pair_i] | rattler[pair_j])
    n_nr = int(n - np.count_nonzero(rattler))
    wall_i = np.empty(0, dtype=np.int64) if wall_i is None else wall_i
    k_wall, k_wall_nr = len(wall_i), int(np.count_nonzero(~rattler[wall_i]))
    k_nr = int(np.count_nonzero(keep)) + k_wall_nr
    if n_nr == 0:
        k0 = 0
    elif container is None:
        k0 = dim * (n_nr - 1) + 1 - free
    else:
        k0 = container.isostatic_contacts(n_nr, free)
    return Coordination(
        contact_tolerance=float(tolerance),
        n_contacts=len(pair_i) + k_wall,
        z_mean=(2.0 * len(pair_i) + k_wall) / n,
        n_nonrattlers=n_nr,
        n_contacts_nonrattler=k_nr,
        z_nonrattler=(2.0 * (k_nr - k_wall_nr) + k_wall_nr) / n_nr if n_nr else math.nan,
        rattler_fraction=1.0 - n_nr / n,
        isostatic_contacts=k0,
        isostatic_excess=k_nr - k0,
        isostatic_at_tolerance=int(n_nr > 0 and k_nr == k0),
    )


@dataclass(frozen=True)
class ContactAnalysis:
    """Contacts of a packing at the chosen tolerance, with the arrays figures need."""

    coordination: Coordination
    pair_i: np.ndarray  #: first particle of each contact (i < j)
    pair_j: np.ndarray  #: second particle
    gap: np.ndarray  #: relative gap h_ij of each contact
    rattler: np.ndarray  #: (N,) bool, True for rattlers
    contacts_per_particle: np.ndarray  #: (N,) int, contacts of each particle (all partners, walls included)
    pressure: float | None  #: reduced pressure used by the tolerance rule (None if unknown)
    wall_i: np.ndarray = field(default_factory=lambda: np.empty(0, dtype=np.int64))  #: sphere of each wall contact
    wall: np.ndarray = field(default_factory=lambda: np.empty(0, dtype=np.int64))  #: its wall (:func:`wall_gaps`)
    wall_gap: np.ndarray = field(default_factory=lambda: np.empty(0))  #: its relative gap h_iw


def analyze_contacts(
    packing: Packing,
    *,
    contact_tolerance: float | None = None,
    pressure: float | None = None,
    min_contacts: int | None = None,
) -> ContactAnalysis:
    """Contacts, rattlers and coordination of ``packing`` (ACTUAL diameters).

    ``contact_tolerance`` None -> :func:`choose_tolerance` with ``pressure`` (default: the packing's
    ``metadata["reduced_pressure"]``). ``min_contacts`` defaults to d + 1.
    """
    p = packing_pressure(packing, pressure)
    k = packing.dim + 1 if min_contacts is None else min_contacts
    container = packing.container if packing.container.has_walls else None
    if contact_tolerance is None:
        i, j, h, vec = _near_pairs(packing, MAX_SCAN_GAP * 10.0**0.5)
        _, hw = wall_gaps(packing)
        tol = choose_tolerance(np.concatenate([h, hw.ravel()]), p)
    else:
        _check_tolerance(contact_tolerance)
        tol = float(contact_tolerance)
        i, j, h, vec = _near_pairs(packing, tol)
    keep = h < tol
    i, j, h, vec = i[keep], j[keep], h[keep], vec[keep]
    wi, ww, wh = wall_contacts(packing, tol)
    walls = np.bincount(wi, minlength=packing.n)
    rattler, free = _rattlers(packing, i, j, vec, wi, ww, k)
    per_particle = np.bincount(i, minlength=packing.n) + np.bincount(j, minlength=packing.n) + walls
    return ContactAnalysis(
        coordination=_coordination(packing.n, packing.dim, tol, i, j, rattler, container, wi, free),
        pair_i=i, pair_j=j, gap=h, rattler=rattler, contacts_per_particle=per_particle, pressure=p,
        wall_i=wi, wall=ww, wall_gap=wh,
    )


def tolerance_scan(
    packing: Packing, tolerances: np.ndarray | None = None, *, pressure: float | None = None,
    min_contacts: int | None = None,
) -> dict[str, np.ndarray]:
    """Coordination over a range of tolerances (default: the grid of :func:`scan_grid`), to show the plateau.

    Returns arrays keyed like :class:`Coordination` fields, one entry per tolerance.
    """
    p = packing_pressure(packing, pressure)
    grid = scan_grid(p) if tolerances is None else np.asarray(tolerances, dtype=np.float64)
    if grid.ndim != 1 or len(grid) == 0:
        raise InputError(f"tolerances: shape {grid.shape}: must be a non-empty 1-d array")
    for g in grid:
        _check_tolerance(float(g))
    k = packing.dim + 1 if min_contacts is None else min_contacts
    container = packing.container if packing.container.has_walls else None
    i, j, h, vec = _near_pairs(packing, float(grid.max()))
    wi, ww, wh = wall_contacts(packing, float(grid.max()))
    rows = []
    for g in grid:
        keep = h < g
        ii, jj = i[keep], j[keep]
        wg = wi[wh < g]
        rattler, free = _rattlers(packing, ii, jj, vec[keep], wg, ww[wh < g], k)
        rows.append(_coordination(packing.n, packing.dim, g, ii, jj, rattler, container, wg, free))
    return {name: np.array([getattr(r, name) for r in rows]) for name in Coordination.__dataclass_fields__}


def brute_force_contacts(packing: Packing, tolerance: float):
    """O(N^2) reference for :func:`contact_pairs` over every periodic image, no cell list (tests)."""
    x, d, box = packing.positions, packing.diameters, packing.require_cube("brute_force_contacts")
    reach = math.ceil((1.0 + tolerance) * float(d.max()) / box) + 1
    ii, jj = np.triu_indices(packing.n, 1)
    dij = 0.5 * (d[ii] + d[jj])
    out = [], [], []
    for n in itertools.product(range(-reach, reach + 1), repeat=packing.dim):
        v = x[jj] + box * np.asarray(n, dtype=float) - x[ii]
        h = np.sqrt((v * v).sum(axis=1)) / dij - 1.0
        keep = h < tolerance
        for part, a in zip(out, (ii[keep], jj[keep], h[keep])):
            part.append(a)
    i, j, h = (np.concatenate(a) for a in out)
    key = np.lexsort((h, j, i))
    return i[key], j[key], h[key]
