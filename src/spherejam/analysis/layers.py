"""Structure by layer from a container's wall: contacts, rattlers, local Q6 and crystalline particles in layers of
one mean diameter, and the container section of ``spherejam analyze`` (docs/containers_structure.md).

Layer m holds the spheres whose centre lies between m and m + 1 mean diameters from the nearest wall
(``container.wall_distance``): a sphere touching a wall has its centre at r_i from it, so the wall layer is layer 0.
Flat walls order the first layers (they seed crystals at slow growth), which the local Q6 and the crystalline
fraction by layer show; a sphere at a wall has fewer bonds, which biases its local q6 upwards, so compare a layer
with the same layer of another packing, not with the bulk value.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..core.errors import require
from ..core.packing import Packing
from . import profiles
from .contacts import ContactAnalysis

#: Layer width, in mean diameters.
LAYER_WIDTH = 1.0


def _finite_or_none(x):
    x = float(x)
    return x if math.isfinite(x) else None


@dataclass(frozen=True)
class Layers:
    """Per-layer statistics (arrays of one entry per layer; NaN where a layer holds no sphere: not estimable)."""

    edges: np.ndarray  #: layer edges, distance of the centre from the nearest wall in mean diameters
    n: np.ndarray  #: spheres in the layer
    contacts_mean: np.ndarray  #: mean contacts of a sphere, walls included
    wall_contacts_mean: np.ndarray  #: mean sphere-wall contacts of a sphere
    rattler_fraction: np.ndarray
    q6_local: np.ndarray  #: mean local Steinhardt q6 of the layer's spheres with neighbours
    crystalline_fraction: np.ndarray

    def as_dict(self) -> dict:
        out = {"edges": self.edges.tolist(), "n": self.n.tolist()}
        for name in ("contacts_mean", "wall_contacts_mean", "rattler_fraction", "q6_local", "crystalline_fraction"):
            out[name] = [_finite_or_none(x) for x in getattr(self, name)]
        return out


def layer_index(packing: Packing, width: float = LAYER_WIDTH) -> np.ndarray:
    """The layer of each sphere: floor(distance of its centre from the nearest wall / (width <d>))."""
    require(math.isfinite(width) and width > 0, "layer_width", width, "must be a finite number > 0 (mean diameters)")
    require(packing.container.has_walls, "container", packing.container.spec, "has no wall to count layers from")
    return np.floor(packing.container.wall_distance(packing.positions) / (width * packing.mean_diameter)).astype(int)


def by_layer(packing: Packing, contacts: ContactAnalysis, q6_per_particle: np.ndarray | None = None,
             crystalline: np.ndarray | None = None, width: float = LAYER_WIDTH) -> Layers:
    """Contacts, rattlers, local q6 and crystalline particles of each layer of ``width`` mean diameters."""
    layer = layer_index(packing, width)
    m = int(layer.max()) + 1
    n = np.bincount(layer, minlength=m)

    def mean(values):
        values = np.asarray(values, dtype=np.float64)
        ok = np.isfinite(values)
        s = np.bincount(layer[ok], values[ok], minlength=m)
        c = np.bincount(layer[ok], minlength=m)
        with np.errstate(invalid="ignore", divide="ignore"):
            return np.where(c > 0, s / np.maximum(c, 1), math.nan)

    walls = np.bincount(contacts.wall_i, minlength=packing.n)
    nan = np.full(packing.n, math.nan)
    return Layers(
        edges=np.arange(m + 1) * float(width),
        n=n,
        contacts_mean=mean(contacts.contacts_per_particle),
        wall_contacts_mean=mean(walls),
        rattler_fraction=mean(contacts.rattler),
        q6_local=mean(nan if q6_per_particle is None else q6_per_particle),
        crystalline_fraction=mean(nan if crystalline is None else crystalline),
    )


def container_record(packing: Packing, contacts: ContactAnalysis, q6_per_particle: np.ndarray | None = None,
                     crystalline: np.ndarray | None = None, bin_width: float = profiles.DEFAULT_BIN_WIDTH,
                     core_distance: float = profiles.DEFAULT_CORE_DISTANCE) -> dict:
    """The container section of the analysis record: the container, its achieved lengths in mean diameters, phi,
    the core phi, the porosity profile, the wall contacts and the statistics by layer."""
    c = packing.container
    core = profiles.core(packing, core_distance)
    prof = profiles.profile(packing, bin_width)
    return {
        "spec": c.spec,
        "achieved": c.in_diameters(packing.mean_diameter),
        "phi": packing.phi,
        "core": {"distance": core.distance, "phi": _finite_or_none(core.phi),
                 "volume_fraction": core.fraction_of_container,
                 "note": None if core.volume > 0 else f"not estimable: no region {core_distance:g} d from every wall"},
        "wall_contacts": int(len(contacts.wall_i)),
        "isostatic_contacts": int(contacts.coordination.isostatic_contacts),
        "profile": None if prof is None else prof.as_dict(),
        "layers": by_layer(packing, contacts, q6_per_particle, crystalline).as_dict() if c.has_walls else None,
    }
