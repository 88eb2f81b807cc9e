"""The force-biased engine's numba kernels: the Verlet-list build, the forces (pairs and walls) and the move of one
iteration (the rules are in :mod:`spherejam.engines.force_biased`).

Frame and walls (docs/algorithms.md §4.6): the kernels run in a container's frame of edges ``lengths``; a difference
folds (``fold``, one minimum-image fold) along periodic axes only (``half`` = L_k/2 there, +inf along a walled axis),
and the cell stencils end at the walls (:func:`~spherejam.core.neighbours.stencil_cell` gives -1 beyond them).
``walls`` is :meth:`~spherejam.core.container.Container.wall_array`; the wall terms sit behind one loop-invariant test
(``has_walls``), so that the periodic cube runs the same operations as before containers.
"""

from __future__ import annotations

import numpy as np
from numba import njit, types
from numba.extending import overload

from ...core.neighbours import cell_sort, fold, image_span, image_vector, stencil_cell, stencil_size, unravel_cell

#: The curved-wall code of a cylinder in ``walls[3]`` (core.container.CYLINDER).
_CYLINDER = 1.0


def _along(x, a):
    """x[a] of a per-axis array, or x itself for a scalar (the same along every axis)."""
    return x if np.isscalar(x) else x[a]


@overload(_along, inline="always")
def _along_overload(x, a):
    if isinstance(x, types.Float):
        return lambda x, a: x
    return lambda x, a: x[a]


@njit(cache=True, inline="always")
def _scan_cell(ps, ds, order, begin, end, a, i, shift, wrap, lengths, half, rho_out, skin, pairs, count):
    """Append to ``pairs`` the pairs of sphere a (index i) with the spheres begin..end-1 of one cell, kept if sphere
    a is the larger one (ties: the lower index); False if ``pairs`` is full."""
    dim = ps.shape[1]
    di = ds[a]
    cap = pairs.shape[1]
    for b in range(begin, end):
        dj = ds[b]
        j = order[b]
        if dj > di or (dj == di and j <= i):
            continue
        r2 = 0.0
        for q in range(dim):
            dx = ps[b, q] + shift[q] - ps[a, q]
            if wrap:
                dx = fold(dx, lengths[q], half[q])
            r2 += dx * dx
        cut = rho_out * 0.5 * (di + dj) + skin
        if r2 < cut * cut:
            k = count[0]
            if k == cap:
                return False
            pairs[0, k] = min(i, j)
            pairs[1, k] = max(i, j)
            count[0] = k + 1
    return True


