"""Structural measures of a packing: Steinhardt Q6, crystalline fraction, radical Voronoi cells, g(r), pore-size
entropy; and :func:`analyze`, which gathers them with the contact statistics of
:mod:`spherejam.analysis.contacts` into flat scalars.

All lengths use the ACTUAL diameters; volumes and distances are reported in units of the mean diameter ā (so
every measure is invariant under a uniform rescaling of box and diameters). Q6 and Voronoi are defined for d = 3
only (NaN otherwise); contacts, g(r) and pore sizes work for d = 2..5.

**Voronoi tessellation.** Polydisperse packings need the radical (power, Laguerre) tessellation with weights
a_i^2/4. freud 3.4's ``locality.Voronoi`` takes no radii (ordinary Voronoi only, and works in float32), and the
maintained voro++ power-mode wrapper (pyvoro2) would be a new dependency, so we build the power diagram ourselves:
the regular triangulation is the lower convex hull of the lifted points (x_i, |x_i|^2 - a_i^2/4) in R^4 (qhull via
scipy, with periodic images in a shell around the box), and each cell volume is a signed sum over the flags
(i ⊂ ij ⊂ ijk ⊂ tetrahedron) of the simplices (x_i, c_ij, c_ijk, c_T) built from the power centres, in a numba
kernel. Non-overlapping spheres always lie inside their own power cell, so no cell is empty. The shell is widened
until every tetrahedron touching a particle in the box is certified by its orthosphere, and sum V_i = L^3 holds to
round-off.
"""

from __future__ import annotations

import itertools
import math
import time

import numpy as np
from numba import njit

from ..core import neighbours
from ..core.errors import InputError, SimulationError, require
from ..core.packing import Packing, ball_volume
from ..core.seeding import rng_for
from . import contacts as _contacts

#: Neighbour cutoff of the Steinhardt bond network: r_ij <= Q6_CUTOFF * D_ij (docs/algorithms.md §6.4, as in the
#: reference code).
Q6_CUTOFF = 1.2
#: Minimum volume of a cell around a sphere of diameter a: the regular dodecahedron circumscribing it, 0.694 a^3.
DODECAHEDRON_VOLUME = 0.6938
#: Pore-size entropy: threshold r_0 = ā/4 (mean radius R = ā/2, alpha = 2), S = alpha^2 ln P (docs/algorithms.md §6.5).
PORE_ALPHA = 2.0
PORE_MIN_SAMPLES = 10**7
PORE_CHECK_EVERY = 10**4
PORE_REL_CHANGE = 1e-3
PORE_MAX_SAMPLES = 10**8

#: Every scalar returned by :func:`analyze`: name -> (long_name, units). Units "1" = dimensionless (CF).
VARIABLES: dict[str, tuple[str, str]] = {
    "contact_tolerance": ("relative gap tolerance for contacts, h_ij = r_ij/D_ij - 1 < tolerance", "1"),
    "n_contacts": ("number of contacts among all particles", "1"),
    "z_mean": ("mean coordination number of all particles, 2K/N", "1"),
    "n_nonrattlers": ("number of non-rattlers N' ((d+1)-core of the contact graph)", "1"),
    "n_contacts_nonrattler": ("number of contacts among non-rattlers K'", "1"),
    "z_nonrattler": ("coordination number of non-rattlers, 2K'/N'", "1"),
    "rattler_fraction": ("fraction of rattlers, 1 - N'/N", "1"),
    "isostatic_contacts": ("isostatic contact number K_0 = d(N'-1)+1", "1"),
    "isostatic_excess": ("excess contacts over isostaticity, K' - K_0", "1"),
    "isostatic_at_tolerance": ("1 if K' == K_0 exactly at contact_tolerance, else 0: a contact count at one gap "
                               "tolerance, not a verdict on jamming (calippso_is_isostatic certifies)", "1"),
    "q6_global": ("global Steinhardt bond-orientational order Q6 (bonds r_ij <= 1.2 D_ij)", "1"),
    "q6_local": ("mean local Steinhardt q6 over particles with neighbours", "1"),
    "crystalline_fraction": ("fraction of crystalline particles (>= 7 bonds with normalised q6 dot product > 0.7)",
                             "1"),
    "voronoi_volume_mean": ("mean radical Voronoi cell volume in units of mean diameter cubed", "1"),
    "voronoi_volume_std": ("standard deviation of radical Voronoi cell volumes divided by their mean", "1"),
    "voronoi_k": ("shape k of the k-Gamma fit of Voronoi free volumes (Aste & Di Matteo)", "1"),
    "voronoi_entropy": ("differential entropy of the k-Gamma fit of Voronoi free volumes (units of mean diameter)",
                        "1"),
    "large_pore_fraction": ("fraction of random points farther than a/4 from every sphere surface", "1"),
    "pore_size_entropy": ("pore-size entropy S = 4 ln P (Baranau et al. 2013, alpha = 2)", "1"),
    "pore_samples": ("number of random points used for the pore-size entropy", "1"),
}


