"""LAMMPS data files, atom style ``sphere`` (DEM codes): ``id type diameter density x y z`` per atom, 3D.

The writer gives every sphere type 1 and mass density 1 (a hard-sphere packing has no mass scale) and writes
numbers with 17 significant digits, so a round trip is exact. The reader accepts any LAMMPS data file whose
``Atoms`` section is in the sphere style (optionally with image flags), in an orthogonal box; other sections
(Velocities, ...) are skipped.

A data file holds no boundary flags (they belong to the input script). A packing in a container is written in its
frame, with the container on the title line (``container=JSON``) and, below the title, the ``boundary`` command
and the wall commands that reproduce it in LAMMPS as comments; the reader restores the container from the title
line. A non-cubic box without one is read as a periodic box with three edge lengths.
"""

from __future__ import annotations

import json
import os
import re
from pathlib import Path

import numpy as np

from ..core.atomic import atomic_output
from ..core.container import Container
from ..core.errors import PackingFileError
from ..core.packing import DEFAULT_OVERLAP_TOLERANCE, Packing
from ..core.input_paths import regular_file
from ..core.packing_io import reject_file, validated_packing

#: Section headers of a LAMMPS data file (a line holding only one of these starts a section).
SECTIONS = ("Atoms", "Velocities", "Masses", "Ellipsoids", "Lines", "Triangles", "Bodies", "Bonds", "Angles",
            "Dihedrals", "Impropers", "Pair Coeffs", "PairIJ Coeffs", "Bond Coeffs", "Angle Coeffs",
            "Dihedral Coeffs", "Improper Coeffs")
_BOUNDS = re.compile(r"^\s*(\S+)\s+(\S+)\s+([xyz])lo\s+[xyz]hi\s*$")


def read(path: str | os.PathLike, tolerance: float | None = DEFAULT_OVERLAP_TOLERANCE) -> Packing:
    """Read a LAMMPS data file (atom style sphere) as a 3D packing."""
    path = regular_file(path, "LAMMPS data file", missing="no such file")
    try:
        lines = path.read_text().splitlines()
    except UnicodeDecodeError:
        reject_file(path, "not a text file")
    n = None
    bounds: dict[str, tuple[float, float]] = {}
    k = 1  # line 1 is a comment by definition
    while k < len(lines):
        text = lines[k].split("#")[0].strip()
        if text in SECTIONS:
            break
        if text.endswith(" atoms"):
            try:
                n = int(text.split()[0])
            except ValueError:
                reject_file(path, f"line {k + 1}: {lines[k].strip()!r} does not give the number of atoms")
        elif text.endswith("xy xz yz"):
            try:
                tilted = any(float(v) != 0 for v in text.split()[:3])
            except ValueError:
                reject_file(path, f"line {k + 1}: {lines[k].strip()!r} is not three tilt factors")
            if tilted:
                reject_file(path, f"line {k + 1}: a triclinic box; spherejam packings are cubes")
        elif _BOUNDS.match(text):
            m = _BOUNDS.match(text)
            try:
                bounds[m.group(3)] = (float(m.group(1)), float(m.group(2)))
            except ValueError:
                reject_file(path, f"line {k + 1}: {lines[k].strip()!r} is not two numbers")
        k += 1
    if n is None:
        reject_file(path, "no 'N atoms' line in the header")
    if sorted(bounds) != ["x", "y", "z"]:
        reject_file(path, "the header needs 'xlo xhi', 'ylo yhi' and 'zlo zhi' lines")
    sides = {a: hi - lo for a, (lo, hi) in bounds.items()}
    container = _title_container(path, lines[0])
    box = sides["x"]
    if container is None and not sides["x"] == sides["y"] == sides["z"]:
        container = Container(tuple(sides[a] for a in "xyz"), (True,) * 3, (False,) * 3,
                              spec="periodic:" + ",".join(f"{a}={sides[a]!r}" for a in "xyz"))
    if container is not None:
        box = float("nan")
        if not np.allclose([sides[a] for a in "xyz"], container.lengths, rtol=1e-15, atol=0):
            reject_file(path, f"box sides {[sides[a] for a in 'xyz']} are not the frame of container {container.spec}")
    origin = np.array([bounds[a][0] for a in "xyz"])
    atoms = None
    while k < len(lines):
        header, _, comment = lines[k].partition("#")
        if header.strip() == "Atoms":
            style = comment.strip()
            if style and style.split()[0] != "sphere":
                reject_file(path, f"line {k + 1}: atom style '{style}', expected 'sphere' "
                            "(id type diameter density x y z)")
            atoms = _atoms(path, lines, k + 1, n)
            break
        k += 1
    if atoms is None:
        reject_file(path, "no Atoms section")
    order = np.argsort(atoms[:, 0], kind="stable")
    atoms = atoms[order]
    ids = atoms[:, 0]
    if len(np.unique(ids)) != n:
        reject_file(path, "atom IDs are not unique")
    positions = atoms[:, 4:7] - origin
    diameters = atoms[:, 2]
    source = {"format": "lammps", "files": [str(path)], "origin": origin.tolist()}
    return validated_packing(path, positions, diameters, box, {"algorithm": "imported", "source": source},
                             tolerance, container)


