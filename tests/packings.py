"""Packings and checks the tests of several folders share (calippso/, cli/, engines/): random sequential
addition and FCC starts, and the brute-force overlap check over every periodic image (no cell list)."""

import itertools
import math

import numpy as np

from spherejam.core.packing import Packing, ball_volume


def rsa_packing(n: int, phi: float, dim: int, seed: int = 0, size_ratio: float = 1.0) -> Packing:
    """Random sequential addition up to packing fraction ``phi`` (overlap-free by construction).

    Half the spheres have diameter 1 and half ``size_ratio`` (a bidisperse mix keeps d = 2 from crystallising).
    The low-density start of the reference's random-init examples; brute force, fine for a few hundred spheres.
    """
    rng = np.random.default_rng(seed)
    dia = np.where(np.arange(n) % 2 == 0, 1.0, size_ratio)
    box = (float(np.sum(ball_volume(dia, dim))) / phi) ** (1.0 / dim)
    pts = np.empty((n, dim))
    k = 0
    while k < n:
        p = rng.random(dim) * box
        d = pts[:k] - p
        d -= box * np.round(d / box)
        if k == 0 or np.all(np.einsum("ij,ij->i", d, d) >= (0.5 * (dia[:k] + dia[k])) ** 2):
            pts[k] = p
            k += 1
    return Packing(pts, dia, box, {"algorithm": "rsa", "seed": seed})


def fcc_packing(cells: int) -> Packing:
    """Perfect FCC at close packing: 4 cells^3 unit spheres, lattice constant sqrt(2)."""
    a = math.sqrt(2.0)
    basis = np.array([[0, 0, 0], [0.5, 0.5, 0], [0.5, 0, 0.5], [0, 0.5, 0.5]])
    cells_xyz = np.array(list(itertools.product(range(cells), repeat=3)), dtype=float)
    pos = (cells_xyz[:, None, :] + basis[None, :, :]).reshape(-1, 3) * a
    return Packing(pos, np.ones(len(pos)), cells * a)


def worst_overlap_all_images(packing: Packing) -> float:
    """max over pairs i <= j and over every image n (n != 0 for i = j) of 1 - |x_j + n L - x_i| / D_ij."""
    x, d, box = packing.positions, packing.diameters, packing.box
    reach = int(math.ceil(d.max() / box)) + 1
    shifts = box * np.array(list(itertools.product(range(-reach, reach + 1), repeat=3)), dtype=float)
    own = np.any(shifts != 0.0, axis=1)
    worst = -math.inf
    for i in range(packing.n):
        v = x[i:, None, :] + shifts[None, :, :] - x[i]
        r = np.sqrt(np.einsum("jsk,jsk->js", v, v))
        h = 1.0 - r / (0.5 * (d[i] + d[i:]))[:, None]
        h[0, ~own] = -math.inf  # a sphere and itself, unshifted
        worst = max(worst, float(h.max()))
    return worst


class Killed(Exception):
    """A run cut short, as a kill would cut it (raised by :func:`kill_at`'s callback)."""


def kill_at(window: int):
    """A window callback that raises :class:`Killed` at ``window``: a checkpoint test's stand-in for a kill."""

    def kill(w, stats):
        if w == window:
            raise Killed

    return kill
