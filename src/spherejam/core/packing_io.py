"""One HDF5 file per packing, written atomically and validated on read; export to extended XYZ.

Layout of a packing file::

    /positions   (N, d) float64, in [0, L)
    /diameters   (N,)   float64, actual diameters
    /history/*   optional per-window (or per-iteration) columns of the run that made it
    /<group>/*   optional extra arrays (e.g. /contacts/forces of a CALiPPSO packing)
    attrs: format, box, dim, n, phi, algorithm, seed, reduced_pressure, parameters (JSON), counters (JSON),
           metadata (JSON, everything else), spherejam_version, git_commit, created, package_versions (JSON),
           container (JSON, only for a container other than the periodic cube, whose box is then NaN)
"""

from __future__ import annotations

import json
import math
import os
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

from .atomic import atomic_output
from .container import Container
from .errors import OverlapError, PackingFileError
from .input_paths import regular_file
from .packing import DEFAULT_OVERLAP_TOLERANCE, Packing
from .provenance import provenance
from .validation import BOX_SIDE

FORMAT = "spherejam-packing-1"
_SCALAR_KEYS = ("algorithm", "seed", "reduced_pressure")
_JSON_KEYS = ("parameters", "counters")


def _h5py():
    import h5py  # deferred: keeps `spherejam --help` fast

    return h5py


def _json_default(obj):
    if isinstance(obj, np.generic):
        return obj.item()
    if isinstance(obj, np.ndarray):
        return obj.tolist()
    raise TypeError(f"not JSON serialisable: {type(obj).__name__}")


def dumps(obj) -> str:
    return json.dumps(obj, default=_json_default, sort_keys=True)


def write_packing(
    path: str | os.PathLike,
    packing: Packing,
    history: Mapping[str, np.ndarray] | None = None,
    tolerance: float = DEFAULT_OVERLAP_TOLERANCE,
    groups: Mapping[str, Mapping[str, np.ndarray]] | None = None,
) -> Path:
    """Validate ``packing`` and write it (plus an optional run history and extra array groups) atomically.

    Raises :class:`OverlapError` (and writes nothing) if the packing overlaps beyond ``tolerance``.
    """
    path = Path(path)
    for side in packing.container.lengths:
        if not BOX_SIDE.ok(side):
            raise PackingFileError(f"refusing to write {path}: box side {side!r}; {BOX_SIDE.rule()} (L**d must "
                                   "stay a finite number)")
    packing.validate(tolerance, what=f"refusing to write {path}")
    h5py = _h5py()
    meta = dict(packing.metadata)
    with atomic_output(path, ".h5") as tmp:
        with h5py.File(tmp, "w") as f:
            f.create_dataset("positions", data=packing.positions)
            f.create_dataset("diameters", data=packing.diameters)
            a = f.attrs
            a["format"] = FORMAT
            a["box"] = packing.box
            a["dim"] = packing.dim
            a["n"] = packing.n
            a["phi"] = packing.phi
            if not packing.container.is_periodic_cube:
                a["container"] = dumps(packing.container.to_dict())
            for key in _SCALAR_KEYS:
                value = meta.pop(key, None)
                if value is not None:
                    a[key] = value
            for key in _JSON_KEYS:
                a[key] = dumps(meta.pop(key, {}))
            a["metadata"] = dumps(meta)
            prov = provenance()
            a["spherejam_version"] = prov["spherejam_version"]
            a["git_commit"] = prov["git_commit"]
            a["created"] = prov["created"]
            a["package_versions"] = dumps(prov["package_versions"])
            for group_name, arrays in {"history": history or {}, **(groups or {})}.items():
                if arrays:
                    g = f.create_group(group_name)
                    for name, column in arrays.items():
                        g.create_dataset(name, data=np.asarray(column))
    return path


