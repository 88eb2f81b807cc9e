"""Radical (power, Laguerre) Voronoi tessellation of a periodic packing (d = 3) and the statistics of its cell
volumes.

Polydisperse packings need the radical tessellation with weights a_i^2/4. freud 3.4's ``locality.Voronoi`` takes no
radii (ordinary Voronoi only, and works in float32), and the maintained voro++ power-mode wrapper (pyvoro2) would be a
new dependency, so we build the power diagram ourselves: the regular triangulation is the lower convex hull of the
lifted points (x_i, |x_i|^2 - a_i^2/4) in R^4 (qhull via scipy, with periodic images in a shell around the box), and
each cell volume is a signed sum over the flags (i ⊂ ij ⊂ ijk ⊂ tetrahedron) of the simplices (x_i, c_ij, c_ijk, c_T)
built from the power centres, in a numba kernel. Non-overlapping spheres always lie inside their own power cell, so no
cell is empty. The shell is widened until every tetrahedron touching a particle in the box is certified by its
orthosphere, and sum V_i = L^3 holds to round-off.
"""

from __future__ import annotations

import itertools
import math

import numpy as np
from numba import njit

from ..core.errors import SimulationError, require
from ..core.packing import Packing

#: Minimum volume of a cell around a sphere of diameter a: the regular dodecahedron circumscribing it, 0.694 a^3.
DODECAHEDRON_VOLUME = 0.6938
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

    require(packing.dim == 3, "dimension d", packing.dim, "the Voronoi tessellation is defined for d = 3 only")
    # In units of the box side: qhull's tolerances are absolute, and the lifted coordinate |x|^2 of a box of 1e20
    # would swamp the others (a "not full dimensional" error); the volumes are scaled back at the end.
    n, unit, box = packing.n, packing.require_cube("the Voronoi tessellation"), 1.0
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

