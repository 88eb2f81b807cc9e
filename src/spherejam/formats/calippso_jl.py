"""The text input of CALiPPSO.jl's examples: dimension, N, diameter, then one line of centre coordinates per sphere.

Layout (docs/formats.md)::

    d
    N
    sigma            (one diameter: a monodisperse packing, as in the examples)
    x_1 ... x_d      (N lines)

For a polydisperse packing the diameter line is left out and every centre line ends with that sphere's radius
(``x_1 ... x_d R``; CALiPPSO.jl takes radii). The file holds no box: the examples use a unit cube, so the writer
scales the packing to L = 1 (phi is unchanged) and the reader takes the box side as an argument (default 1).
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from ..core.atomic import atomic_output
from ..core.packing import DEFAULT_OVERLAP_TOLERANCE, Packing
from ..core.input_paths import regular_file
from ..core.packing_io import reject_file, validated_packing


def _floats(path, lineno: int, line: str) -> list[float]:
    try:
        return [float(t) for t in line.split()]
    except ValueError:
        reject_file(path, f"line {lineno}: {line.strip()[:60]!r} is not a row of numbers")


def _integer(path, lineno: int, line: str, what: str) -> int:
    try:
        return int(line.strip())
    except ValueError:
        reject_file(path, f"line {lineno}: {line.strip()[:60]!r} is not an integer ({what})")


def read(path: str | os.PathLike, tolerance: float | None = DEFAULT_OVERLAP_TOLERANCE, box: float = 1.0) -> Packing:
    """Read a CALiPPSO.jl example-style file; ``box`` is the side L of the periodic cube (not in the file)."""
    path = regular_file(path, "CALiPPSO.jl file", missing="no such file")
    try:
        lines = [ln for ln in path.read_text().splitlines() if ln.strip()]
    except UnicodeDecodeError:
        reject_file(path, "not a text file")
    if len(lines) < 3:
        reject_file(path, f"{len(lines)} non-empty line(s); expected d, N and the centres")
    dim = _integer(path, 1, lines[0], "the dimension d")
    n = _integer(path, 2, lines[1], "the number of spheres N")
    if not 2 <= dim <= 5:
        reject_file(path, f"line 1: dimension d={dim}, expected 2 to 5")
    if n < 2:
        reject_file(path, f"line 2: N={n}; a packing needs at least 2 spheres")
    first = _floats(path, 3, lines[2])
    monodisperse = len(first) == 1
    rows = lines[3:] if monodisperse else lines[2:]
    width = dim if monodisperse else dim + 1
    if len(rows) != n:
        reject_file(path, f"holds {len(rows)} centre line(s) but line 2 says N={n}")
    start = 4 if monodisperse else 3
    table = np.empty((n, width))
    for k, line in enumerate(rows):
        values = _floats(path, start + k, line)
        if len(values) != width:
            what = f"{dim} coordinates" if monodisperse else f"{dim} coordinates and a radius"
            reject_file(path, f"line {start + k}: {len(values)} numbers, expected {what}")
        table[k] = values
    if monodisperse:
        diameters = np.full(n, first[0])
        positions = table
    else:
        diameters = 2.0 * table[:, dim]
        positions = table[:, :dim]
    source = {"format": "calippso-jl", "files": [str(path)], "box": float(box)}
    return validated_packing(path, positions, diameters, float(box), {"algorithm": "imported", "source": source},
                             tolerance)


def write(packing: Packing, path: str | os.PathLike) -> Path:
    """Write the packing scaled to a unit box (monodisperse: the examples' layout; else one radius per line)."""
    path = Path(path)
    L = packing.box
    x = packing.positions / L
    x[x >= 1.0] = 0.0  # x / L can round up to 1 for x just below L
    d = packing.diameters / L
    lines = [str(packing.dim), str(packing.n)]
    if np.all(d == d[0]):
        lines.append(repr(float(d[0])))
        lines += [" ".join(repr(v) for v in row) for row in x.tolist()]
    else:
        lines += [" ".join(repr(v) for v in row) + f" {r!r}" for row, r in zip(x.tolist(), (d / 2.0).tolist())]
    with atomic_output(path, ".dat") as tmp:
        tmp.write_text("\n".join(lines) + "\n")
    return path