@njit(cache=True)
def build_verlet(positions, diameters, lengths, half, periodic, rho_out, skin, ms, capacity):
    """CSR half list (row i holds j > i, ascending) of all pairs with r_ij < rho_out D_ij + skin (minimum image
    along the periodic axes of the frame; none through a wall).

    Each pair is found from its larger sphere, which scans the cells within rho_out D_i + skin. Cells (``ms`` per
    axis) are sized for typical spheres, which scan the 3^d adjacent cells (cell by cell, so the periodic image of
    a neighbour cell is a known shift); the few larger spheres of a polydisperse packing scan a wider stencil.
    Returns empty arrays if more than ``capacity`` pairs are found (retry with a larger one).
    """
    n, dim = positions.shape
    side = lengths[0] / ms[0]  # the narrowest cell side sets the stencils' half-widths
    ncells = 1
    adjacent = True  # every axis has >= 3 cells: a one-cell stencil never wraps onto itself
    for k in range(dim):
        side = min(side, lengths[k] / ms[k])
        ncells *= ms[k]
        adjacent = adjacent and ms[k] >= 3
    cell, start, order = cell_sort(positions, lengths, ms)
    ps = np.empty((n, dim))  # positions and diameters in cell order, for locality
    ds = np.empty(n)
    stencil = np.empty(n, dtype=np.int64)  # half-width of each sphere's stencil, in cells
    for a in range(n):
        for q in range(dim):
            ps[a, q] = positions[order[a], q]
        ds[a] = diameters[order[a]]
        stencil[a] = int(np.ceil((rho_out * ds[a] + skin) / side))
    pairs = np.empty((2, capacity), dtype=np.int64)  # appended in scan order: sequential writes
    count = np.zeros(1, dtype=np.int64)
    coords = np.empty(dim, dtype=np.int64)
    shift = np.empty(dim)
    failed = (np.empty(0, dtype=np.int64), np.empty(0, dtype=np.int64))
    # spheres with a one-cell stencil, cell pair by cell pair
    if adjacent:
        for c in range(ncells):
            unravel_cell(c, ms, coords)
            for o in range(stencil_size(1, ms)):
                cn = stencil_cell(coords, o, 1, ms, lengths, periodic, shift)
                if cn < 0:  # beyond a wall
                    continue
                for a in range(start[c], start[c + 1]):
                    if stencil[a] == 1 and not _scan_cell(ps, ds, order, start[cn], start[cn + 1], a, order[a],
                                                          shift, False, lengths, half, rho_out, skin, pairs, count):
                        return failed
    # the others, sphere by sphere over a (2w+1)^d stencil; along an axis where it wraps onto itself it scans every
    # cell once, unshifted, and each difference is folded
    for a in range(n):
        w = stencil[a]
        if w == 1 and adjacent:
            continue
        wrap = False
        for k in range(dim):
            wrap = wrap or 2 * w + 1 > ms[k]
        unravel_cell(cell[order[a]], ms, coords)
        for o in range(stencil_size(w, ms)):
            cn = stencil_cell(coords, o, w, ms, lengths, periodic, shift)
            if cn < 0:
                continue
            if not _scan_cell(ps, ds, order, start[cn], start[cn + 1], a, order[a], shift, wrap, lengths, half,
                              rho_out, skin, pairs, count):
                return failed
    # CSR by the lower index, each row sorted: the force sums then do not depend on when or how the list was built
    k = count[0]
    row = np.zeros(n + 1, dtype=np.int64)
    for p in range(k):
        row[pairs[0, p] + 1] += 1
    for i in range(n):
        row[i + 1] += row[i]
    fill = row[:-1].copy()
    nbr = np.empty(k, dtype=np.int64)
    for p in range(k):
        i = pairs[0, p]
        nbr[fill[i]] = pairs[1, p]
        fill[i] += 1
    for i in range(n):
        for p in range(row[i] + 1, row[i + 1]):
            v = nbr[p]
            q = p - 1
            while q >= row[i] and nbr[q] > v:
                nbr[q + 1] = nbr[q]
                q -= 1
            nbr[q + 1] = v
    return row, nbr


@njit(cache=True)
def forces(positions, diameters, lengths, half, periodic, rho_out, nbr_start, nbr, forces, dx, multi):
    """Bezrukov forces of the pairs whose outer spheres overlap; returns min r_ij / D_ij over the list.

    ``multi``: an outer sphere may reach several images of a listed neighbour (rho_out D_ij > L_k/2 along a
    periodic axis); each adds its force (the minimum image is the closest, so the returned minimum is unchanged).
    """
    cube = True
    for a in range(positions.shape[1]):
        cube = cube and periodic[a] and lengths[a] == lengths[0]
    if cube:
        # one scalar period: the pair loop reads no frame array (an array would be reloaded after every store to
        # ``forces``, which numba cannot prove apart from it: 5 % slower at N = 10^4)
        return _pair_forces(positions, diameters, lengths[0], half[0], lengths, periodic, rho_out, nbr_start, nbr,
                            forces, dx, multi)
    return _pair_forces(positions, diameters, lengths, half, lengths, periodic, rho_out, nbr_start, nbr, forces, dx,
                        multi)