# --- Steinhardt order -----------------------------------------------------------------------------------------------


def _require_3d(packing: Packing, what: str) -> None:
    if packing.dim != 3:
        raise InputError(f"dimension d={packing.dim}: {what} is defined for d = 3 only")


def bond_network(packing: Packing, cutoff: float = Q6_CUTOFF):
    """Bonds of the Steinhardt network: pairs i < j with r_ij < ``cutoff`` * D_ij and their vectors, one per periodic
    image within reach (:func:`spherejam.core.neighbours.pair_images`)."""
    require(math.isfinite(cutoff) and cutoff > 0, "cutoff", cutoff, "must be a finite number > 0")
    return neighbours.pair_images(packing.positions, packing.diameters, packing.box, cutoff)


def steinhardt(packing: Packing, l: int = 6, cutoff: float = Q6_CUTOFF, bonds=None):  # noqa: E741 (degree l)
    """Steinhardt bond-orientational order of degree ``l`` (even), d = 3 (docs/algorithms.md §6.4).

    Returns ``(q_global, q_local, q_per_particle, n_neighbours)``: q_global from <Y_lm> over all bonds; q(i) from
    the bonds of i (NaN for particles without neighbours); q_local = mean of q(i) over particles with neighbours.
    ``bonds``: the output of :func:`bond_network` for this ``cutoff``, if already computed.
    """
    from scipy.special import sph_harm_y

    _require_3d(packing, "Steinhardt order")
    require(int(l) == l and l >= 2 and l % 2 == 0, "l", l, "must be an even integer >= 2")
    i, j, d = bond_network(packing, cutoff) if bonds is None else bonds
    n = packing.n
    nb = np.bincount(i, minlength=n) + np.bincount(j, minlength=n)
    if len(i) == 0:
        return math.nan, math.nan, np.full(n, math.nan), nb
    r = np.sqrt(np.einsum("ij,ij->i", d, d))
    polar = np.arccos(np.clip(d[:, 2] / r, -1.0, 1.0))
    azimuth = np.arctan2(d[:, 1], d[:, 0])
    # Y_l,-m = (-1)^m conj(Y_lm): |sums| for m < 0 equal those for m > 0, so use m = 0..l with weight 2 for m > 0;
    # Y_lm(-r) = Y_lm(r) for even l, so each pair counts once for i and once for j.
    glob = 0.0
    per = np.zeros(n)
    for m in range(l + 1):
        y = sph_harm_y(l, m, polar, azimuth)
        weight = 1.0 if m == 0 else 2.0
        re = np.bincount(i, y.real, n) + np.bincount(j, y.real, n)
        im = np.bincount(i, y.imag, n) + np.bincount(j, y.imag, n)
        with np.errstate(invalid="ignore", divide="ignore"):
            per += weight * (re * re + im * im) / (nb * nb)
        glob += weight * abs(y.sum() / len(y)) ** 2
    norm = 4.0 * math.pi / (2 * l + 1)
    q_i = np.sqrt(norm * per)
    q_i[nb == 0] = math.nan
    return math.sqrt(norm * glob), float(np.nanmean(q_i)), q_i, nb


#: Solid-like bond: normalised q6(i).q6*(j) > SOLID_BOND_THRESHOLD; a particle with >= SOLID_BONDS such bonds is
#: crystalline (ten Wolde, Ruiz-Montero and Frenkel 1996; the values used for hard spheres by Filion et al. 2010).
SOLID_BOND_THRESHOLD = 0.7
SOLID_BONDS = 7


