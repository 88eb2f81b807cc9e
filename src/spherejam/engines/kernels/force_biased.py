"""The force-biased engine's numba kernels: the Verlet-list build, the forces and the move of one iteration
(the rules are in :mod:`spherejam.engines.force_biased`)."""

from __future__ import annotations

import numpy as np
from numba import njit

from ...core.neighbours import cell_sort, fold, image_span, image_vector, stencil_cell, stencil_size, unravel_cell


@njit(cache=True, inline="always")
def _scan_cell(ps, ds, order, begin, end, a, i, shift, wrap, box, rho_out, skin, pairs, count):
    """Append to ``pairs`` the pairs of sphere a (index i) with the spheres begin..end-1 of one cell, kept if sphere
    a is the larger one (ties: the lower index); False if ``pairs`` is full."""
    dim = ps.shape[1]
    half = 0.5 * box
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
                dx = fold(dx, box, half)
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
def build_verlet(positions, diameters, box, rho_out, skin, m, capacity):
    """CSR half list (row i holds j > i, ascending) of all pairs with r_ij < rho_out D_ij + skin.

    Each pair is found from its larger sphere, which scans the cells within rho_out D_i + skin. Cells are sized
    for typical spheres, which scan the 3^d adjacent cells (cell by cell, so the periodic image of a neighbour
    cell is a known shift); the few larger spheres of a polydisperse packing scan a wider stencil.
    Returns empty arrays if more than ``capacity`` pairs are found (retry with a larger one).
    """
    n, dim = positions.shape
    side = box / m
    lengths = np.full(dim, box)  # the periodic cube as a frame (core.neighbours)
    ms = np.full(dim, m, dtype=np.int64)
    periodic = np.ones(dim, dtype=np.bool_)
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
    if m >= 3:
        for c in range(m**dim):
            unravel_cell(c, ms, coords)
            for o in range(stencil_size(1, ms)):
                cn = stencil_cell(coords, o, 1, ms, lengths, periodic, shift)
                for a in range(start[c], start[c + 1]):
                    if stencil[a] == 1 and not _scan_cell(ps, ds, order, start[cn], start[cn + 1], a, order[a],
                                                          shift, False, box, rho_out, skin, pairs, count):
                        return failed
    # the others, sphere by sphere over a (2w+1)^d stencil; one that wraps onto itself scans every cell once
    for a in range(n):
        w = stencil[a]
        if w == 1 and m >= 3:
            continue
        wrap = 2 * w + 1 > m  # the whole grid, unshifted: fold each difference
        unravel_cell(cell[order[a]], ms, coords)
        for o in range(stencil_size(w, ms)):
            cn = stencil_cell(coords, o, w, ms, lengths, periodic, shift)
            if not _scan_cell(ps, ds, order, start[cn], start[cn + 1], a, order[a], shift, wrap, box, rho_out,
                              skin, pairs, count):
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
def forces(positions, diameters, box, rho_out, nbr_start, nbr, forces, dx, multi):
    """Bezrukov forces of the pairs whose outer spheres overlap; returns min r_ij / D_ij over the list.

    ``multi``: an outer sphere may reach several images of a listed neighbour (rho_out D_ij > L/2); each adds its
    force (the minimum image is the closest, so the returned minimum is unchanged).
    """
    n, dim = positions.shape
    half = 0.5 * box
    forces[:, :] = 0.0
    rho2 = rho_out * rho_out
    hmin2 = np.inf
    for i in range(n):
        di = diameters[i]
        for p in range(nbr_start[i], nbr_start[i + 1]):
            j = nbr[p]
            r2 = 0.0
            for a in range(dim):
                dx[a] = fold(positions[i, a] - positions[j, a], box, half)
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
                _image_forces(i, j, di * diameters[j], dij, rho2, box, dx, forces)
    return np.sqrt(hmin2)


@njit(cache=True, inline="always")
def _image_forces(i, j, dd, dij, rho2, box, dx, forces):
    """Add the forces of the images of j other than the minimum one (x_i - x_j = ``dx``) within rho_out D_ij."""
    dim = dx.shape[0]
    lo = np.empty(dim, dtype=np.int64)
    span = np.empty(dim, dtype=np.int64)
    e = np.empty(dim)
    lengths = np.full(dim, box)
    periodic = np.ones(dim, dtype=np.bool_)
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
def pair_ratio(positions, diameters, box, i, j):
    """r_ij / D_ij, computed with the same operations as in :func:`forces`."""
    half = 0.5 * box
    r2 = 0.0
    for a in range(positions.shape[1]):
        dx = fold(positions[i, a] - positions[j, a], box, half)
        r2 += dx * dx
    dij = 0.5 * (diameters[i] + diameters[j])
    return np.sqrt(r2 / (dij * dij))


@njit(cache=True)
def move(positions, diameters, box, forces, prefactor, drift):
    """x_i += prefactor / D_i * F_i, wrapped into [0, box); returns the largest drift since the last list build."""
    n, dim = positions.shape
    max2 = 0.0
    for i in range(n):
        c = prefactor / diameters[i]
        d2 = 0.0
        for a in range(dim):
            step = c * forces[i, a]
            x = positions[i, a] + step
            x -= box * np.floor(x / box)  # any step size, not just one box length
            if x >= box:  # round-off of a tiny negative x
                x -= box
            positions[i, a] = x
            drift[i, a] += step
            d2 += drift[i, a] * drift[i, a]
        max2 = max(max2, d2)
    return np.sqrt(max2)
