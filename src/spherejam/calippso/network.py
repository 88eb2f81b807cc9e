"""The contact network an LP certifies: contacts and forces from its duals, rattlers, isostaticity, force balance,
the pinned particle, and the gaps of the near-contacts (docs/calippso.md §3).
"""

from __future__ import annotations

import math

import numpy as np

from ..core.rattlers import SPAN_TOLERANCE, rattler_mask, spanned_dimensions
from ..core.neighbours import pair_images
from .constraints import as_pins, pair_keys, particle_force_sums


def contact_network(rij, sigma2, pi, pj, duals, n, dim, zero_force, pins=None):
    """Contacts, rattlers and force balance from LP duals.

    ``n`` is the LP's node count; with ``pins`` (:class:`~.constraints.Pins`, a container's LP) the nodes from
    ``pins.spheres`` on are walls: never rattlers, their contacts count for their spheres and in N_c, and the force
    balance is taken over spheres only (a wall absorbs its forces). Rattlers by the rank rule of
    :func:`~spherejam.core.rattlers.rattler_mask` (the (d+1)-core where contacts span R^d). Isostatic:
    N_c = d N_s - z + 1 - F, z the zero modes (d in a periodic box: d (N_s - 1) + 1; docs/containers.md §4), F the
    free directions of the partial rattlers (:func:`free_directions`; 0 in a generic packing).

    Returns ``(contact_mask over pairs, rattler mask over nodes, n_contacts among non-rattlers, isostatic,
    residual)``.
    """
    pins = as_pins(0, n, dim) if pins is None else pins
    contact = duals * sigma2 * n > zero_force
    ci, cj = pi[contact], pj[contact]
    walls = None
    if pins.spheres < n:
        walls = np.zeros(n, dtype=np.int64)
        walls[pins.spheres:] = dim + 1  # a wall never peels
    rattler = rattler_mask(n, ci, cj, dim + 1, walls, rij[contact])
    stable_pair = contact & ~rattler[pi] & ~rattler[pj]
    n_contacts = int(np.count_nonzero(stable_pair))
    n_stable = pins.spheres - int(np.count_nonzero(rattler[:pins.spheres]))
    free = free_directions(rij, stable_pair, pi, pj, rattler, pins.spheres)
    isostatic = bool(n_stable > 0 and n_contacts == dim * n_stable - pins.zero_modes + 1 - free)
    # every contact force counts (in a degenerate, crystalline vertex a "rattler" can hold d collinear forces)
    weight = np.where(contact, duals, 0.0)
    residual = force_balance(rij, weight, pi, pj, n, rattler, pins.spheres)
    return contact, rattler, n_contacts, isostatic, residual


def free_directions(rij, stable_pair, pi, pj, rattler, spheres) -> int:
    """F = sum over non-rattler spheres of d - s_i, s_i the dimensions their contacts with non-rattlers (rows
    ``stable_pair``, walls included) span: the directions of the partial rattlers that no contact loads
    (docs/containers.md §4, §5). 0 in a generic packing."""
    dim = rij.shape[1]
    node = np.concatenate([pi[stable_pair], pj[stable_pair]])
    vec = np.concatenate([rij[stable_pair], rij[stable_pair]])
    keep = node < spheres
    span = spanned_dimensions(spheres, node[keep], vec[keep])
    return int(np.sum(dim - span[~rattler[:spheres]]))


#: Rows closer than this relative gap are the touching pairs a degenerate dual's forces are sought on.
TOUCHING_GAP = 1e-9