def crystalline_fraction(packing: Packing, q_threshold: float = SOLID_BOND_THRESHOLD, solid_bonds: int = SOLID_BONDS,
                         cutoff: float = Q6_CUTOFF, bonds=None) -> tuple[float, float]:
    """Fraction of crystalline (solid-like) particles, and the largest crystalline cluster as a fraction of N.

    Bonds are those of :func:`bond_network` (r_ij <= ``cutoff`` * D_ij); the bond-orientational test is freud's
    ``order.SolidLiquid`` (l = 6, normalised q6m). A perfect FCC or HCP crystal gives (1, 1); jammed amorphous
    packings give a few per cent of scattered particles. Monodisperse MLS and slow LS runs can nucleate crystals
    (paper §IV.A), which this measure flags. ``bonds`` as in :func:`steinhardt`.
    """
    import freud

    _require_3d(packing, "the crystalline fraction")
    require(math.isfinite(q_threshold) and -1 <= q_threshold <= 1, "q_threshold", q_threshold, "must lie in [-1, 1]")
    require(int(solid_bonds) == solid_bonds and solid_bonds >= 1, "solid_bonds", solid_bonds,
            "must be an integer >= 1")
    i, j, d = bond_network(packing, cutoff) if bonds is None else bonds
    if len(i) == 0:
        return 0.0, 0.0
    query, point, vec = np.r_[i, j], np.r_[j, i], np.r_[d, -d]
    order = np.lexsort((point, query))
    nlist = freud.locality.NeighborList.from_arrays(packing.n, packing.n, query[order], point[order], vec[order])
    solid = freud.order.SolidLiquid(6, q_threshold, int(solid_bonds), normalize_q=True)
    solid.compute((freud.box.Box.cube(packing.box), packing.positions - packing.box / 2), neighbors=nlist)
    crystalline = np.asarray(solid.num_connections) >= solid_bonds
    if not crystalline.any():
        return 0.0, 0.0
    # freud clusters every particle (non-solid ones as singletons): the largest cluster of crystalline particles
    sizes = np.bincount(np.asarray(solid.cluster_idx)[crystalline])
    return float(crystalline.mean()), float(sizes.max() / packing.n)


# --- radical (power) Voronoi tessellation ---------------------------------------------------------------------


#: Widest shell of periodic images tried around the box, in box lengths (a box of a few spheres needs more than one).
MAX_SHELL = 3.0
_FLAG_ORDERS = np.array(list(itertools.permutations(range(3))), dtype=np.int64)


@njit(cache=True)
def _det3(a0, a1, a2, b0, b1, b2, c0, c1, c2):
    return a0 * (b1 * c2 - b2 * c1) - a1 * (b0 * c2 - b2 * c0) + a2 * (b0 * c1 - b1 * c0)