def _title_container(path: Path, title: str) -> Container | None:
    """The container written on a spherejam title line, or None."""
    _, found, rest = title.partition(" container=")
    if not found:
        return None
    try:
        return Container.from_dict(json.loads(rest.strip()))
    except ValueError as exc:
        reject_file(path, f"line 1: container={rest.strip()[:60]!r} is not a container record ({exc})")


def _atoms(path: Path, lines: list[str], start: int, n: int) -> np.ndarray:
    rows = []
    k = start
    while k < len(lines) and not lines[k].strip():
        k += 1
    while k < len(lines) and len(rows) < n:
        text = lines[k].split("#")[0].strip()
        if not text:
            break
        fields = text.split()
        if len(fields) not in (7, 10):
            reject_file(path, f"line {k + 1}: {len(fields)} columns, expected 7 (id type diameter density x y z) or 10 "
                        "(with image flags)")
        try:
            rows.append([float(v) for v in fields[:7]])
        except ValueError:
            reject_file(path, f"line {k + 1}: {text[:60]!r} is not a row of numbers")
        k += 1
    extra = 0  # rows beyond the header's count: LAMMPS refuses such a file, and so do we
    while k < len(lines) and lines[k].split("#")[0].strip() not in ("", *SECTIONS):
        extra += 1
        k += 1
    if extra:
        reject_file(path, f"the Atoms section holds {len(rows) + extra} atoms but the header says {n}")
    if len(rows) != n:
        reject_file(path, f"the Atoms section holds {len(rows)} atoms but the header says {n}")
    return np.array(rows)


def write(packing: Packing, path: str | os.PathLike) -> Path:
    """Write a LAMMPS data file, atom style sphere, box [0, L)^3."""
    path = Path(path)
    if packing.dim != 3:
        raise PackingFileError(f"{path}: LAMMPS sphere data files hold 3D packings, this one has d={packing.dim}")
    c = packing.container
    alg = packing.metadata.get("algorithm", "unknown")
    title = f"LAMMPS data file (atom_style sphere) written by spherejam; phi={packing.phi!r} algorithm={alg}"
    lines = [title] if c.is_periodic_cube else [title + " container=" + json.dumps(c.to_dict()), *_commands(c)]
    lines += ["", f"{packing.n} atoms", "1 atom types", ""]
    lines += [f"0.0 {L!r} {a}lo {a}hi" for L, a in zip(c.lengths, "xyz")]
    lines += ["", "Atoms # sphere", ""]
    lines += [f"{i + 1} 1 {d!r} 1.0 {x!r} {y!r} {z!r}"
              for i, ((x, y, z), d) in enumerate(zip(packing.positions.tolist(), packing.diameters.tolist()))]
    with atomic_output(path, ".data") as tmp:
        tmp.write_text("\n".join(lines) + "\n")
    return path


def _commands(c: Container) -> list[str]:
    """The LAMMPS input commands that give the container's walls, as comment lines of the header."""
    flags = " ".join("p" if p else "f" for p in c.periodic)
    out = [f"# boundary {flags}"]
    for k, a in enumerate("xyz"):
        if c.planes[k]:
            out.append(f"# fix wall{a} all wall/reflect {a}lo EDGE {a}hi EDGE")
    if c.curved == "cylinder":
        x, y = (float(c.centre[q]) for q in range(3) if q != c.axis)
        out.append(f"# region tube cylinder {'xyz'[c.axis]} {x!r} {y!r} {c.radius!r} INF INF side in")
        out.append("# fix tube all wall/region tube harmonic 1.0 1.0 0.5")
    elif c.curved == "sphere":
        x, y, z = map(float, c.centre)
        out.append(f"# region ball sphere {x!r} {y!r} {z!r} {c.radius!r} side in")
        out.append("# fix ball all wall/region ball harmonic 1.0 1.0 0.5")
    return out
