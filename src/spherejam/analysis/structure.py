"""All structural measures of a packing as flat scalars: :func:`analyze` gathers the contact statistics of
:mod:`.contacts`, the bond order of :mod:`.bond_order`, the Voronoi statistics of :mod:`.voronoi` and the pore-size
entropy of :mod:`.pore_size`; :data:`VARIABLES` names and describes each scalar.

All lengths use the ACTUAL diameters; volumes and distances are reported in units of the mean diameter ā (so
every measure is invariant under a uniform rescaling of box and diameters). Q6 and Voronoi are defined for d = 3
only (NaN otherwise); contacts, g(r) and pore sizes work for d = 2..5.

In a container (docs/containers_structure.md) the contacts count sphere-wall contacts and the container's isostatic
count, Q6 and the crystalline fraction use bonds that never cross a wall, and the measures that handle only a
periodic box (the Voronoi statistics, the pore-size entropy) are NaN, each with its reason in :func:`unavailable`;
``container`` receives the container section (analysis/layers: profile, core phi, layers at the wall).
"""

from __future__ import annotations

import math
import time

from ..core.packing import Packing
from . import contacts as _contacts
from . import layers as _layers
from .bond_order import bond_network, crystalline_particles, steinhardt
from .pore_size import pore_size_entropy
from .voronoi import voronoi_statistics, voronoi_volumes

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


#: What a container packing leaves out of the record, and why (the variables of each part are NaN).
NOT_IN_A_CONTAINER: dict[str, tuple[tuple[str, ...], str]] = {
    "voronoi": (("voronoi_volume_mean", "voronoi_volume_std", "voronoi_k", "voronoi_entropy"),
                "not available in a container (n/a: the radical Voronoi tessellation is periodic; cells bounded by "
                "the walls are not implemented)"),
    "pore_size_entropy": (("large_pore_fraction", "pore_size_entropy", "pore_samples"),
                          "not available in a container (n/a: the pore sampling covers a periodic cube; sampling "
                          "inside walls is not implemented)"),
}


def unavailable(packing: Packing) -> dict[str, str]:
    """The parts of :func:`analyze` a packing's container leaves out (NaN in the record), with the reason of each."""
    if packing.container.is_periodic_cube:
        return {}
    return {part: reason for part, (_, reason) in NOT_IN_A_CONTAINER.items()}


def analyze(
    packing: Packing,
    *,
    pressure: float | None = None,
    contact_tolerance: float | None = None,
    seed: int = 0,
    pore_samples: int | None = None,
    timings: dict[str, float] | None = None,
    container: dict | None = None,
) -> dict[str, float]:
    """All structural measures of ``packing`` as flat scalars named as in :data:`VARIABLES`.

    ``pressure`` (default: ``metadata["reduced_pressure"]``) sets the contact tolerance rule unless
    ``contact_tolerance`` is given (see :mod:`spherejam.analysis.contacts`); ``seed`` and ``pore_samples`` control the
    pore-size sampling (None: the reference convergence rule, >= 10^7 points). Q6 and Voronoi measures are NaN
    for d != 3. ``timings``, if given, receives the wall time of each part in seconds. ``container``, if given and
    the packing has walls, receives the container section (:func:`spherejam.analysis.layers.container_record`).
    """
    clock = {} if timings is None else timings
    t0 = time.perf_counter()
    out = _contacts.analyze_contacts(packing, contact_tolerance=contact_tolerance, pressure=pressure)
    result = out.coordination.as_dict()
    t1 = time.perf_counter()
    clock["contacts"] = t1 - t0
    skip = unavailable(packing)
    q_per = solid = None
    if packing.dim == 3:
        bonds = bond_network(packing)
        q_global, q_local, q_per, _ = steinhardt(packing, 6, bonds=bonds)
        solid, _ = crystalline_particles(packing, bonds=bonds)
        crystalline = float(solid.mean()) if solid.any() else 0.0
        t2 = time.perf_counter()
        clock["q6"] = t2 - t1
        if "voronoi" not in skip:
            result.update(voronoi_statistics(voronoi_volumes(packing), packing.diameters))
        t3 = time.perf_counter()
        clock["voronoi"] = t3 - t2
    else:
        q_global = q_local = crystalline = math.nan
        t3 = time.perf_counter()
    result["q6_global"], result["q6_local"] = float(q_global), float(q_local)
    result["crystalline_fraction"] = float(crystalline)
    if "pore_size_entropy" not in skip:
        s, p, used = pore_size_entropy(packing, seed=seed, samples=pore_samples)
        result.update(pore_size_entropy=s, large_pore_fraction=p, pore_samples=float(used))
    clock["pore_size_entropy"] = time.perf_counter() - t3
    for part in skip:
        result.update({name: math.nan for name in NOT_IN_A_CONTAINER[part][0]})
    result.update({k: math.nan for k in VARIABLES if k.startswith("voronoi_") and k not in result})
    if container is not None and packing.container.has_walls and packing.dim == 3:
        container.update(_layers.container_record(packing, out, q_per, solid))
    missing = set(VARIABLES) ^ set(result)
    assert not missing, f"analyze and VARIABLES disagree on {sorted(missing)}"
    return {k: result[k] for k in VARIABLES}