@njit(cache=True)
def _power_cell_volumes(points, weights, tets, n_orig, box, shell, max_weight, orders, volumes):
    """Accumulate power-cell volumes of the first n_orig points; return the number of uncertified tetrahedra.

    For tetrahedron T and vertex i, in the frame of x_i with e_b = x_b - x_i the power centre c solves
    e_b . c = beta_b = (|e_b|^2 + w_i - w_b)/2; c_ij, c_ijk are the power centres of the edge and face.
    Cell volume = sum over flags of sign(det(e_j, e_k, e_l)) det(c_ij, c_ijk, c_T)/6.
    A tetrahedron is certified when no point outside the replicated region [-shell, L+shell]^3 can have a
    smaller power at c_T than its vertices: dist(c_T, outside)^2 - max_weight >= |c_T|^2 - w_i.
    """
    e = np.empty((4, 3))
    beta = np.empty(4)
    other = np.empty(3, dtype=np.int64)
    bad = 0
    for t in range(tets.shape[0]):
        for a in range(4):
            i = tets[t, a]
            if i >= n_orig:
                continue
            for b in range(4):
                q = tets[t, b]
                s = 0.0
                for k in range(3):
                    e[b, k] = points[q, k] - points[i, k]
                    s += e[b, k] * e[b, k]
                beta[b] = 0.5 * (s + weights[i] - weights[q])
            c = 0
            for b in range(4):
                if b != a:
                    other[c] = b
                    c += 1
            o0, o1, o2 = other[0], other[1], other[2]
            det = _det3(e[o0, 0], e[o0, 1], e[o0, 2], e[o1, 0], e[o1, 1], e[o1, 2], e[o2, 0], e[o2, 1], e[o2, 2])
            if det == 0.0:
                continue  # flat tetrahedron of a degenerate (cospherical) configuration: no volume
            # Cramer's rule: c_T = (beta0 (e1 x e2) + beta1 (e2 x e0) + beta2 (e0 x e1)) / det
            ct = np.empty(3)
            for k in range(3):
                k1 = (k + 1) % 3
                k2 = (k + 2) % 3
                ct[k] = (
                    beta[o0] * (e[o1, k1] * e[o2, k2] - e[o1, k2] * e[o2, k1])
                    + beta[o1] * (e[o2, k1] * e[o0, k2] - e[o2, k2] * e[o0, k1])
                    + beta[o2] * (e[o0, k1] * e[o1, k2] - e[o0, k2] * e[o1, k1])
                ) / det
            power = ct[0] * ct[0] + ct[1] * ct[1] + ct[2] * ct[2] - weights[i]
            reach = np.inf
            for k in range(3):
                x = points[i, k] + ct[k]
                reach = min(reach, x + shell, box + shell - x)
            if reach <= 0.0 or reach * reach - max_weight < power:
                bad += 1
            acc = 0.0
            for p in range(orders.shape[0]):
                j = other[orders[p, 0]]
                kk = other[orders[p, 1]]
                ll = other[orders[p, 2]]
                jj = e[j, 0] * e[j, 0] + e[j, 1] * e[j, 1] + e[j, 2] * e[j, 2]
                ss = e[kk, 0] * e[kk, 0] + e[kk, 1] * e[kk, 1] + e[kk, 2] * e[kk, 2]
                jk = e[j, 0] * e[kk, 0] + e[j, 1] * e[kk, 1] + e[j, 2] * e[kk, 2]
                s1 = beta[j] / jj
                gram = jj * ss - jk * jk
                s2 = (beta[j] * ss - beta[kk] * jk) / gram
                t2 = (beta[kk] * jj - beta[j] * jk) / gram
                vol = _det3(
                    s1 * e[j, 0], s1 * e[j, 1], s1 * e[j, 2],
                    s2 * e[j, 0] + t2 * e[kk, 0], s2 * e[j, 1] + t2 * e[kk, 1], s2 * e[j, 2] + t2 * e[kk, 2],
                    ct[0], ct[1], ct[2],
                )
                orient = _det3(e[j, 0], e[j, 1], e[j, 2], e[kk, 0], e[kk, 1], e[kk, 2], e[ll, 0], e[ll, 1], e[ll, 2])
                acc += vol if orient > 0.0 else -vol
            volumes[i] += acc / 6.0
    return bad


def _periodic_shell(positions, weights, box, shell):
    """Positions and weights with the periodic images that fall within ``shell`` of the box (any shell: a small
    box needs images beyond its neighbours)."""
    pts, wts = [positions], [weights]
    reach = math.ceil(shell / box)
    for shift in itertools.product(range(-reach, reach + 1), repeat=3):
        if shift == (0, 0, 0):
            continue
        y = positions + box * np.asarray(shift, dtype=np.float64)
        keep = np.all((y > -shell) & (y < box + shell), axis=1)
        pts.append(y[keep])
        wts.append(weights[keep])
    return np.concatenate(pts), np.concatenate(wts)


def voronoi_volumes(packing: Packing, radical: bool = True) -> np.ndarray:
    """Cell volumes (N,) of the periodic radical (power) Voronoi tessellation, weights a_i^2/4; d = 3.

    ``radical=False`` gives the ordinary Voronoi tessellation (equal weights). Volumes are in the packing's
    length unit cubed and sum to L^3.
    """
    from scipy.spatial import ConvexHull

    _require_3d(packing, "the Voronoi tessellation")
    # In units of the box side: qhull's tolerances are absolute, and the lifted coordinate |x|^2 of a box of 1e20
    # would swamp the others (a "not full dimensional" error); the volumes are scaled back at the end.
    n, unit, box = packing.n, packing.box, 1.0
    positions, diameters = packing.positions / unit, packing.diameters / unit
    weights = 0.25 * diameters**2 if radical else np.zeros(n)
    spacing = (box**3 / n) ** (1.0 / 3.0)
    shell = min(2.0 * spacing + float(diameters.max()), MAX_SHELL * box)
    while True:
        pts, wts = _periodic_shell(positions, weights, box, shell)
        lifted = np.column_stack([pts, np.einsum("ij,ij->i", pts, pts) - wts])
        hull = ConvexHull(lifted)
        lower = hull.equations[:, 3] < 0.0  # outward normal pointing down: a regular tetrahedron
        tets = hull.simplices[lower]
        tets = np.ascontiguousarray(tets[(tets < n).any(axis=1)], dtype=np.int64)
        volumes = np.zeros(n)
        bad = _power_cell_volumes(pts, wts, tets, n, box, shell, float(wts.max()), _FLAG_ORDERS, volumes)
        if bad == 0:
            break
        if shell >= MAX_SHELL * box:
            raise SimulationError(f"Voronoi: {bad} tetrahedra not certified even with a shell of {MAX_SHELL} box sides")
        shell = min(2.0 * shell, MAX_SHELL * box)
    total = volumes.sum()
    if not (np.all(volumes > 0) and abs(total / box**3 - 1.0) < 1e-8):
        raise SimulationError(
            f"Voronoi: cell volumes sum to {total:.12g} L^3, not L^3 (or a cell is empty); overlapping spheres?"
        )
    return volumes * unit**3


