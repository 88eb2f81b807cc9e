"""The contact network an LP certifies: contacts and forces from its duals, rattlers, isostaticity, force balance,
the pinned particle, and the gaps of the near-contacts (docs/calippso.md §3).
"""

from __future__ import annotations

import math

import numpy as np

from ..core.rattlers import rattler_mask
from ..core.neighbours import pair_images
from .constraints import pair_keys, particle_force_sums


def contact_network(rij, sigma2, pi, pj, duals, n, dim, zero_force):
    """Contacts, rattlers and force balance from LP duals.

    Returns ``(contact_mask over pairs, rattler mask, n_contacts among non-rattlers, isostatic, residual)``.
    """
    contact = duals * sigma2 * n > zero_force
    ci, cj = pi[contact], pj[contact]
    rattler = rattler_mask(n, ci, cj, dim + 1)
    stable_pair = contact & ~rattler[pi] & ~rattler[pj]
    n_contacts = int(np.count_nonzero(stable_pair))
    n_stable = n - int(np.count_nonzero(rattler))
    isostatic = bool(n_stable > 0 and n_contacts == dim * (n_stable - 1) + 1)
    # every contact force counts (in a degenerate, crystalline vertex a "rattler" can hold d collinear forces)
    weight = np.where(contact, duals, 0.0)
    residual = force_balance(rij, weight, pi, pj, n, rattler)
    return contact, rattler, n_contacts, isostatic, residual


def force_balance(rij, weight, pi, pj, n, rattler) -> float:
    """max over non-rattlers of |sum_j w_ij r_ij| divided by the mean w_ij |r_ij| over pairs with w > 0."""
    active = weight > 0
    if not np.any(active) or np.all(rattler):
        return math.inf
    mean_force = float(np.mean(weight[active] * np.linalg.norm(rij[active], axis=1)))
    net = particle_force_sums(rij, weight, pi, pj, n)
    return float(np.max(np.linalg.norm(net[~rattler], axis=1)) / mean_force)


def initial_pin(x, dia, box) -> int:
    """The particle with the most neighbours within 1.05 sigma, images counted (likely part of the rigid network):
    pinned first."""
    i, j, _ = pair_images(x, dia, box, 1.05)
    if len(i) == 0:
        return len(x) - 1
    count = np.bincount(np.concatenate([i, j]), minlength=len(x))
    return int(np.argmax(count))


def repin(contact, pi, pj, rattler, n) -> int:
    """The non-rattler with the most contacts: the pinned particle once the pinned one turned out a rattler."""
    count = np.bincount(np.concatenate([pi[contact], pj[contact]]), minlength=n)
    count[rattler] = -1
    return int(np.argmax(count))


def near_gaps(x, dia, box, gap_range, rattler, contact_keys, n):
    """Gaps h = r/sigma - 1 < ``gap_range`` of the non-contact pair images among non-rattlers, and their pairs.

    ``contact_keys`` are the contacts' :func:`~.constraints.pair_keys` in the LP's rows: a pair's images are ranked
    by distance in both lists, so an image's key is the same in each (docs/calippso.md §1.2).
    """
    i, j, d = pair_images(x, dia, box, 1.0 + gap_range)
    r = np.sqrt(sum(d[:, k] * d[:, k] for k in range(d.shape[1])))  # summed in pairs_within's order: same bits
    is_contact = np.isin(pair_keys(i, j, n), contact_keys)
    keep = ~rattler[i] & ~rattler[j] & ~is_contact
    i, j, r = i[keep], j[keep], r[keep]
    h = r / (0.5 * (dia[i] + dia[j])) - 1.0
    return h, np.stack([i, j], axis=1)