def read_group(path: str | os.PathLike, group: str) -> dict[str, np.ndarray]:
    """The arrays of one extra group of a packing file (empty if the group is absent)."""
    path = regular_file(path, "packing file", missing="no such file")
    h5py = _h5py()
    try:
        with h5py.File(path, "r") as f:
            if group not in f:
                return {}
            return {k: v[()] for k, v in f[group].items()}
    except OSError as exc:
        reject_file(path, f"not a readable HDF5 packing file ({str(exc).splitlines()[0]})")


def reject_file(path, problem: str):
    """Raise the one-line error of a bad input file: ``<path>: <problem>``."""
    raise PackingFileError(f"{path}: {problem}")


def _read_attrs(path, f) -> dict[str, Any]:
    a = f.attrs
    if a.get("format") != FORMAT:
        reject_file(path, f"not a spherejam packing file (format attribute is {a.get('format')!r}, "
                          f"expected {FORMAT!r})")
    meta: dict[str, Any] = {}
    try:
        meta.update(json.loads(a.get("metadata", "{}")))
        for key in _JSON_KEYS:
            meta[key] = json.loads(a.get(key, "{}"))
        meta["provenance"] = {
            "spherejam_version": str(a.get("spherejam_version", "")),
            "git_commit": str(a.get("git_commit", "")),
            "created": str(a.get("created", "")),
            "package_versions": json.loads(a.get("package_versions", "{}")),
        }
    except (json.JSONDecodeError, TypeError) as exc:
        reject_file(path, f"corrupt JSON attribute ({exc})")
    for key in _SCALAR_KEYS:
        if key in a:
            value = a[key]
            meta[key] = value.item() if isinstance(value, np.generic) else value
    return meta


def read_packing(
    path: str | os.PathLike,
    tolerance: float | None = DEFAULT_OVERLAP_TOLERANCE,
    with_history: bool = False,
):
    """Read and validate a packing file.

    Checks the format tag, shapes, dtypes, finiteness, that centres lie in [0, L), and (unless ``tolerance`` is
    None) that no pair overlaps beyond ``tolerance``. Any problem raises :class:`PackingFileError` naming the file.
    Returns the packing, or ``(packing, history)`` if ``with_history``.
    """
    path = regular_file(path, "packing file", missing="no such file")
    h5py = _h5py()
    try:
        with h5py.File(path, "r") as f:
            meta = _read_attrs(path, f)
            for name in ("positions", "diameters"):
                if name not in f or not isinstance(f[name], h5py.Dataset):
                    reject_file(path, f"missing dataset '{name}'")
            pos_ds, dia_ds = f["positions"], f["diameters"]
            if pos_ds.dtype != np.float64 or dia_ds.dtype != np.float64:
                reject_file(path, f"datasets must be float64 (positions {pos_ds.dtype}, diameters {dia_ds.dtype})")
            positions = pos_ds[()]
            diameters = dia_ds[()]
            box = float(f.attrs.get("box", math.nan))
            container = f.attrs.get("container")
            history = None
            if with_history and "history" in f:
                history = {k: v[()] for k, v in f["history"].items()}
    except PackingFileError:
        raise
    except (OSError, KeyError, ValueError, TypeError) as exc:
        # h5py reports truncated or non-HDF5 files as OSError with internal detail; keep the first line only.
        reason = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        reject_file(path, f"not a readable HDF5 packing file ({reason})")
    if container is not None:
        try:
            container = Container.from_dict(json.loads(container))
        except (json.JSONDecodeError, TypeError, ValueError) as exc:
            reject_file(path, f"corrupt container attribute ({str(exc).splitlines()[0]})")
    packing = validated_packing(path, positions, diameters, box, meta, tolerance, container)
    return (packing, history or {}) if with_history else packing


