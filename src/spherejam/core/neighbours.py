"""Cell lists in a box of any edge lengths, periodic or walled along each axis, in any dimension d: the one cell
geometry of every neighbour search in the package, and the exact pair search built on it (polydisperse spheres).

Frame
    A search runs in a rectangular frame [0, L_0) x ... x [0, L_{d-1}) (:class:`Frame`): the periodic cube of side L
    (every packing before containers; a plain float ``box`` means it), or a container's frame
    (core/container), which repeats along its periodic axes only. Along a walled axis no difference is folded and
    no image exists.

Geometry
    Axis k is cut into m_k cells of side L_k/m_k (:func:`cells_per_axis`); the cell with coordinates
    (c_0, ..., c_{d-1}) has index sum_k c_k prod_{q<k} m_q (first axis fastest). The *stencil* of half-width w of a
    cell is the cells within w cells of it along every axis, entry o = sum_k (o_k + w) prod_{q<k} s_q with
    s_k = 2w+1 (first axis fastest), each with the image shift (-L_k, 0 or +L_k per axis) that puts its spheres next
    to the central cell. Along an axis where the stencil would wrap onto itself (2w+1 > m_k) it spans the m_k cells
    once, with no shift (s_k = m_k): the caller then folds each difference to the minimum image. Along a walled axis
    a stencil entry beyond the frame is no cell (index -1).

Binnings of the same cells
    :func:`cell_sort` (cell of each point, CSR start of each cell, points in cell order) for searches over a fixed
    set of points: a cell's points are contiguous, and callers may copy their data in that order.
    :func:`link_cells` / :func:`move_to_cell` (head/next/prev linked lists) for the event-driven engine, whose
    spheres change cells one at a time between full rebuilds: a move is O(1), where a CSR would be rebuilt.

Pair search
    A pair (i, j) is *within scale s* when its minimum-image distance r_ij < s * D_ij, with D_ij = (D_i + D_j)/2 the
    contact distance. The cell side is at least s * max_i D_i >= s * max_ij D_ij, so every such pair lies in the
    same or an adjacent cell whatever the size ratio; the search costs O(N) for a bounded size ratio. The minimum
    image is a pair's closest image, so overlap checks need no other; :func:`pair_images` adds the other images
    within reach, which exist when s * D_ij > L_k/2 along a periodic axis (contacts and bonds in small boxes).

All kernels are numba ``njit(cache=True)`` functions over plain arrays; the small geometry helpers are inlined into
the engines' kernels. Numba keys a cached kernel on its own source file only: after editing this module, clear the
numba cache, or the kernels that inline it (engines/kernels, analysis/pore_size) keep the old code.
"""

from __future__ import annotations

import itertools
import math

import numpy as np
from numba import njit


class Frame:
    """The frame of a search: edge lengths L_k and which axes are periodic (see the module docstring).

    ``lengths`` (d,) float64; ``half`` (d,) L_k/2 along periodic axes and +inf along walled ones (a difference folds
    only beyond it, so a walled axis never folds); ``periodic`` (d,) bool.
    """

    __slots__ = ("lengths", "half", "periodic")

    def __init__(self, lengths, periodic):
        self.lengths = np.ascontiguousarray(lengths, dtype=np.float64)
        self.periodic = np.ascontiguousarray(periodic, dtype=np.bool_)
        self.half = np.where(self.periodic, 0.5 * self.lengths, np.inf)

    @classmethod
    def of(cls, box, dim: int | None = None) -> Frame:
        """A frame from a cube side (float, with ``dim``), a container, or a frame."""
        if isinstance(box, Frame):
            return box
        if hasattr(box, "lengths") and hasattr(box, "periodic"):
            return cls(box.lengths, box.periodic)
        return cls(np.full(dim, float(box)), np.ones(dim, dtype=np.bool_))

    @property
    def dim(self) -> int:
        return len(self.lengths)

    @property
    def is_periodic_cube(self) -> bool:
        return bool(np.all(self.periodic)) and bool(np.all(self.lengths == self.lengths[0]))


@njit(cache=True, inline="always")
def fold(dx, box, half):
    """Minimum image of a difference known to lie in (-1.5 L, 1.5 L) (coordinates kept in [0, L)): one fold. With
    ``half`` = +inf (a walled axis) nothing folds."""
    if dx > half:
        return dx - box
    if dx < -half:
        return dx + box
    return dx


@njit(cache=True)
def minimum_image(dx, box):
    """Fold a coordinate difference into [-box/2, box/2]."""
    return dx - box * np.floor(dx / box + 0.5)


