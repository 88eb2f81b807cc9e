"""The file set of the C++ packing-generation code: ``packing.xyzd`` + ``packing.nfo`` + ``generation.conf``.

* ``packing.xyzd``: binary, per sphere ``x y z d`` as little-endian float64 (32 bytes a sphere), no header.
* ``generation.conf``: text ``Key: value`` lines; ``Particles count`` (N), ``Packing size`` (three box sides) and
  ``Boundaries mode`` (1 = periodic in all directions) are the ones a packing needs.
* ``packing.nfo``: text, written by a finished generation; ``Theoretical Porosity`` is 1 - phi of the diameters as
  stored, ``Final Porosity`` is 1 - phi of the final packing.

The stored diameters are those of the start, not the final ones: the final diameters are the stored ones times
s = ((1 - Final Porosity) / (1 - Theoretical Porosity))^(1/3) (docs/formats.md). The reader applies s and refuses a
file set whose sizes disagree (N, box, or a Theoretical Porosity that the stored diameters do not give). The writer
stores the actual diameters with both porosities equal (s = 1), so the code's post-processing, which reads the
diameters as stored, sees the right sizes.
"""

from __future__ import annotations

import math
import os
import re
from pathlib import Path

import numpy as np

from ..core.atomic import atomic_folder
from ..core.errors import PackingFileError
from ..core.packing import DEFAULT_OVERLAP_TOLERANCE, Packing, ball_volume
from ..core.input_paths import regular_file
from ..core.packing_io import reject_file, validated_packing
from ..core.validation import BOX_SIDE

XYZD, NFO, CONF = "packing.xyzd", "packing.nfo", "generation.conf"
#: Relative agreement required between the nfo's Theoretical Porosity density and that of the stored diameters
#: (the code prints porosities with 15 significant digits).
DENSITY_RTOL = 1e-9
#: Contraction rate written into generation.conf when the packing's own rate is unknown (the code needs one).
DEFAULT_CONTRACTION_RATE = 1e-4

_LINE = re.compile(r"^\s*([A-Za-z][A-Za-z ]*?)\s*:\s*(.*?)\s*$")


def file_set(path: str | os.PathLike) -> tuple[Path, Path, Path]:
    """``(xyzd, nfo, conf)`` paths from a folder or from the path of any of the three files."""
    path = Path(path)
    folder = path if path.is_dir() else path.parent
    xyzd = path if path.suffix == ".xyzd" else folder / XYZD
    return xyzd, folder / NFO, folder / CONF


def _key_values(path: Path) -> dict[str, str]:
    try:
        text = path.read_text()
    except UnicodeDecodeError:
        reject_file(path, "not a text file")
    out = {}
    for line in text.splitlines():
        m = _LINE.match(line)
        if m:
            out.setdefault(m.group(1).lower(), m.group(2))
    return out


def _number(path: Path, values: dict[str, str], key: str, kind=float, count: int = 1):
    if key.lower() not in values:
        reject_file(path, f"no '{key}:' line")
    text = values[key.lower()].split("(")[0].split()  # "0.35 (Tolerance: 1.0001)" -> "0.35"
    try:
        numbers = [kind(t) for t in text[:count]]
    except ValueError:
        numbers = []
    if len(numbers) != count or not all(math.isfinite(x) for x in numbers):
        reject_file(path, f"'{key}: {values[key.lower()]}' is not {count} finite number(s)")
    return numbers[0] if count == 1 else numbers