def validated_packing(
    path, positions: np.ndarray, diameters: np.ndarray, box: float, metadata: dict[str, Any] | None = None,
    tolerance: float | None = DEFAULT_OVERLAP_TOLERANCE, container: Container | None = None,
) -> Packing:
    """The checks every packing reader runs (HDF5 and the other formats, :mod:`spherejam.formats`).

    Shapes, finiteness, centres in [0, L) (in the container's frame, and inside its walls), at least 2 spheres, and
    (unless ``tolerance`` is None) no pair overlapping and no sphere penetrating a wall beyond ``tolerance``; any
    problem raises :class:`PackingFileError` naming ``path``. ``container`` None is the periodic cube of side
    ``box``.
    """
    positions = np.asarray(positions)
    diameters = np.asarray(diameters)
    if positions.ndim != 2 or not 2 <= positions.shape[1] <= 5:
        reject_file(path, f"positions have shape {positions.shape}, expected (N, d) with 2 <= d <= 5")
    if diameters.shape != (positions.shape[0],):
        reject_file(path, f"diameters have shape {diameters.shape}, expected ({positions.shape[0]},)")
    if positions.shape[0] < 2:
        reject_file(path, f"holds {positions.shape[0]} sphere(s); a packing needs at least 2")
    if container is not None and container.dim != positions.shape[1]:
        reject_file(path, f"container {container.spec} has {container.dim} axes, positions have {positions.shape[1]}")
    sides = [box] if container is None else list(container.lengths)
    for side in sides:
        if not BOX_SIDE.ok(side):
            reject_file(path, f"box side is {side!r}; {BOX_SIDE.rule()} (L**d must stay a finite number)")
    if not np.all(np.isfinite(positions)):
        reject_file(path, "positions contain NaN or infinity")
    if not (np.all(np.isfinite(diameters)) and np.all(diameters > 0)):
        reject_file(path, "diameters must be finite and > 0")
    upper = box if container is None else np.asarray(container.lengths)
    if np.any(positions < 0) or np.any(positions >= upper):
        where = f"[0, {box})" if container is None else f"frame of container {container.spec}"
        reject_file(path, f"positions lie outside the box {where}")
    if container is not None and np.any(container.wall_distance(positions) < 0):
        reject_file(path, f"centres lie outside the walls of container {container.spec}")
    packing = Packing(positions, diameters, box, metadata or {}, container)
    if tolerance is not None:
        try:
            packing.validate(tolerance, what=str(path))
        except OverlapError as exc:
            raise PackingFileError(str(exc)) from None
    return packing


def export_xyz(packing: Packing, path: str | os.PathLike) -> Path:
    """Write extended XYZ (OVITO, ASE): species, position and per-particle ``radius``; d = 2 gets z = 0."""
    if packing.dim not in (2, 3):
        raise PackingFileError(f"{path}: extended XYZ holds 2D or 3D packings, this one has d={packing.dim}")
    pos = packing.positions
    if packing.dim == 2:
        pos = np.column_stack([pos, np.zeros(packing.n)])
    c = packing.container
    lx, ly = c.lengths[0], c.lengths[1]
    lz = c.lengths[2] if packing.dim == 3 else c.lengths[0]
    flags = [("T" if p else "F") for p in c.periodic] + ([] if packing.dim == 3 else ["F"])
    pbc = '"' + " ".join(flags) + '"'
    alg = str(packing.metadata.get("algorithm", "unknown"))
    where = "" if c.is_periodic_cube else f" container={c.spec}"
    header = (
        f'Lattice="{lx!r} 0.0 0.0 0.0 {ly!r} 0.0 0.0 0.0 {lz!r}" Origin="0.0 0.0 0.0" '
        f"Properties=species:S:1:pos:R:3:radius:R:1 pbc={pbc} phi={packing.phi!r} algorithm={alg}{where}"
    )
    radius = packing.diameters / 2.0
    lines = [str(packing.n), header]
    lines += [f"S {x!r} {y!r} {z!r} {r!r}" for (x, y, z), r in zip(pos.tolist(), radius.tolist())]
    path = Path(path)
    with atomic_output(path, ".xyz") as tmp:
        tmp.write_text("\n".join(lines) + "\n")
    return path