@njit(cache=True, inline="always")
def frame_image(dx, length, periodic):
    """The minimum image of a difference along one axis of a frame: folded along a periodic axis, as is otherwise."""
    if periodic:
        return dx - length * np.floor(dx / length + 0.5)
    return dx


# --- cell geometry --------------------------------------------------------------------------------------------


def cells_per_side(box: float, min_side: float, dim: int, n: int) -> int:
    """Cells per box side m for cells of side L/m >= ``min_side``; 1 (one cell: all pairs) when fewer than 3 fit.

    Also caps the number of cells at about 2N (dilute, tiny-cutoff searches would otherwise allocate huge grids).
    The LS engine numbers its spheres in cell order, so a change to this rule changes LS runs bitwise (not in
    distribution); the searches' results do not depend on it.
    """
    m = int(float(box) // float(min_side)) if min_side > 0 else 1  # exact floor: L / m >= min_side in floats too
    m = min(m, math.ceil((2.0 * n) ** (1.0 / dim)))
    return m if m >= 3 else 1


def cells_per_axis(box, min_side: float, n: int, dim: int | None = None) -> np.ndarray:
    """Cells per axis m_k (int64 array) of a frame (or a cube side with ``dim``) for cells of side >= ``min_side``;
    :func:`cells_per_side` along every axis of a cube. An axis where fewer than 3 fit gets 1 cell, and the grid has
    at most about 2N cells."""
    frame = Frame.of(box, dim)
    if frame.is_periodic_cube:
        return np.full(frame.dim, cells_per_side(frame.lengths[0], min_side, frame.dim, n), dtype=np.int64)
    cell = (float(np.prod(frame.lengths)) / (2.0 * n)) ** (1.0 / frame.dim)  # the side of ~2N cells in the frame
    out = np.empty(frame.dim, dtype=np.int64)
    for k, length in enumerate(frame.lengths):
        m = int(float(length) // float(min_side)) if min_side > 0 else 1
        m = min(m, max(math.ceil(length / cell), 1))
        out[k] = m if m >= 3 else 1
    return out


@njit(cache=True, inline="always")
def axis_cell(x, length, m):
    """Cell coordinate 0..m-1 of coordinate x along one axis; an x outside [0, L) (round-off, or a position not yet
    wrapped) gets the cell of its periodic image."""
    return int(np.floor(x / length * m)) % m


@njit(cache=True, inline="always")
def cell_of(point, lengths, ms):
    """Index of the cell holding ``point`` (a length-d array)."""
    c = 0
    stride = 1
    for k in range(point.shape[0]):
        c += axis_cell(point[k], lengths[k], ms[k]) * stride
        stride *= ms[k]
    return c


@njit(cache=True, inline="always")
def unravel_cell(c, ms, coords):
    """Write the coordinates of cell index c into ``coords`` (length d)."""
    for k in range(coords.shape[0]):
        coords[k] = c % ms[k]
        c //= ms[k]


@njit(cache=True, inline="always")
def stencil_size(w, ms):
    """Number of entries of the half-width-w stencil: prod_k min(2w+1, m_k)."""
    span = 2 * w + 1
    total = 1
    for k in range(ms.shape[0]):
        total *= ms[k] if span > ms[k] else span
    return total


@njit(cache=True, inline="always")
def stencil_cell(coords, o, w, ms, lengths, periodic, shift):
    """Index of entry o of the half-width-w stencil around the cell at ``coords``; its image shift goes to ``shift``.
    -1 when the entry lies beyond a walled end of the frame.

    Along an axis where the stencil would wrap onto itself (2w+1 > m_k), entry o_k is cell o_k, unshifted.
    """
    dim = coords.shape[0]
    span = 2 * w + 1
    cn = 0
    stride = 1
    outside = False
    for q in range(dim):
        mq = ms[q]
        shift[q] = 0.0  # the image of the cell's spheres as seen from the unfolded cq
        if span > mq:
            cq = o % mq
            o //= mq
        else:
            cq = coords[q] + o % span - w
            o //= span
            if cq < 0:
                cq += mq
                shift[q] = -lengths[q]
                outside = outside or not periodic[q]
            elif cq >= mq:
                cq -= mq
                shift[q] = lengths[q]
                outside = outside or not periodic[q]
        cn += cq * stride
        stride *= mq
    return -1 if outside else cn


def neighbour_offsets(dim: int, m) -> np.ndarray:
    """The cell offsets of the entries of the half-width-1 stencil of a cubic grid of m cells per side, row o =
    entry o of :func:`stencil_cell` (just the zero offset when there is a single cell): for searches that visit the
    stencil in an order of their own."""
    if m == 1:
        return np.zeros((1, dim), dtype=np.int64)
    return np.array([t[::-1] for t in itertools.product((-1, 0, 1), repeat=dim)], dtype=np.int64)


# --- binnings ---------------------------------------------------------------------------------------------------


@njit(cache=True)
def cell_sort(positions, lengths, ms):
    """Sort particles into the grid of ``ms`` cells per axis. Returns (cell of each particle, CSR start per cell,
    particle order); each cell holds its particles in index order."""
    n, dim = positions.shape
    ncells = 1
    for k in range(dim):
        ncells *= ms[k]
    cell = np.empty(n, dtype=np.int64)
    for i in range(n):
        cell[i] = cell_of(positions[i], lengths, ms)
    counts = np.zeros(ncells + 1, dtype=np.int64)
    for i in range(n):
        counts[cell[i] + 1] += 1
    for c in range(ncells):
        counts[c + 1] += counts[c]
    start = counts.copy()
    order = np.empty(n, dtype=np.int64)
    fill = counts[:-1].copy()
    for i in range(n):
        order[fill[cell[i]]] = i
        fill[cell[i]] += 1
    return cell, start, order


@njit(cache=True)
def link_levels(positions, level, lengths, lvl_ms, lvl_off):
    """Linked cell lists of a grid of several levels: ``(head, nxt, prv, cell)`` (int32). Particle i is linked in
    level ``level[i]``, a grid of ``lvl_ms[level[i]]`` cells per axis whose cells are ``lvl_off[l]`` ...
    ``lvl_off[l + 1] - 1`` of ``head``; head[c] is the first particle of cell c, nxt[i] / prv[i] the next / previous
    one in i's cell (-1: none), cell[i] the (global) cell of i. Each cell lists its particles in index order."""
    n = positions.shape[0]
    head = np.full(lvl_off[-1], -1, dtype=np.int32)
    nxt = np.full(n, -1, dtype=np.int32)
    prv = np.full(n, -1, dtype=np.int32)
    cell = np.empty(n, dtype=np.int32)
    for i in range(n - 1, -1, -1):  # pushed at the head in reverse, so each cell ends up in index order
        lv = level[i]
        c = lvl_off[lv] + cell_of(positions[i], lengths, lvl_ms[lv])
        cell[i] = c
        nxt[i] = head[c]
        if head[c] >= 0:
            prv[head[c]] = i
        head[c] = i
    return head, nxt, prv, cell


def link_cells(positions, lengths, ms):
    """:func:`link_levels` of a grid of one level, ``ms`` cells per axis."""
    ms = np.ascontiguousarray(ms, dtype=np.int64)
    n = positions.shape[0]
    return link_levels(positions, np.zeros(n, dtype=np.int64), lengths, ms[None, :],
                       np.array([0, int(np.prod(ms))], dtype=np.int64))


@njit(cache=True, inline="always")
def move_to_cell(i, c, head, nxt, prv, cell):
    """Move particle i of :func:`link_cells` lists into cell c (at its head; nothing if i is there already)."""
    c_old = cell[i]
    if c == c_old:
        return
    if prv[i] >= 0:
        nxt[prv[i]] = nxt[i]
    else:
        head[c_old] = nxt[i]
    if nxt[i] >= 0:
        prv[nxt[i]] = prv[i]
    prv[i] = -1
    nxt[i] = head[c]
    if head[c] >= 0:
        prv[head[c]] = i
    head[c] = i
    cell[i] = c


# --- pair search ------------------------------------------------------------------------------------------------


@njit(cache=True)
def _pairs_kernel(positions, diameters, lengths, periodic, scale, ms, count_only, out_i, out_j, out_r):
    n, dim = positions.shape
    cell, start, order = cell_sort(positions, lengths, ms)
    coords = np.empty(dim, dtype=np.int64)
    shift = np.empty(dim)  # unused: differences are folded to the minimum image
    npairs = 0
    for i in range(n):
        unravel_cell(cell[i], ms, coords)
        for o in range(stencil_size(1, ms)):
            cj = stencil_cell(coords, o, 1, ms, lengths, periodic, shift)
            if cj < 0:
                continue
            for idx in range(start[cj], start[cj + 1]):
                j = order[idx]
                if j <= i:
                    continue
                r2 = 0.0
                for k in range(dim):
                    dx = frame_image(positions[j, k] - positions[i, k], lengths[k], periodic[k])
                    r2 += dx * dx
                cut = scale * 0.5 * (diameters[i] + diameters[j])
                if r2 < cut * cut:
                    if not count_only:
                        out_i[npairs] = i
                        out_j[npairs] = j
                        out_r[npairs] = np.sqrt(r2)
                    npairs += 1
    return npairs


def pairs_within(positions: np.ndarray, diameters: np.ndarray, box, scale: float = 1.0):
    """All pairs i < j with r_ij < scale * D_ij (minimum image along periodic axes).

    ``box`` is the cube side L or a :class:`Frame` (or a container). Returns ``(i, j, r)`` arrays sorted by (i, j).
    ``scale`` is dimensionless (1 = contact).
    """
    positions = np.ascontiguousarray(positions, dtype=np.float64)
    diameters = np.ascontiguousarray(diameters, dtype=np.float64)
    n, dim = positions.shape
    frame = Frame.of(box, dim)
    ms = cells_per_axis(frame, scale * float(diameters.max()), n)
    empty_i = np.empty(0, dtype=np.int64)
    empty_r = np.empty(0, dtype=np.float64)
    args = (positions, diameters, frame.lengths, frame.periodic, float(scale), ms)
    count = _pairs_kernel(*args, True, empty_i, empty_i, empty_r)
    out_i = np.empty(count, dtype=np.int64)
    out_j = np.empty(count, dtype=np.int64)
    out_r = np.empty(count, dtype=np.float64)
    _pairs_kernel(*args, False, out_i, out_j, out_r)
    key = np.lexsort((out_j, out_i))
    return out_i[key], out_j[key], out_r[key]


def closest_pair(positions: np.ndarray, diameters: np.ndarray, box):
    """The pair with the smallest normalised distance h_ij = r_ij / D_ij (``box``: the cube side or a frame).

    Returns ``(i, j, h)``. Overlap-free iff h >= 1. Grows the search scale from a density-based guess until a pair
    is found, so it works from Poisson configurations (h ~ 1e-2) to jammed ones (h ~ 1).
    """
    n, dim = positions.shape
    if n < 2:
        raise ValueError("closest_pair needs at least 2 particles")
    frame = Frame.of(box, dim)
    mean_d = float(np.mean(diameters))
    volume = frame.lengths[0] ** dim if frame.is_periodic_cube else float(np.prod(frame.lengths))
    spacing = (volume / n) ** (1.0 / dim)
    scale = min(1.0, 0.5 * spacing / mean_d) if mean_d > 0 else 1.0
    scale = max(scale, 1e-300)
    max_scale = 2.0 * float(frame.lengths.max()) * np.sqrt(dim) / max(float(np.min(diameters)), 1e-300)
    while True:
        i, j, r = pairs_within(positions, diameters, frame, scale)
        if len(r):
            h = r / (0.5 * (diameters[i] + diameters[j]))
            k = int(np.argmin(h))
            return int(i[k]), int(j[k]), float(h[k])
        if scale > max_scale:
            raise ValueError("closest_pair found no pair (degenerate diameters?)")
        scale *= 2.0


@njit(cache=True, inline="always")
def image_span(d, cut, lengths, periodic, lo, span):
    """The images n (integer vectors) of a difference ``d`` with |d_k + n_k L_k| < ``cut`` along every axis k (n_k = 0
    along a walled axis): n_k = lo[k] ... lo[k] + span[k] - 1, written to ``lo`` and ``span``; returns their number,
    prod span[k]. Image number ``code`` (0 <= code < that) is n_k = lo[k] + (code // prod_{q<k} span[q]) % span[k]."""
    total = 1
    for k in range(d.shape[0]):
        if periodic[k]:
            lo[k] = int(np.ceil((-cut - d[k]) / lengths[k]))
            span[k] = max(int(np.floor((cut - d[k]) / lengths[k])) - lo[k] + 1, 0)
        else:
            lo[k] = 0
            span[k] = 1 if abs(d[k]) < cut else 0
        total *= span[k]
    return total


@njit(cache=True, inline="always")
def image_vector(code, d, lengths, lo, span, out):
    """Write d + n L of image ``code`` of :func:`image_span` to ``out``; returns (|d + n L|^2, n == 0)."""
    r2 = 0.0
    zero = True
    for k in range(d.shape[0]):
        nk = lo[k] + code % span[k]
        code //= span[k]
        zero = zero and nk == 0
        out[k] = d[k] + nk * lengths[k]
        r2 += out[k] * out[k]
    return r2, zero


@njit(cache=True)
def _extra_images_kernel(positions, diameters, lengths, periodic, scale, big, is_big, count_only, out_i, out_j,
                         out_d):
    """The images other than the minimum one of the pairs i < j with |x_j + n L - x_i| < scale * D_ij, for the
    pairs with a sphere in ``big`` (only those can have one). Returns their number."""
    n, dim = positions.shape
    d = np.empty(dim)
    e = np.empty(dim)
    lo = np.empty(dim, dtype=np.int64)
    span = np.empty(dim, dtype=np.int64)
    count = 0
    for a in range(big.shape[0]):
        i0 = big[a]
        for j0 in range(n):
            if j0 == i0 or (is_big[j0] and j0 < i0):
                continue  # a pair of two big spheres is visited from its lower index
            i = min(i0, j0)
            j = max(i0, j0)
            cut = scale * 0.5 * (diameters[i] + diameters[j])
            for k in range(dim):
                d[k] = frame_image(positions[j, k] - positions[i, k], lengths[k], periodic[k])
            for code in range(image_span(d, cut, lengths, periodic, lo, span)):
                r2, zero = image_vector(code, d, lengths, lo, span, e)
                if zero or not r2 < cut * cut:
                    continue
                if not count_only:
                    out_d[count, :] = e
                    out_i[count] = i
                    out_j[count] = j
                count += 1
    return count


def _minimum_image_vectors(d: np.ndarray, frame: Frame) -> np.ndarray:
    """Fold difference vectors (K, d) to the minimum image along the frame's periodic axes (in place)."""
    if frame.is_periodic_cube:
        box = frame.lengths[0]
        d -= box * np.floor(d / box + 0.5)
        return d
    for k in np.flatnonzero(frame.periodic):
        d[:, k] -= frame.lengths[k] * np.floor(d[:, k] / frame.lengths[k] + 0.5)
    return d


def pair_images(positions: np.ndarray, diameters: np.ndarray, box, scale: float = 1.0):
    """Every periodic image of every pair i < j with |x_j + n L - x_i| < scale * D_ij: ``(i, j, d)``, d the (K, d)
    vectors x_j + n L - x_i, sorted by (i, j, |d|). ``box``: the cube side or a frame (no image along walled axes).

    A pair appears once per image within reach, so in a box smaller than two contact distances (small N or a wide
    size ratio) it may appear several times; otherwise this is :func:`pairs_within` with minimum-image vectors.
    A sphere's own images are left out (a sphere wider than L overlaps itself: :meth:`Packing.check`).
    """
    positions = np.ascontiguousarray(positions, dtype=np.float64)
    diameters = np.ascontiguousarray(diameters, dtype=np.float64)
    frame = Frame.of(box, positions.shape[1])
    i, j, _ = pairs_within(positions, diameters, frame, scale)
    d = _minimum_image_vectors(positions[j] - positions[i], frame)
    # an image other than the minimum one lies >= L_k/2 away along some periodic axis k, so only a pair with
    # scale D_ij >= L_k/2 has one: its larger sphere has D >= L_k / (2 scale) and D >= L_k / scale - D_max
    if not frame.periodic.any():
        return i, j, d
    period = float(frame.lengths[frame.periodic].min())
    threshold = max(0.5 * period / scale, period / scale - float(diameters.max()))
    is_big = diameters >= threshold
    big = np.flatnonzero(is_big)
    if len(big):
        args = (positions, diameters, frame.lengths, frame.periodic, float(scale), big.astype(np.int64), is_big)
        count = _extra_images_kernel(*args, True, np.empty(0, np.int64), np.empty(0, np.int64), np.empty((0, 1)))
        ei, ej, ed = np.empty(count, np.int64), np.empty(count, np.int64), np.empty((count, positions.shape[1]))
        _extra_images_kernel(*args, False, ei, ej, ed)
        i, j, d = np.concatenate([i, ei]), np.concatenate([j, ej]), np.concatenate([d, ed])
        key = np.lexsort((np.einsum("ij,ij->i", d, d), j, i))
        i, j, d = i[key], j[key], d[key]
    return i, j, d


def brute_force_pairs(positions: np.ndarray, diameters: np.ndarray, box, scale: float = 1.0):
    """O(N^2) reference for :func:`pairs_within` (tests and tiny systems)."""
    n = len(positions)
    frame = Frame.of(box, positions.shape[1])
    ii, jj = np.triu_indices(n, 1)
    d = _minimum_image_vectors(positions[jj] - positions[ii], frame)
    r = np.sqrt((d * d).sum(axis=1))
    keep = r < scale * 0.5 * (diameters[ii] + diameters[jj])
    return ii[keep], jj[keep], r[keep]
