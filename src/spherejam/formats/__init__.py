"""Packing file formats of other codes, read and written (one module per format; docs/formats.md).

Every reader returns a :class:`~spherejam.core.packing.Packing` that passed the same checks as our HDF5 reader
(:func:`spherejam.core.packing_io.validated_packing`: shapes, finiteness, centres inside the box, no overlap beyond the
tolerance), or raises :class:`~spherejam.core.errors.PackingFileError` naming the file and the problem. Every writer
writes through :mod:`spherejam.core.atomic`, so a failure leaves nothing at the output path.
"""

from __future__ import annotations

import importlib
import os
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

from ..core.errors import InputError

if TYPE_CHECKING:  # the CLI imports this module to list the formats; the engines' numba stays unloaded
    from ..core.packing import Packing


@dataclass(frozen=True)
class Format:
    """One file format: the module holding its ``read``/``write``, its file suffix and a one-line description."""

    name: str
    module: str
    suffix: str
    description: str
    readable: bool = True


FORMATS = {f.name: f for f in (
    Format("xyz", "spherejam.core.packing_io", ".xyz", "extended XYZ (OVITO, ASE), radius per particle",
           readable=False),
    Format("packing-generation", f"{__name__}.packing_generation", "",
           "packing-generation (C++): folder with packing.xyzd, packing.nfo, generation.conf"),
    Format("calippso-jl", f"{__name__}.calippso_jl", ".dat", "CALiPPSO.jl example input: d, N, diameter, centres"),
    Format("gsd", f"{__name__}.gsd", ".gsd", "GSD (HOOMD-blue, OVITO), one frame"),
    Format("lammps", f"{__name__}.lammps", ".data", "LAMMPS data file, atom style sphere"),
)}
READABLE = tuple(name for name, f in FORMATS.items() if f.readable)

_SUFFIXES = {".xyzd": "packing-generation", ".nfo": "packing-generation", ".conf": "packing-generation",
             ".dat": "calippso-jl", ".gsd": "gsd", ".data": "lammps", ".lmp": "lammps"}


def guess_format(path: str | os.PathLike) -> str:
    """The readable format of ``path`` from its suffix (a folder is a packing-generation file set)."""
    path = Path(path)
    if path.is_dir():
        return "packing-generation"
    name = _SUFFIXES.get(path.suffix.lower())
    if path.suffix.lower() == ".h5":
        raise InputError(f"{path}: already a spherejam packing file (HDF5); `spherejam check` validates it")
    if name is None:
        raise InputError(f"{path}: cannot tell the format from the suffix {path.suffix!r}; give --format "
                         f"({', '.join(READABLE)})")
    return name


def _module(name: str):
    if name not in FORMATS:
        raise InputError(f"format={name!r}: must be one of {', '.join(FORMATS)}")
    return importlib.import_module(FORMATS[name].module)


def read(path: str | os.PathLike, fmt: str | None = None, **options) -> Packing:
    """Read and validate a packing in format ``fmt`` (default: from the suffix). ``options``: ``tolerance``
    (relative overlap, default 1e-10; None skips the overlap check), ``box`` for calippso-jl, ``frame`` for gsd.

    Overlaps that a looser ``tolerance`` lets through (the round-off of a float32 file) are removed: see
    :func:`remove_round_off_overlaps`. The packing returned never overlaps beyond the default tolerance."""
    fmt = fmt or guess_format(path)
    module = _module(fmt)
    if not FORMATS[fmt].readable:
        raise InputError(f"format={fmt!r}: can be written, not read; readable: {', '.join(READABLE)}")
    path = Path(path)
    if path.is_dir() and fmt != "packing-generation":
        raise InputError(f"{path}: is a directory; the {fmt} format is one file (a folder is a packing-generation "
                         "file set: --format packing-generation)")
    packing = module.read(path, **options)
    return packing if options.get("tolerance") is None else remove_round_off_overlaps(packing)


def remove_round_off_overlaps(packing: Packing) -> Packing:
    """``packing`` with every diameter multiplied by the smallest normalised distance s = min r_ij/D_ij if s < 1
    (all pairs then touch at most), the factor recorded as ``source.diameter_scale``; unchanged otherwise.

    A file read with a loose tolerance (float32 positions of a jammed packing overlap by ~1e-7) would otherwise
    become a packing that every other command refuses. One common factor keeps the size ratios, and s - 1 is the
    round-off of the file, far below anything the file can resolve."""
    from ..core.packing import DEFAULT_OVERLAP_TOLERANCE

    if packing.check(DEFAULT_OVERLAP_TOLERANCE).ok:
        return packing
    _, _, scale = packing.closest_pair()
    meta = dict(packing.metadata)
    source = dict(meta.get("source", {}))
    note = f"diameters scaled by {scale!r} to remove overlaps of up to {1 - scale:.2g} (round-off of the file)"
    source.update(diameter_scale=scale, note="; ".join(filter(None, (source.get("note"), note))))
    meta["source"] = source
    return packing.replace(diameters=packing.diameters * scale, metadata=meta)


#: The formats that can hold a container other than the periodic cube (docs/containers.md §6).
CONTAINER_FORMATS = ("xyz", "lammps")


def write(packing: Packing, path: str | os.PathLike, fmt: str) -> list[Path]:
    """Write ``packing`` in format ``fmt``; returns the files written. A container the format cannot represent is
    refused in one line."""
    module = _module(fmt)
    if not packing.container.is_periodic_cube and fmt not in CONTAINER_FORMATS:
        raise InputError(f"format={fmt!r}: holds only a periodic cube, not container {packing.container.spec} "
                         f"(formats with containers: {', '.join(CONTAINER_FORMATS)})")
    out = module.export_xyz(packing, path) if fmt == "xyz" else module.write(packing, path)
    return out if isinstance(out, list) else [out]


def default_output(path: str | os.PathLike, fmt: str) -> Path:
    """Default output of exporting ``path``: its suffix replaced by the format's (packing-generation: the folder
    ``<stem>-packing-generation``)."""
    path = Path(path)
    f = FORMATS[fmt]
    return path.with_name(f"{path.stem}-{fmt}") if not f.suffix else path.with_suffix(f.suffix)
