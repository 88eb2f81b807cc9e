"""Bond-orientational order of a packing (d = 3): the Steinhardt bond network, Steinhardt q_l (global, local, per
particle) and the crystalline fraction (ten Wolde solid-like bonds). Bond lengths use the actual diameters, so the
measures are invariant under a uniform rescaling of box and diameters."""

from __future__ import annotations

import math

import numpy as np

from ..core import neighbours
from ..core.errors import require
from ..core.packing import Packing

#: Neighbour cutoff of the Steinhardt bond network: r_ij <= Q6_CUTOFF * D_ij (docs/algorithms.md §6.4, as in the
#: reference code).
Q6_CUTOFF = 1.2


def bond_network(packing: Packing, cutoff: float = Q6_CUTOFF):
    """Bonds of the Steinhardt network: pairs i < j with r_ij < ``cutoff`` * D_ij and their vectors, one per periodic
    image within reach (:func:`spherejam.core.neighbours.pair_images`)."""
    require(math.isfinite(cutoff) and cutoff > 0, "cutoff", cutoff, "must be a finite number > 0")
    return neighbours.pair_images(packing.positions, packing.diameters, packing.frame, cutoff)


def steinhardt(packing: Packing, l: int = 6, cutoff: float = Q6_CUTOFF, bonds=None):  # noqa: E741 (degree l)
    """Steinhardt bond-orientational order of degree ``l`` (even), d = 3 (docs/algorithms.md §6.4).

    Returns ``(q_global, q_local, q_per_particle, n_neighbours)``: q_global from <Y_lm> over all bonds; q(i) from
    the bonds of i (NaN for particles without neighbours); q_local = mean of q(i) over particles with neighbours.
    ``bonds``: the output of :func:`bond_network` for this ``cutoff``, if already computed.
    """
    from scipy.special import sph_harm_y

    require(packing.dim == 3, "dimension d", packing.dim, "Steinhardt order is defined for d = 3 only")
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


def crystalline_particles(packing: Packing, q_threshold: float = SOLID_BOND_THRESHOLD,
                          solid_bonds: int = SOLID_BONDS, cutoff: float = Q6_CUTOFF,
                          bonds=None) -> tuple[np.ndarray, np.ndarray]:
    """``(crystalline, cluster)``, each (N,): whether each particle is crystalline (solid-like), and freud's cluster
    of solid bonds it belongs to (see :func:`crystalline_fraction`)."""
    import freud

    require(packing.dim == 3, "dimension d", packing.dim, "the crystalline fraction is defined for d = 3 only")
    require(math.isfinite(q_threshold) and -1 <= q_threshold <= 1, "q_threshold", q_threshold, "must lie in [-1, 1]")
    require(int(solid_bonds) == solid_bonds and solid_bonds >= 1, "solid_bonds", solid_bonds,
            "must be an integer >= 1")
    i, j, d = bond_network(packing, cutoff) if bonds is None else bonds
    if len(i) == 0:
        return np.zeros(packing.n, dtype=bool), np.arange(packing.n)
    query, point, vec = np.r_[i, j], np.r_[j, i], np.r_[d, -d]
    order = np.lexsort((point, query))
    nlist = freud.locality.NeighborList.from_arrays(packing.n, packing.n, query[order], point[order], vec[order])
    solid = freud.order.SolidLiquid(6, q_threshold, int(solid_bonds), normalize_q=True)
    c = packing.container
    if c.is_periodic_cube:
        box = packing.box
        solid.compute((freud.box.Box.cube(box), packing.positions - box / 2), neighbors=nlist)
    else:  # the bonds come from the frame's own pair search (no bond through a wall); freud only needs a box
        frame = freud.box.Box(*c.lengths)
        frame.periodic = list(c.periodic)
        solid.compute((frame, packing.positions - c.centre), neighbors=nlist)
    return np.asarray(solid.num_connections) >= solid_bonds, np.asarray(solid.cluster_idx)


def crystalline_fraction(packing: Packing, q_threshold: float = SOLID_BOND_THRESHOLD, solid_bonds: int = SOLID_BONDS,
                         cutoff: float = Q6_CUTOFF, bonds=None) -> tuple[float, float]:
    """Fraction of crystalline (solid-like) particles, and the largest crystalline cluster as a fraction of N.

    Bonds are those of :func:`bond_network` (r_ij <= ``cutoff`` * D_ij); the bond-orientational test is freud's
    ``order.SolidLiquid`` (l = 6, normalised q6m). A perfect FCC or HCP crystal gives (1, 1); jammed amorphous
    packings give a few per cent of scattered particles. Monodisperse MLS and slow LS runs can nucleate crystals
    (paper §IV.A), which this measure flags. ``bonds`` as in :func:`steinhardt`. In a container the bonds never
    cross a wall (:func:`bond_network`).
    """
    crystalline, cluster = crystalline_particles(packing, q_threshold, solid_bonds, cutoff, bonds)
    if not crystalline.any():
        return 0.0, 0.0
    # freud clusters every particle (non-solid ones as singletons): the largest cluster of crystalline particles
    sizes = np.bincount(cluster[crystalline])
    return float(crystalline.mean()), float(sizes.max() / packing.n)