@njit(cache=True, inline="always")
def _pair_forces(positions, diameters, period, half, lengths, periodic, rho_out, nbr_start, nbr, forces, dx, multi):
    """The loop of :func:`forces`; ``period`` and ``half`` are per-axis arrays, or scalars in a periodic cube (a
    second compiled version of the same loop)."""
    n, dim = positions.shape
    forces[:, :] = 0.0
    rho2 = rho_out * rho_out
    hmin2 = np.inf
    for i in range(n):
        di = diameters[i]
        for p in range(nbr_start[i], nbr_start[i + 1]):
            j = nbr[p]
            r2 = 0.0
            for a in range(dim):
                dx[a] = fold(positions[i, a] - positions[j, a], _along(period, a), _along(half, a))
                r2 += dx[a] * dx[a]
            dij = 0.5 * (di + diameters[j])
            h2 = r2 / (dij * dij)
            hmin2 = min(hmin2, h2)
            if h2 < rho2 and r2 > 0.0:
                f = di * diameters[j] * (1.0 - h2 / rho2) / np.sqrt(r2)
                for a in range(dim):
                    forces[i, a] += f * dx[a]
                    forces[j, a] -= f * dx[a]
            if multi:
                _image_forces(i, j, di * diameters[j], dij, rho2, lengths, periodic, dx, forces)
    return np.sqrt(hmin2)


@njit(cache=True, inline="always")
def _image_forces(i, j, dd, dij, rho2, lengths, periodic, dx, forces):
    """Add the forces of the images of j other than the minimum one (x_i - x_j = ``dx``) within rho_out D_ij."""
    dim = dx.shape[0]
    lo = np.empty(dim, dtype=np.int64)
    span = np.empty(dim, dtype=np.int64)
    e = np.empty(dim)
    for code in range(image_span(dx, np.sqrt(rho2) * dij, lengths, periodic, lo, span)):
        r2, zero = image_vector(code, dx, lengths, lo, span, e)
        h2 = r2 / (dij * dij)
        if zero or not h2 < rho2:
            continue
        f = dd * (1.0 - h2 / rho2) / np.sqrt(r2)
        for a in range(dim):
            forces[i, a] += f * e[a]
            forces[j, a] -= f * e[a]


@njit(cache=True)
def pair_ratio(positions, diameters, lengths, half, i, j):
    """r_ij / D_ij, computed with the same operations as in :func:`forces`."""
    r2 = 0.0
    for a in range(positions.shape[1]):
        dx = fold(positions[i, a] - positions[j, a], lengths[a], half[a])
        r2 += dx * dx
    dij = 0.5 * (diameters[i] + diameters[j])
    return np.sqrt(r2 / (dij * dij))


# --- walls (docs/algorithms.md §4.6) ----------------------------------------------------------------------------


@njit(cache=True, inline="always")
def _curved_offset(positions, i, walls, p):
    """Offset p of centre i from the curved wall's axis (a cylinder: the components across it) or centre (a
    sphere), into ``p`` (3,); returns |p|."""
    p2 = 0.0
    for k in range(3):
        p[k] = positions[i, k] - walls[5 + k]
    if walls[3] == _CYLINDER:
        p[int(walls[4])] = 0.0
    for k in range(3):
        p2 += p[k] * p[k]
    return np.sqrt(p2)


@njit(cache=True, inline="always")
def _wall_push(forces, i, a, sign, di, h, rho2):
    """The mirror-image force on sphere i of diameter di at distance h from a plane wall across axis a, into the
    container (``sign`` +1: the wall x_a = 0, -1: the wall x_a = L_a); returns the wall ratio 2 h / D_i."""
    hw = 2.0 * h / di
    h2 = hw * hw
    if h2 < rho2:
        forces[i, a] += sign * di * di * (1.0 - h2 / rho2)
    return hw


