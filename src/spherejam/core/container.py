"""The container of a packing: a periodic box, a slab, a closed box, a cylinder or a sphere (docs/containers.md).

Every container lives in a rectangular **frame** [0, L_0) x [0, L_1) x [0, L_2) (the packing's coordinates). Along
a *periodic* axis the frame repeats; along a *walled* axis it does not, and no periodic image of a sphere exists
there. The walls are

* flat walls (``planes``): the two planes x_k = 0 and x_k = L_k of a walled axis k (slab, closed box, the caps of a
  capped cylinder);
* one curved wall (``curved``): the cylinder |x_perp - c_perp| = R around ``axis`` (periodic along it unless
  capped), or the sphere |x - c| = R, centred in the frame (c_k = L_k / 2).

A container is named by a **spec**, ``shape:parameters``, in the style of the size distributions
(core/size_distribution):

=============================================  ============================================================
``periodic``                                   the periodic cube (the default; N fixes its side)
``periodic:x=10,y=10,z=40``                    a periodic box with three edge lengths (any may be left out)
``slab:height=8``                              walls at z = 0 and z = height, periodic along x and y
``box:x=10,y=10,z=10``                         a closed box (any length may be left out)
``cylinder:diameter=10,length=20,capped=yes``  a cylinder along z, periodic along z unless capped
``sphere:diameter=12``                         a spherical container
=============================================  ============================================================

Lengths are in **number-mean diameters of the final packing** (D/<d>), as a user thinks of a column. Spheres grow
during generation, so the final <d> is known only at the end: :func:`build` sets the frame in the length unit of
the nominal diameters (mean 1) from an estimate of the final packing fraction, solving the lengths the spec leaves
out from N (or N from the lengths, when the spec fixes them all), and a packing reports its achieved D/<d>
exactly (:meth:`Container.in_diameters`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import numpy as np

from .errors import InputError

SHAPES = ("periodic", "slab", "box", "cylinder", "sphere")
AXES = "xyz"
#: The packing fraction assumed when a container is sized before its packing exists (the final phi of fast LS and
#: of MLS lies between 0.58 and 0.66 for the paper's spheres; the achieved D/<d> is reported exactly).
PHI_ESTIMATE = 0.62
#: Curved-wall codes of the engine's wall array (:meth:`Container.wall_array`).
NO_CURVED, CYLINDER, SPHERE = 0, 1, 2

_PARAMETERS = {
    "periodic": {"x": float, "y": float, "z": float},
    "slab": {"height": float},
    "box": {"x": float, "y": float, "z": float},
    "cylinder": {"diameter": float, "length": float, "capped": bool},
    "sphere": {"diameter": float},
}
_USAGE = {
    "periodic": "periodic or periodic:x=L,y=L,z=L",
    "slab": "slab:height=H",
    "box": "box:x=L,y=L,z=L",
    "cylinder": "cylinder:diameter=D[,length=L][,capped=yes]",
    "sphere": "sphere:diameter=D",
}


@dataclass(frozen=True)
class ContainerSpec:
    """A parsed container spec: its shape and the lengths it gives, in mean diameters of the final packing
    (None: left to N). ``text`` is the spec in canonical form (floats by repr, so it parses back to the same)."""

    shape: str
    lengths: dict = field(default_factory=dict)
    capped: bool = False

    @property
    def text(self) -> str:
        if self.shape == "periodic" and not self.lengths:
            return "periodic"
        items = [f"{k}={self.lengths[k]!r}" for k in _PARAMETERS[self.shape] if self.lengths.get(k) is not None]
        if self.shape == "cylinder" and self.capped:
            items.append("capped=yes")
        return f"{self.shape}:{','.join(items)}"

    @property
    def is_periodic(self) -> bool:
        return self.shape == "periodic"


def parse(spec: str | ContainerSpec | None, field_name: str = "container") -> ContainerSpec:
    """Parse a container spec (see the module docstring); None is the periodic cube. Bad specs raise
    :class:`InputError` naming the field and the value."""
    if spec is None:
        return ContainerSpec("periodic")
    if isinstance(spec, ContainerSpec):
        return spec
    if not isinstance(spec, str) or not spec.strip():
        raise InputError(f"{field_name}={spec!r}: must be a container spec, e.g. cylinder:diameter=10 "
                         f"(one of {', '.join(SHAPES)})")
    text = spec.strip()
    shape, _, rest = text.partition(":")
    shape = shape.strip().lower()
    if shape not in SHAPES:
        raise InputError(f"{field_name}={spec!r}: unknown shape {shape!r} (one of {', '.join(SHAPES)})")
    kinds = _PARAMETERS[shape]
    values: dict = {}
    for item in filter(None, (s.strip() for s in rest.split(","))):
        key, eq, value = (s.strip() for s in item.partition("="))
        if not eq:
            raise InputError(f"{field_name}={spec!r}: {item!r} must be NAME=VALUE ({_USAGE[shape]})")
        if key not in kinds:
            raise InputError(f"{field_name}={spec!r}: unknown parameter {key!r} ({_USAGE[shape]})")
        if key in values:
            raise InputError(f"{field_name}={spec!r}: parameter {key!r} given twice")
        if kinds[key] is bool:
            if value.lower() not in ("yes", "no", "true", "false"):
                raise InputError(f"{field_name}={spec!r}: {shape}.{key}={value!r}: must be yes or no")
            values[key] = value.lower() in ("yes", "true")
            continue
        try:
            number = float(value)
        except ValueError:
            raise InputError(f"{field_name}={spec!r}: {shape}.{key}={value!r}: must be a number") from None
        if not (math.isfinite(number) and number > 0):
            raise InputError(f"{field_name}={spec!r}: {shape}.{key}={value!r}: must be a finite number > 0")
        values[key] = number
    capped = bool(values.pop("capped", False))
    required = {"slab": "height", "cylinder": "diameter", "sphere": "diameter"}.get(shape)
    if required and required not in values:
        raise InputError(f"{field_name}={spec!r}: {shape}.{required} missing ({_USAGE[shape]})")
    return ContainerSpec(shape, values, capped)


@dataclass(frozen=True)
class Container:
    """A container in the packing's length unit (see the module docstring).

    ``lengths`` are the frame's edges L_k; ``periodic[k]`` whether axis k repeats; ``planes[k]`` whether axis k has
    flat walls at 0 and L_k; ``curved`` is ``"cylinder"``, ``"sphere"`` or None, of radius ``radius`` around the
    frame's centre (a cylinder along ``axis``). ``spec`` is the spec the container was built from (its lengths in
    mean diameters of the final packing, as asked; the achieved ones are :meth:`in_diameters`).
    """

    lengths: tuple
    periodic: tuple
    planes: tuple
    curved: str | None = None
    radius: float = 0.0
    axis: int = 2
    spec: str = "periodic"

    def __post_init__(self) -> None:
        lengths = tuple(float(x) for x in self.lengths)
        if not lengths or not all(math.isfinite(x) and x > 0 for x in lengths):
            raise InputError(f"container lengths={self.lengths!r}: must be finite numbers > 0")
        dim = len(lengths)
        periodic = tuple(bool(p) for p in self.periodic)
        planes = tuple(bool(p) for p in self.planes)
        if len(periodic) != dim or len(planes) != dim:
            raise InputError(f"container: periodic and planes must have one flag per axis ({dim})")
        if any(p and q for p, q in zip(periodic, planes)):
            raise InputError("container: an axis cannot be both periodic and walled")
        if self.curved not in (None, "cylinder", "sphere"):
            raise InputError(f"container curved={self.curved!r}: must be cylinder, sphere or None")
        if self.curved is not None and not (math.isfinite(self.radius) and self.radius > 0):
            raise InputError(f"container radius={self.radius!r}: must be a finite number > 0")
        object.__setattr__(self, "lengths", lengths)
        object.__setattr__(self, "periodic", periodic)
        object.__setattr__(self, "planes", planes)

    # --- constructors -------------------------------------------------------------------------------------------
    @classmethod
    def cube(cls, side: float, dim: int = 3) -> Container:
        """The periodic cube of side L (every packing before containers)."""
        return cls((side,) * dim, (True,) * dim, (False,) * dim)

    # --- properties -------------------------------------------------------------------------------------------
    @property
    def dim(self) -> int:
        return len(self.lengths)

    @property
    def shape(self) -> str:
        return self.spec.partition(":")[0]

    @property
    def is_periodic_cube(self) -> bool:
        """A periodic cube: every code path of the package handles it (the frame side is ``side``)."""
        return all(self.periodic) and len(set(self.lengths)) == 1

    @property
    def side(self) -> float:
        """The side L of a periodic cube (an error for any other container)."""
        if not self.is_periodic_cube:
            raise InputError(f"container {self.spec}: has no single periodic side (not a periodic cube)")
        return self.lengths[0]

    @property
    def has_walls(self) -> bool:
        return any(self.planes) or self.curved is not None

    @property
    def centre(self) -> np.ndarray:
        return 0.5 * np.asarray(self.lengths)

    @property
    def volume(self) -> float:
        """The volume inside the walls (the frame's volume for a periodic box or a slab)."""
        if self.curved == "sphere":
            return 4.0 / 3.0 * math.pi * self.radius**3
        if self.curved == "cylinder":
            return math.pi * self.radius**2 * self.lengths[self.axis]
        return float(np.prod(self.lengths))

    def wall_area(self) -> float:
        """Area of the walls (0 for a periodic box)."""
        area = 0.0
        for k in range(self.dim):
            if self.planes[k]:
                others = [self.lengths[q] for q in range(self.dim) if q != k]
                area += 2.0 * float(np.prod(others))
        if self.curved == "cylinder":
            area += 2.0 * math.pi * self.radius * self.lengths[self.axis]
            if self.planes[self.axis]:  # the caps are discs, not the frame's squares
                area -= 2.0 * (float(np.prod([self.lengths[q] for q in range(self.dim) if q != self.axis]))
                               - math.pi * self.radius**2)
        elif self.curved == "sphere":
            area = 4.0 * math.pi * self.radius**2
        return area

    @property
    def zero_modes(self) -> int:
        """The rigid motions of all spheres together that no contact resists (docs/containers.md §4): a translation
        along each periodic axis, the rotation about a cylinder's axis, the three rotations in a sphere. A flat wall
        or a periodic frame across an axis breaks every rotation but those."""
        modes = sum(self.periodic)
        if self.curved == "cylinder":
            modes += 1  # rotation about the axis (translation along it, if periodic, is counted above)
        elif self.curved == "sphere":
            modes += 3 if self.dim == 3 else 1
        return modes

    def isostatic_contacts(self, n: int, free: int = 0) -> int:
        """The contact count (sphere-sphere and sphere-wall) of an isostatic jammed packing of ``n`` non-rattlers:
        d n degrees of freedom, less the zero modes, plus one for the pressure (Gamma in CALiPPSO's LP); d (n - 1)
        + 1 in a periodic box. Less ``free``, the directions of partial rattlers that no contact loads
        (docs/containers.md §4)."""
        return self.dim * n - self.zero_modes + 1 - free

    def in_diameters(self, mean_diameter: float) -> dict:
        """The container's lengths in units of ``mean_diameter`` (the achieved D/<d>, L/<d>, ...)."""
        out = {}
        if self.curved is not None:
            out["diameter"] = 2.0 * self.radius / mean_diameter
        if self.curved == "cylinder":
            out["length"] = self.lengths[self.axis] / mean_diameter
        elif self.curved is None:
            for k in range(self.dim):
                out[AXES[k] if self.dim <= 3 else f"x{k}"] = self.lengths[k] / mean_diameter
            if self.shape == "slab":
                out["height"] = out[AXES[self.dim - 1]]
        return out

    # --- geometry -----------------------------------------------------------------------------------------------
    def wall_distance(self, positions: np.ndarray) -> np.ndarray:
        """Distance from each centre to its nearest wall (inf where there is none): a sphere of radius r is inside
        iff r <= that distance."""
        x = np.asarray(positions, dtype=np.float64)
        dist = np.full(len(x), np.inf)
        for k in range(self.dim):
            if self.planes[k]:
                dist = np.minimum(dist, np.minimum(x[:, k], self.lengths[k] - x[:, k]))
        if self.curved is not None:
            p = x - self.centre
            if self.curved == "cylinder":
                p = np.delete(p, self.axis, axis=1)
            dist = np.minimum(dist, self.radius - np.sqrt(np.einsum("ij,ij->i", p, p)))
        return dist

    def contains(self, positions: np.ndarray) -> np.ndarray:
        """Whether each point lies inside the frame and strictly inside every wall."""
        x = np.asarray(positions, dtype=np.float64)
        inside = np.all((x >= 0) & (x < np.asarray(self.lengths)), axis=1)
        return inside & (self.wall_distance(x) > 0)

    def wall_penetration(self, positions: np.ndarray, diameters: np.ndarray) -> tuple[float, int]:
        """``(worst, i)``: the largest relative penetration (r_i - distance_i) / r_i of a sphere into a wall (<= 0:
        none) and its sphere (-inf, -1 without walls)."""
        if not self.has_walls:
            return -math.inf, -1
        r = 0.5 * np.asarray(diameters, dtype=np.float64)
        pen = (r - self.wall_distance(positions)) / r
        i = int(np.argmax(pen))
        return float(pen[i]), i

    def max_scale(self, positions: np.ndarray, diameters: np.ndarray) -> float:
        """The largest factor by which the diameters may grow before a sphere meets a wall (inf without walls)."""
        if not self.has_walls:
            return math.inf
        return float(np.min(self.wall_distance(positions) / (0.5 * np.asarray(diameters))))

    def wrap(self, positions: np.ndarray) -> np.ndarray:
        """Positions folded into [0, L_k) along the periodic axes (walled axes untouched)."""
        x = np.array(positions, dtype=np.float64, copy=True)
        for k in range(self.dim):
            if self.periodic[k]:
                x[:, k] = np.mod(x[:, k], self.lengths[k])
                x[x[:, k] >= self.lengths[k], k] = 0.0  # np.mod can round up to L for tiny negatives
        return x

    def half_lengths(self) -> np.ndarray:
        """L_k / 2 along periodic axes and +inf along walled ones: a difference folds (minimum image) only where
        it is larger than this, so a walled axis never folds."""
        return np.array([0.5 * L if p else np.inf for L, p in zip(self.lengths, self.periodic)])

    def wall_array(self) -> np.ndarray:
        """The walls for the engines' kernels, one float64 array: [planes_0..2, curved code, axis, c_0..2, R]."""
        curved = {None: NO_CURVED, "cylinder": CYLINDER, "sphere": SPHERE}[self.curved]
        c = self.centre
        return np.array([*map(float, self.planes), float(curved), float(self.axis), *c, float(self.radius)])

    def scaled(self, factor: float) -> Container:
        """The same container with every length multiplied by ``factor``."""
        return replace(self, lengths=tuple(factor * x for x in self.lengths), radius=factor * self.radius)

    # --- persistence --------------------------------------------------------------------------------------------
    def to_dict(self) -> dict:
        return {"spec": self.spec, "lengths": list(self.lengths), "periodic": list(self.periodic),
                "planes": list(self.planes), "curved": self.curved, "radius": self.radius, "axis": self.axis}

    @classmethod
    def from_dict(cls, d: dict) -> Container:
        try:
            return cls(tuple(d["lengths"]), tuple(d["periodic"]), tuple(d["planes"]), d.get("curved"),
                       float(d.get("radius", 0.0)), int(d.get("axis", 2)), str(d.get("spec", "periodic")))
        except (KeyError, TypeError, ValueError) as exc:
            raise InputError(f"container={d!r}: not a container record ({exc})") from None

    def __str__(self) -> str:
        return self.spec


def _solve_free(spec: ContainerSpec, volume: float) -> dict:
    """The spec's lengths (in units of the nominal mean diameter, scale factor 1) with the free ones solved so that
    the container's volume is ``volume``."""
    given = dict(spec.lengths)
    if spec.shape in ("periodic", "box"):
        free = [k for k in "xyz" if k not in given]
        fixed = float(np.prod([given[k] for k in "xyz" if k in given])) if len(free) < 3 else 1.0
        side = (volume / fixed) ** (1.0 / len(free)) if free else None
        return {k: given.get(k, side) for k in "xyz"}
    if spec.shape == "slab":
        h = given["height"]
        side = math.sqrt(volume / h)
        return {"x": side, "y": side, "z": h}
    if spec.shape == "cylinder":
        d = given["diameter"]
        length = given.get("length", volume / (math.pi * d * d / 4.0))
        return {"diameter": d, "length": length}
    return dict(given)  # sphere


def _fixes_n(spec: ContainerSpec) -> bool:
    """Whether the spec gives every length (so it fixes N through the packing-fraction estimate)."""
    return {"periodic": len(spec.lengths) == 3, "box": len(spec.lengths) == 3, "slab": False,
            "cylinder": "length" in spec.lengths, "sphere": True}[spec.shape]


def number_for(spec: str | ContainerSpec, mean_ball_volume: float, phi_estimate: float = PHI_ESTIMATE) -> int | None:
    """N for a spec that fixes every length (None otherwise): the number of spheres of mean volume
    ``mean_ball_volume`` (in mean diameters cubed) that fill it at ``phi_estimate``."""
    spec = parse(spec)
    if not _fixes_n(spec):
        return None
    lengths = _solve_free(spec, 1.0)
    return max(int(round(phi_estimate * _make(spec, lengths).volume / mean_ball_volume)), 0)


def _make(spec: ContainerSpec, lengths: dict) -> Container:
    text = spec.text
    if spec.shape in ("periodic", "box"):
        walled = spec.shape == "box"
        return Container(tuple(lengths[k] for k in "xyz"), (not walled,) * 3, (walled,) * 3, spec=text)
    if spec.shape == "slab":
        return Container((lengths["x"], lengths["y"], lengths["z"]), (True, True, False), (False, False, True),
                         spec=text)
    if spec.shape == "cylinder":
        d = lengths["diameter"]
        return Container((d, d, lengths["length"]), (False, False, not spec.capped), (False, False, spec.capped),
                         curved="cylinder", radius=d / 2.0, axis=2, spec=text)
    d = lengths["diameter"]
    return Container((d, d, d), (False,) * 3, (False,) * 3, curved="sphere", radius=d / 2.0, spec=text)


def build(spec: str | ContainerSpec | None, n: int | None, nominal: np.ndarray,
          phi_estimate: float = PHI_ESTIMATE, dim: int = 3) -> Container:
    """The container of a spec for N spheres of nominal diameters ``nominal`` (mean 1), in their length unit.

    The spec's lengths are taken in mean diameters; the lengths it leaves out are solved so that the spheres fill
    the container at ``phi_estimate`` (the periodic cube: the side of the cube they fill at it). A spec that gives
    every length fixes N (:func:`number_for`); ``n`` must then be None or that number. A container that cannot
    hold its spheres (a length below the largest diameter, or N too large for it) is refused in one line.
    """
    spec = parse(spec)
    if dim != 3 and not spec.is_periodic:
        raise InputError(f"container={spec.text!r}: walls are implemented in d = 3 only (dim={dim})")
    nominal = np.asarray(nominal, dtype=np.float64)
    volume_of_spheres = float(np.sum(math.pi ** (dim / 2) / math.gamma(dim / 2 + 1) * (nominal / 2.0) ** dim))
    if spec.is_periodic and not spec.lengths:
        return Container.cube((volume_of_spheres / phi_estimate) ** (1.0 / dim), dim)
    lengths = _solve_free(spec, volume_of_spheres / phi_estimate)
    container = _make(spec, lengths)
    if _fixes_n(spec):
        expected = number_for(spec, volume_of_spheres / len(nominal), phi_estimate)
        if n is not None and n != len(nominal):
            raise InputError(f"n={n}: does not match the {len(nominal)} diameters given")
        fill = volume_of_spheres / container.volume
        if not 0.5 * phi_estimate <= fill <= min(1.5 * phi_estimate, 0.74):
            raise InputError(f"container={spec.text!r}: {len(nominal)} spheres would fill it to phi = {fill:.3g}; "
                             f"it holds about {expected} (give n={expected}, or leave a length free)")
    dmax = float(nominal.max())
    for name, value in spec.lengths.items():
        if value < 1.0 or value < dmax * 1.05:
            raise InputError(f"container={spec.text!r}: {name}={value!r} mean diameters cannot hold a sphere of "
                             f"{dmax:.3g} mean diameters (the largest of the sample)")
    for k in range(dim):
        walled = container.planes[k]
        if container.lengths[k] < (1.05 * dmax if walled else dmax) and (walled or container.periodic[k]):
            kind = "walled" if walled else "periodic"
            raise InputError(f"container={spec.text!r}: its {kind} length along {AXES[k]} "
                             f"({container.lengths[k]:.3g} mean diameters at N = {len(nominal)}) is below the largest "
                             f"sphere ({dmax:.3g}); take a larger N or give that length")
    return container