def voronoi_statistics(volumes: np.ndarray, diameters: np.ndarray) -> dict[str, float]:
    """Normalised std and k-Gamma entropy of cell volumes (docs/algorithms.md §6.6), volumes in units of ā^3.

    Free volume of a cell: V_i - V_min,i with V_min,i = 0.694 a_i^3 (the dodecahedron circumscribing sphere i;
    for sigma = 0 this is the spec's V_min; for sigma > 0 it is our per-particle extension). k-Gamma fit by
    moments: k = <V - V_min>^2 / var(V - V_min), theta = <V - V_min>/k; entropy
    H = k + ln(theta) + ln Gamma(k) + (1 - k) psi(k).
    """
    from scipy.special import digamma, gammaln

    abar = float(np.mean(diameters))
    v = np.asarray(volumes, dtype=np.float64) / abar**3
    free = v - DODECAHEDRON_VOLUME * (np.asarray(diameters) / abar) ** 3
    mean_free, var_free = float(free.mean()), float(free.var())
    if mean_free > 0 and math.sqrt(var_free) > 1e-12 * mean_free:  # else a perfect crystal (round-off spread)
        k = mean_free**2 / var_free
        theta = mean_free / k
        entropy = float(k + math.log(theta) + gammaln(k) + (1.0 - k) * digamma(k))
    else:
        k, entropy = math.inf, -math.inf
    return {
        "voronoi_volume_mean": float(v.mean()),
        "voronoi_volume_std": float(v.std() / v.mean()),
        "voronoi_k": float(k),
        "voronoi_entropy": entropy,
    }


# --- pair correlation ----------------------------------------------------------------------------------------------


def pair_correlation(packing: Packing, r_max: float = 5.0, bins: int = 500) -> tuple[np.ndarray, np.ndarray]:
    """Radial distribution g(r), any d; r in units of the mean diameter ā, up to min(``r_max``, L/2ā).

    Returns ``(r_centres, g)``, normalised so that g -> 1 for an ideal gas of N points: g = counts /
    (N (N - 1)/(2 V) * shell volume).
    """
    require(math.isfinite(r_max) and r_max > 0, "r_max", r_max, "must be a finite number > 0")
    require(int(bins) == bins and bins >= 1, "bins", bins, "must be an integer >= 1")
    abar = packing.mean_diameter
    r_cut = min(r_max * abar, 0.5 * packing.box)
    unit = np.full(packing.n, r_cut)
    _, _, r = neighbours.pairs_within(packing.positions, unit, packing.box, 1.0)
    edges = np.linspace(0.0, r_cut, int(bins) + 1)
    counts = np.histogram(r, bins=edges)[0]
    shell = np.diff(ball_volume(2.0 * edges, packing.dim))
    ideal = 0.5 * packing.n * (packing.n - 1) / packing.volume * shell
    return 0.5 * (edges[1:] + edges[:-1]) / abar, counts / ideal


# --- pore-size entropy -----------------------------------------------------------------------------------------------


