"""The pair load W of a size distribution: how much work a collision costs relative to equal spheres (issue 47,
docs/algorithms.md §7.5). The cost model prices the event-driven stages by it (:mod:`.cost_model`), and the
experiment computes it for each distribution at each N (:meth:`.experiment.Experiment.pair_load`); a module of its
own, below both, so that neither imports the other for it. Standard library only: the rules' resource functions use it.
"""

from __future__ import annotations

import math

from ..core.errors import require

#: The Verlet skin of the event-driven engine in mean diameters (engines.event_driven.ListOptions.skin_fraction),
#: part of a neighbour list's radius in pair_load.
LIST_SKIN = 0.2
#: The largest diameter, in box lengths, from which the event-driven engine predicts pairs through several periodic
#: images (engines/event_driven.py, ``rebuild_lists``: rho D_max >= 0.9 x 0.45 L), judged at the packing fraction
#: JAMMED_PHI, where LS and MLS spend most of their collisions.
MULTI_IMAGE_SPAN = 0.405
JAMMED_PHI = 0.64
#: Work per collision in the multi-image mode relative to the lists' alone (every listed pair tested through the
#: images one box length around it, and one cell per side), fitted with the cost model's slow-down
#: (`benchmarks/cost_fit.py fit`, docs/algorithms.md §7.9).
MULTI_IMAGE_FACTOR = 2.34


def pair_load(diameters) -> float:
    """W: the work of a collision relative to equal spheres (1 for equal spheres): :func:`list_load`, times
    MULTI_IMAGE_FACTOR when the largest sphere spans so much of the box (:func:`image_span` >= MULTI_IMAGE_SPAN) that
    the engine predicts pairs through several images. ``diameters`` is a sample of N diameters (any scale): the box
    is that of N spheres, so the same distribution can be multi-image at small N and not at large N."""
    load = list_load(diameters)
    return load * MULTI_IMAGE_FACTOR if image_span(diameters) >= MULTI_IMAGE_SPAN else load


def image_span(diameters) -> float:
    """D_max / L: the largest diameter in box lengths, L the side of the periodic cube holding the spheres at packing
    fraction JAMMED_PHI (L^3 = sum pi D^3 / 6 / JAMMED_PHI)."""
    values = _diameters(diameters)
    side = (math.fsum(math.pi / 6.0 * d**3 for d in values) / JAMMED_PHI) ** (1.0 / 3.0)
    return max(values) / side


def _diameters(diameters) -> list[float]:
    values = [float(d) for d in diameters]
    require(len(values) > 0 and all(math.isfinite(d) and d > 0 for d in values), "diameters", len(values),
            "must be a non-empty sequence of finite numbers > 0")
    return values


def list_load(diameters) -> float:
    """The mean neighbour-list length of a colliding sphere, relative to equal spheres (1 for equal spheres).

    The event-driven engine re-predicts a sphere's whole Verlet list at each of its collisions, so its work per
    collision follows the lists of the spheres that collide. A sphere of diameter D (number mean 1) takes part in
    collisions in proportion to its surface D^2 and lists the centres within (D + 1)/2 + LIST_SKIN, a volume
    ~ ((D + 1)/2 + LIST_SKIN)^3:

        W = <D^2 ((D + 1)/2 + s)^3> / (<D^2> (1 + s)^3),   s = LIST_SKIN.

    ``diameters`` is a sample of the distribution (any scale; a plain sequence, no numpy needed). At 1:10, 30 % small
    by volume, ~ 20; a log-normal sigma = 0.5, ~ 2.2 (docs/algorithms.md §7.5)."""
    values = _diameters(diameters)
    mean = math.fsum(values) / len(values)
    weight = math.fsum((d / mean) ** 2 for d in values)
    volume = math.fsum((d / mean) ** 2 * (0.5 * (d / mean + 1.0) + LIST_SKIN) ** 3 for d in values)
    return volume / (weight * (1.0 + LIST_SKIN) ** 3)