def read(path: str | os.PathLike, tolerance: float | None = DEFAULT_OVERLAP_TOLERANCE) -> Packing:
    """Read a packing-generation file set (folder, or the path of its ``.xyzd``), with the final diameters."""
    xyzd, nfo, conf = file_set(path)
    for p in (xyzd, conf):
        regular_file(p, "packing-generation file", missing="no such file (a packing-generation file set needs "
                     "packing.xyzd and generation.conf)")
    values = _key_values(conf)
    n = _number(conf, values, "Particles count", int)
    sides = _number(conf, values, "Packing size", float, 3)
    if "boundaries mode" in values and _number(conf, values, "Boundaries mode", int) != 1:
        reject_file(conf, f"Boundaries mode {values['boundaries mode']}: only 1 (periodic bulk) is a periodic packing")
    if not (sides[0] == sides[1] == sides[2]):
        reject_file(conf, f"Packing size {sides}: spherejam packings are cubes (all three sides equal)")
    box = sides[0]
    if not BOX_SIDE.ok(box):  # before the porosity check divides by L^3
        reject_file(conf, f"Packing size {sides}: the box side {BOX_SIDE.rule()}")
    size = xyzd.stat().st_size
    if size % 32:
        reject_file(xyzd, f"{size} bytes is not a whole number of spheres (32 bytes each: x y z d as float64)")
    if size // 32 != n:
        reject_file(xyzd, f"holds {size // 32} spheres but {conf.name} says Particles count {n}")
    data = np.fromfile(xyzd, dtype="<f8").reshape(-1, 4).astype(np.float64)
    positions, stored = data[:, :3], data[:, 3]
    bad = np.flatnonzero(~(np.isfinite(stored) & (stored > 0)))
    if len(bad):  # before the porosity check, which would blame the nfo file
        reject_file(xyzd, f"sphere {bad[0]} has diameter {float(stored[bad[0]])!r}; diameters must be finite and > 0")
    source = {"format": "packing-generation", "files": [str(xyzd), str(conf)], "scale": 1.0}
    for key in ("seed", "contraction rate", "generation start"):
        if key in values:
            source[key.replace(" ", "_")] = values[key]
    if nfo.is_file():
        info = _key_values(nfo)
        n_nfo = _number(nfo, info, "N", int)
        if n_nfo != n:
            reject_file(nfo, f"N {n_nfo} disagrees with {conf.name} (Particles count {n})")
        dims = _number(nfo, info, "Dimensions", float, 3)
        if dims != sides:
            reject_file(nfo, f"Dimensions {dims} disagree with {conf.name} (Packing size {sides})")
        theoretical = _number(nfo, info, "Theoretical Porosity")
        final = _number(nfo, info, "Final Porosity")
        if not (0 <= theoretical < 1 and 0 <= final < 1):
            reject_file(nfo, f"porosities must lie in [0, 1) (Theoretical {theoretical!r}, Final {final!r})")
        density = float(np.sum(ball_volume(stored, 3))) / box**3
        if not abs(density - (1.0 - theoretical)) <= DENSITY_RTOL * (1.0 - theoretical):
            reject_file(nfo, f"Theoretical Porosity {theoretical!r} disagrees with the diameters in {xyzd.name} "
                        f"(porosity {1.0 - density!r}): the diameters were rescaled after generation or the "
                        "files belong to different packings")
        scale = ((1.0 - final) / (1.0 - theoretical)) ** (1.0 / 3.0)
        source.update(files=source["files"] + [str(nfo)], scale=scale, final_porosity=final,
                      theoretical_porosity=theoretical)
    else:
        scale = 1.0
        source["note"] = f"no {NFO}: diameters taken as stored"
    return validated_packing(xyzd, positions, stored * scale, box, {"algorithm": "imported", "source": source},
                             tolerance)


def write(packing: Packing, folder: str | os.PathLike) -> list[Path]:
    """Write ``folder/{packing.xyzd, packing.nfo, generation.conf}`` (actual diameters, so s = 1)."""
    folder = Path(folder)
    if packing.dim != 3:
        raise PackingFileError(f"{folder}: packing-generation holds 3D packings, this one has d={packing.dim}")
    if (folder.exists() and not folder.is_dir()) or folder.suffix in (".xyzd", ".nfo", ".conf"):
        raise PackingFileError(f"{folder}: the packing-generation output is a folder (it holds packing.xyzd, "
                               "packing.nfo and generation.conf, the names the code expects)")
    L = packing.box
    porosity = 1.0 - packing.phi
    rate = packing.metadata.get("parameters", {}).get("rate", DEFAULT_CONTRACTION_RATE)
    seed = packing.metadata.get("seed", 0)
    seed = seed if isinstance(seed, int) and 0 <= seed < 2**31 else 0  # the code reads a C int
    conf = (f"Particles count: {packing.n}\nPacking size: {L!r} {L!r} {L!r}\nGeneration start: 0\nSeed: {seed}\n"
            f"Steps to write: 1000\nBoundaries mode: 1\nContraction rate: {float(rate):e}\n")
    nfo = (f"N: {packing.n}\n Dimensions: {L!r} {L!r} {L!r}\n Theoretical Porosity: {porosity!r}\n"
           f"Final Porosity: {porosity!r}\n")
    data = np.column_stack([packing.positions, packing.diameters]).astype("<f8")
    with atomic_folder(folder, (XYZD, NFO, CONF)) as tmp:  # the three files belong together: all new or all old
        data.tofile(tmp / XYZD)
        (tmp / NFO).write_text(nfo)
        (tmp / CONF).write_text(conf)
    return [folder / XYZD, folder / NFO, folder / CONF]