@njit(cache=True)
def _covered_voxels(positions, reach, box, g):
    """(g^3,) uint8 grid, 1 for voxels lying entirely inside one fattened sphere |y - x_i| < reach[i] (d = 3).

    Most random points fall in such voxels and are classified in O(1); only the rest need the exact test.
    """
    h = box / g
    half_diagonal = 0.5 * math.sqrt(3.0) * h
    covered = np.zeros(g * g * g, dtype=np.uint8)
    for i in range(positions.shape[0]):
        r_in = reach[i] - half_diagonal  # voxel centre within r_in => whole voxel within reach
        if r_in <= 0.0:
            continue
        x0, x1, x2 = positions[i, 0], positions[i, 1], positions[i, 2]
        for a in range(math.floor((x0 - r_in) / h), math.floor((x0 + r_in) / h) + 1):
            d0 = (a + 0.5) * h - x0
            for b in range(math.floor((x1 - r_in) / h), math.floor((x1 + r_in) / h) + 1):
                d1 = (b + 0.5) * h - x1
                for c in range(math.floor((x2 - r_in) / h), math.floor((x2 + r_in) / h) + 1):
                    d2 = (c + 0.5) * h - x2
                    if d0 * d0 + d1 * d1 + d2 * d2 <= r_in * r_in:
                        covered[((a % g) * g + (b % g)) * g + (c % g)] = 1
    return covered


@njit(cache=True)
def _uncovered(samples, positions, reach, box, m, visit, cell, start, order, covered, g, out):
    """out[s] = 1 if sample s lies at least reach[i] from every centre i (minimum image), else 0.

    ``covered`` (g^3 voxels, d = 3; g = 0 disables it) short-cuts points inside a fully covered voxel.
    ``visit`` lists the entries of the cell stencil in scan order, best the own cell first (the likeliest to hold a
    covering sphere).
    """
    ns, dim = samples.shape
    noff = visit.shape[0]
    coords = np.empty(dim, dtype=np.int64)
    shift = np.empty(dim)  # unused: differences are folded to the minimum image
    for s in range(ns):
        if g > 0:
            v = 0
            for k in range(3):
                v = v * g + math.floor(samples[s, k] / box * g) % g
            if covered[v]:
                out[s] = 0
                continue
        for k in range(dim):
            coords[k] = neighbours.axis_cell(samples[s, k], box, m)
        free = 1
        for o in range(noff):
            cj = neighbours.stencil_cell(coords, visit[o], 1, m, box, shift)
            for idx in range(start[cj], start[cj + 1]):
                i = order[idx]
                r2 = 0.0
                for k in range(dim):
                    dx = neighbours.minimum_image(samples[s, k] - positions[i, k], box)
                    r2 += dx * dx
                if r2 < reach[i] * reach[i]:
                    free = 0
                    break
            if free == 0:
                break
        out[s] = free