def unheld_spheres(rij, sigma2, pi, pj, duals, n, dim, zero_force, spheres=None):
    """Spheres the duals load whose loaded contacts (as in :func:`contact_network`) span fewer than d dimensions, s,
    and number at least s + 1 (partial rattlers, :func:`~spherejam.core.rattlers.rattler_mask`): ``(indices, unit
    directions (k, d))``, each direction orthogonal to all its loaded contacts (a near-null
    eigenvector of sum_k u_k u_k^T) with the sign that closes its touching rows least (u_k . e largest at its worst,
    u_k a row's direction towards the sphere; on a flat wall: away from the wall). Nodes from ``spheres`` on are
    walls."""
    spheres = n if spheres is None else spheres
    contact = duals * sigma2 * n > zero_force
    length = np.linalg.norm(rij, axis=1)
    u = rij / np.where(length > 0, length, 1.0)[:, None]
    touching = length * length < sigma2 * (1.0 + TOUCHING_GAP) ** 2
    node = np.concatenate([pi, pj])
    toward = np.concatenate([u, -u])  # a row's direction towards each of its two nodes
    loaded = np.concatenate([contact, contact])
    touch = np.concatenate([touching, touching])
    keep = loaded & (node < spheres)
    gram = np.zeros((spheres, dim, dim))
    np.add.at(gram, node[keep], toward[keep, :, None] * toward[keep, None, :])
    eig, vec = np.linalg.eigh(gram)
    low = eig < SPAN_TOLERANCE * eig[:, -1:]
    count = np.bincount(node[keep], minlength=spheres)
    # linearly dependent loaded contacts (s + 1 or more, s their span): forces that can balance, the rank rule's
    found = np.flatnonzero((eig[:, -1] > 0) & low[:, 0] & (count >= dim - np.sum(low, axis=1) + 1))
    directions = np.empty((found.size, dim))
    for k, i in enumerate(found):
        rows = toward[(node == i) & touch]
        best = -np.inf
        for e in vec[i][:, low[i]].T:
            for cand in (e, -e):
                worst = float(np.min(rows @ cand)) if len(rows) else 1.0
                if worst > best:
                    best, directions[k] = worst, cand
    return found.astype(np.int64), directions


def escape_motion(rij, sigma2, pi, pj, duals, n, dim, zero_force, pins, step):
    """A first-order motion that frees the unheld spheres (:func:`unheld_spheres`), or None if there is none.

    v (n, d) keeps every loaded row's length to first order (u_k . (v_i - v_j) = 0), closes no row by more than its
    gap in a step ``step`` v (u_k . (v_i - v_j) >= -gap_k / step, lengths in the rows' units; a touching row cannot
    close), fixes ``pins`` (:class:`~.constraints.Pins`: the gauge and the walls), |v_{i,mu}| <= 1, and moves the
    unheld spheres as far as it can along their directions (maximises sum_i e_i . v_i). Along such a v the loaded
    contacts of a moved unheld sphere open at second order, and so does the network the duals load, whose single
    state of self-stress needs them (docs/containers.md §5). A motion is returned only if that sum is positive;
    a sphere its touching rows hold in place (through every chain of spheres that could make way) is not moved."""
    from scipy.optimize import linprog
    from scipy.sparse import coo_matrix

    idx, free = unheld_spheres(rij, sigma2, pi, pj, duals, n, dim, zero_force, pins.spheres)
    if idx.size == 0:
        return None
    contact = duals * sigma2 * n > zero_force
    length = np.linalg.norm(rij, axis=1)
    u = rij / np.where(length > 0, length, 1.0)[:, None]
    slack = length - np.sqrt(sigma2)
    near = contact | (slack < step * 2.0 * math.sqrt(dim))  # the rows a step can reach
    rows = np.flatnonzero(near)
    k = np.arange(rows.size)
    cols = np.concatenate([pi[rows, None] * dim + np.arange(dim), pj[rows, None] * dim + np.arange(dim)])
    vals = np.concatenate([u[rows], -u[rows]])
    a = coo_matrix((vals.ravel(), (np.repeat(np.concatenate([k, k]), dim), cols.ravel())),
                   shape=(rows.size, n * dim)).tocsr()
    eq = contact[rows]
    cost = np.zeros(n * dim)
    cost[(idx[:, None] * dim + np.arange(dim)).ravel()] = -free.ravel()
    bounds = np.tile([-1.0, 1.0], (n * dim, 1))
    bounds[pins.columns] = 0.0
    res = linprog(cost, A_ub=-a[~eq], b_ub=np.maximum(slack[rows][~eq], 0.0) / step, A_eq=a[eq],
                  b_eq=np.zeros(int(eq.sum())), bounds=bounds, method="highs")
    if res.status != 0 or -res.fun <= 1e-9:
        return None
    return res.x.reshape(n, dim)