@njit(cache=True)
def wall_forces(positions, diameters, lengths, walls, rho_out, forces):
    """Add the forces of the walls to ``forces``; returns min over spheres and walls of 2 h_i / D_i (h_i: the
    distance of centre i to the wall; inf without walls).

    A wall acts on sphere i as its mirror image i' across the wall (for a curved wall, across the tangent plane at
    the nearest point), a sphere of the same diameter at distance 2 h_i: the pair force D_i^2 (1 - (2 h_i / (rho_out
    D_i))^2) along the wall's inward normal, whenever 2 h_i < rho_out D_i (the outer sphere crosses the wall). The
    ratio 2 h_i / D_i is the pair ratio r_ii' / D_ii' of the same mirror pair, so the inner ratio counts walls as it
    counts pairs.
    """
    n = positions.shape[0]
    rho2 = rho_out * rho_out
    hmin = np.inf
    p = np.empty(3)
    for i in range(n):
        di = diameters[i]
        for a in range(3):
            if walls[a] != 0.0:
                hmin = min(hmin, _wall_push(forces, i, a, 1.0, di, positions[i, a], rho2))
                hmin = min(hmin, _wall_push(forces, i, a, -1.0, di, lengths[a] - positions[i, a], rho2))
        if walls[3] != 0.0:
            r = _curved_offset(positions, i, walls, p)
            hw = 2.0 * (walls[8] - r) / di
            hmin = min(hmin, hw)
            h2 = hw * hw
            if h2 < rho2 and r > 0.0:  # at the axis or centre the push has no direction (a wall narrower than D_i)
                f = di * di * (1.0 - h2 / rho2) / r
                for a in range(3):
                    forces[i, a] -= f * p[a]
    return hmin


@njit(cache=True, inline="always")
def _clamp_inside(positions, i, lengths, walls, margin, p):
    """Put centre i back at least ``margin`` from every wall (a centre already there is untouched): onto x_a = margin
    or L_a - margin across a plane, radially onto |p| = R - margin inside a curved wall. The walls of every container
    constrain separate coordinates (the caps of a cylinder the axial one, its curved wall the others), so clamping
    them one after the other is the nearest point that keeps the margin."""
    for a in range(3):
        if walls[a] != 0.0:
            positions[i, a] = min(max(positions[i, a], margin), lengths[a] - margin)
    if walls[3] != 0.0:
        r = _curved_offset(positions, i, walls, p)
        room = walls[8] - margin
        if r > room:
            s = room / r
            axis = int(walls[4]) if walls[3] == _CYLINDER else -1
            for a in range(3):
                if a != axis:
                    positions[i, a] = walls[5 + a] + s * p[a]


@njit(cache=True)
def move(positions, diameters, lengths, periodic, walls, has_walls, rho_in, forces, prefactor, drift):
    """x_i += prefactor / D_i * F_i, wrapped into [0, L_k) along periodic axes; returns the largest drift since the
    last list build.

    With walls (``has_walls``), a centre that would end closer to a wall than its inner radius rho_in D_i / 2 (or
    beyond it) is put back at that distance (:func:`_clamp_inside`): no wall lowers the inner ratio ``rho_in`` of
    the configuration before the move, and no centre leaves the container."""
    n, dim = positions.shape
    max2 = 0.0
    if not has_walls:
        for i in range(n):
            c = prefactor / diameters[i]
            d2 = 0.0
            for a in range(dim):
                step = c * forces[i, a]
                x = positions[i, a] + step
                box = lengths[a]
                x -= box * np.floor(x / box)  # any step size, not just one box length
                if x >= box:  # round-off of a tiny negative x
                    x -= box
                positions[i, a] = x
                drift[i, a] += step
                d2 += drift[i, a] * drift[i, a]
            max2 = max(max2, d2)
        return np.sqrt(max2)
    old = np.empty(dim)
    p = np.empty(3)
    for i in range(n):
        c = prefactor / diameters[i]
        for a in range(dim):
            old[a] = positions[i, a]
            x = old[a] + c * forces[i, a]
            if periodic[a]:
                box = lengths[a]
                x -= box * np.floor(x / box)
                if x >= box:
                    x -= box
            positions[i, a] = x
        _clamp_inside(positions, i, lengths, walls, 0.5 * rho_in * diameters[i], p)
        d2 = 0.0
        for a in range(dim):
            # the displacement: the step along a periodic axis (never clamped), the clamped one along a walled axis
            drift[i, a] += c * forces[i, a] if periodic[a] else positions[i, a] - old[a]
            d2 += drift[i, a] * drift[i, a]
        max2 = max(max2, d2)
    return np.sqrt(max2)