def pore_size_entropy(
    packing: Packing, *, seed: int = 0, samples: int | None = None, min_samples: int = PORE_MIN_SAMPLES,
) -> tuple[float, float, int]:
    """Pore-size entropy S = alpha^2 ln P, alpha = 2 (docs/algorithms.md §6.5; Baranau et al., Soft Matter 9, 3361
    (2013)).

    P is the fraction of uniform random points y whose pore radius r(y) = min_i(|y - x_i| - a_i/2) exceeds ā/4.
    Points are drawn in chunks of 10^6 from the stream of ``seed`` (in box units, so the estimate is identical
    for a uniformly rescaled packing). With ``samples`` None the reference rule applies: check every 10^4 points
    and stop once at least ``min_samples`` were drawn and S changed by < 1e-3 (relative) since the last check.
    Returns ``(S, P, number of points)``; S = -inf if no large pore was found.
    """
    if samples is not None:
        require(int(samples) == samples and samples >= 1, "pore_samples", samples, "must be an integer >= 1")
    require(int(min_samples) == min_samples and min_samples >= 1, "min_samples", min_samples,
            "must be an integer >= 1")
    n, dim, box = packing.n, packing.dim, packing.box
    threshold = packing.mean_diameter / (2.0 * PORE_ALPHA)
    reach = 0.5 * packing.diameters + threshold
    m = neighbours.cells_per_side(box, float(reach.max()), dim, n)
    visit = np.argsort(np.abs(neighbours.neighbour_offsets(dim, m)).sum(axis=1), kind="stable")  # own cell first
    cell, start, order = neighbours.cell_sort(packing.positions, box, m)
    if dim == 3:  # voxels of side ~ min reach / 6, at most 256^3 of them
        g = int(min(256, max(1, math.ceil(6.0 * box / float(reach.min())))))
        covered = _covered_voxels(packing.positions, reach, box, g)
    else:
        g, covered = 0, np.zeros(1, dtype=np.uint8)
    rng = rng_for(seed)
    chunk = 100 * PORE_CHECK_EVERY
    target = int(samples) if samples is not None else PORE_MAX_SAMPLES
    drawn, found, previous = 0, 0, None
    while drawn < target:
        size = min(chunk, target - drawn)
        y = rng.random((size, dim)) * box
        hits = np.empty(size, dtype=np.uint8)
        _uncovered(y, packing.positions, reach, box, m, visit, cell, start, order, covered, g, hits)
        if samples is not None:
            found += int(hits.sum())
            drawn += size
            continue
        # the stopping rule, evaluated at every multiple of PORE_CHECK_EVERY
        cum = found + np.cumsum(hits.reshape(-1, PORE_CHECK_EVERY).sum(axis=1, dtype=np.int64))
        n_at = drawn + PORE_CHECK_EVERY * np.arange(1, len(cum) + 1)
        with np.errstate(divide="ignore"):
            s_at = PORE_ALPHA**2 * np.log(cum / n_at)
        for k in range(len(cum)):
            if previous is not None and n_at[k] >= min_samples and math.isfinite(s_at[k]) and abs(
                    s_at[k] - previous) < PORE_REL_CHANGE * abs(previous):
                p = float(cum[k] / n_at[k])
                return float(s_at[k]), p, int(n_at[k])
            previous = s_at[k] if math.isfinite(s_at[k]) else None
            if n_at[k] >= min_samples and cum[k] == 0:
                return -math.inf, 0.0, int(n_at[k])  # no large pore at all (e.g. a dense crystal)
        found = int(cum[-1])
        drawn += size
    p = found / drawn
    return (PORE_ALPHA**2 * math.log(p) if p > 0 else -math.inf), p, drawn


# --- everything ----------------------------------------------------------------------------------------------------


def analyze(
    packing: Packing,
    *,
    pressure: float | None = None,
    contact_tolerance: float | None = None,
    seed: int = 0,
    pore_samples: int | None = None,
    timings: dict[str, float] | None = None,
) -> dict[str, float]:
    """All structural measures of ``packing`` as flat scalars named as in :data:`VARIABLES`.

    ``pressure`` (default: ``metadata["reduced_pressure"]``) sets the contact tolerance rule unless
    ``contact_tolerance`` is given (see :mod:`spherejam.analysis.contacts`); ``seed`` and ``pore_samples`` control the
    pore-size sampling (None: the reference convergence rule, >= 10^7 points). Q6 and Voronoi measures are NaN
    for d != 3. ``timings``, if given, receives the wall time of each part in seconds.
    """
    clock = {} if timings is None else timings
    t0 = time.perf_counter()
    out = _contacts.analyze_contacts(packing, contact_tolerance=contact_tolerance, pressure=pressure)
    result = out.coordination.as_dict()
    t1 = time.perf_counter()
    clock["contacts"] = t1 - t0
    if packing.dim == 3:
        bonds = bond_network(packing)
        q_global, q_local, _, _ = steinhardt(packing, 6, bonds=bonds)
        crystalline, _ = crystalline_fraction(packing, bonds=bonds)
        t2 = time.perf_counter()
        clock["q6"] = t2 - t1
        result.update(voronoi_statistics(voronoi_volumes(packing), packing.diameters))
        t3 = time.perf_counter()
        clock["voronoi"] = t3 - t2
    else:
        q_global = q_local = crystalline = math.nan
        result.update({k: math.nan for k in ("voronoi_volume_mean", "voronoi_volume_std", "voronoi_k",
                                             "voronoi_entropy")})
        t3 = time.perf_counter()
    result["q6_global"], result["q6_local"] = float(q_global), float(q_local)
    result["crystalline_fraction"] = float(crystalline)
    s, p, used = pore_size_entropy(packing, seed=seed, samples=pore_samples)
    result.update(pore_size_entropy=s, large_pore_fraction=p, pore_samples=float(used))
    clock["pore_size_entropy"] = time.perf_counter() - t3
    missing = set(VARIABLES) ^ set(result)
    assert not missing, f"analyze and VARIABLES disagree on {sorted(missing)}"
    return {k: result[k] for k in VARIABLES}