def balanced_forces(rij, sigma2, pi, pj, n, spheres=None):
    """Duals of a force network on the touching rows, for an LP whose own duals carry none (a crystal: FCC, the
    N = 2 BCC; the optimum Gamma = 1 is degenerate and the solver's vertex may put every dual to zero).

    Contact forces f_k >= 0 on the rows with gap below :data:`TOUCHING_GAP`, balanced on every sphere
    (sum_k f_k r_k = 0 per sphere), summing to 1, with the smallest force as large as possible (so that in a
    symmetric crystal every contact carries one). Returned as duals (f_k / sigma2_k, zero on the other rows), as the
    main LP's would be; all zero if no such network exists (a sphere jammed only by its own image has no row).
    Nodes from ``spheres`` on are a container's walls, which need no balance."""
    from scipy.optimize import linprog
    from scipy.sparse import coo_matrix, vstack

    duals = np.zeros(len(sigma2))
    touching = np.flatnonzero(np.sum(rij * rij, axis=1) < sigma2 * (1.0 + TOUCHING_GAP) ** 2)
    m = touching.size
    if m == 0:
        return duals
    dim = rij.shape[1]
    k = np.arange(m)
    r = rij[touching]
    rows = np.concatenate([pi[touching, None] * dim + np.arange(dim), pj[touching, None] * dim + np.arange(dim)])
    cols = np.concatenate([np.repeat(k[:, None], dim, axis=1)] * 2)
    vals = np.concatenate([r, -r])
    balance = coo_matrix((vals.ravel(), (rows.ravel(), cols.ravel())), shape=(n * dim, m + 1))
    balanced = n if spheres is None else spheres
    if balanced < n:
        balance = balance.tocsr()[:balanced * dim]
    total = coo_matrix((np.ones(m), (np.zeros(m, int), k)), shape=(1, m + 1))
    a_eq = vstack([balance, total]).tocsr()
    b_eq = np.concatenate([np.zeros(balanced * dim), [1.0]])
    a_ub = coo_matrix((np.concatenate([-np.ones(m), np.ones(m)]), (np.concatenate([k, k]),
                       np.concatenate([k, np.full(m, m)]))), shape=(m, m + 1)).tocsr()  # t <= f_k
    cost = np.zeros(m + 1)
    cost[m] = -1.0  # maximise the smallest force t
    res = linprog(cost, A_ub=a_ub, b_ub=np.zeros(m), A_eq=a_eq, b_eq=b_eq,
                  bounds=[(0, None)] * m + [(0, None)], method="highs")
    if res.status != 0:
        return duals
    duals[touching] = np.maximum(res.x[:m], 0.0) / sigma2[touching]
    return duals


def force_balance(rij, weight, pi, pj, n, rattler, spheres=None) -> float:
    """max over non-rattler spheres of |sum_j w_ij r_ij| divided by the mean w_ij |r_ij| over rows with w > 0 (wall
    rows included: a wall's force is lambda r_iw on its sphere). Nodes from ``spheres`` on are walls, left out."""
    spheres = n if spheres is None else spheres
    active = weight > 0
    if not np.any(active) or np.all(rattler[:spheres]):
        return math.inf
    mean_force = float(np.mean(weight[active] * np.linalg.norm(rij[active], axis=1)))
    net = particle_force_sums(rij, weight, pi, pj, n)[:spheres]
    return float(np.max(np.linalg.norm(net[~rattler[:spheres]], axis=1)) / mean_force)


def initial_pin(x, dia, box) -> int:
    """The particle with the most neighbours within 1.05 sigma, images counted (likely part of the rigid network):
    pinned first."""
    i, j, _ = pair_images(x, dia, box, 1.05)
    if len(i) == 0:
        return len(x) - 1
    count = np.bincount(np.concatenate([i, j]), minlength=len(x))
    return int(np.argmax(count))


def repin(contact, pi, pj, rattler, n, spheres=None) -> int:
    """The non-rattler with the most contacts: the pinned particle once the pinned one turned out a rattler (nodes
    from ``spheres`` on are a container's walls, never pinned)."""
    count = np.bincount(np.concatenate([pi[contact], pj[contact]]), minlength=n)
    count[rattler] = -1
    if spheres is not None:
        count[spheres:] = -1
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
