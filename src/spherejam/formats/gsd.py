"""GSD, HOOMD-blue's trajectory format (OVITO reads it), with the ``gsd`` package: one frame per packing.

HOOMD's schema stores the box, positions and diameters as float32 and centres the box on the origin
([-L/2, L/2)^d). The writer fills those chunks for HOOMD and OVITO and keeps the exact float64 values (positions in
[0, L), diameters, box side) in the frame's log chunks ``log/spherejam/{position,diameter,box}``; the reader prefers
them and
otherwise uses the float32 chunks (whose round-off near contact may exceed the overlap tolerance of a jammed
packing: pass a looser tolerance for such files).
"""

from __future__ import annotations

import logging
import os
from pathlib import Path

import numpy as np

from ..core.atomic import atomic_output
from ..core.errors import PackingFileError
from ..core.packing import DEFAULT_OVERLAP_TOLERANCE, Packing
from ..core.input_paths import regular_file
from ..core.packing_io import reject_file, validated_packing

LOG_POSITION = "spherejam/position"
LOG_DIAMETER = "spherejam/diameter"
LOG_BOX = "spherejam/box"

logging.getLogger("gsd").setLevel(logging.WARNING)  # gsd logs every file it opens at INFO


def _hoomd():
    import gsd.hoomd  # deferred: keeps `spherejam --help` fast

    return gsd.hoomd


def read(path: str | os.PathLike, tolerance: float | None = DEFAULT_OVERLAP_TOLERANCE, frame: int = -1) -> Packing:
    """Read frame ``frame`` (default: the last) of a GSD file as a packing."""
    path = regular_file(path, "GSD file", missing="no such file")
    hoomd = _hoomd()
    try:
        with hoomd.open(path, "r") as traj:
            count = len(traj)
            if count == 0:
                reject_file(path, "holds no frames")
            if not -count <= frame < count:
                reject_file(path, f"frame {frame} does not exist (the file holds {count} frame(s))")
            snap = traj[frame]
    except PackingFileError:
        raise
    except (RuntimeError, OSError, KeyError, ValueError) as exc:
        reject_file(path, f"not a readable GSD file ({str(exc).splitlines()[0] if str(exc) else type(exc).__name__})")
    dim = int(snap.configuration.dimensions)
    lx, ly, lz, *tilts = (float(v) for v in snap.configuration.box)
    if any(t != 0 for t in tilts):
        reject_file(path, f"box tilts {tilts}: spherejam packings are cubes (no tilt)")
    if (dim == 3 and not lx == ly == lz) or (dim == 2 and lx != ly) or dim not in (2, 3):
        reject_file(path, f"box {[lx, ly, lz]} in d={dim}: spherejam packings are cubes (all sides equal)")
    box = lx
    n = int(snap.particles.N)
    log = snap.log or {}
    if LOG_POSITION in log and LOG_DIAMETER in log and LOG_BOX in log:
        box = float(np.asarray(log[LOG_BOX]).reshape(-1)[0])
        if abs(box - lx) > 1e-6 * abs(box):
            reject_file(path, f"the exact box side {box!r} in {LOG_BOX} disagrees with configuration/box {lx!r}")
        positions = np.asarray(log[LOG_POSITION], dtype=np.float64)
        diameters = np.asarray(log[LOG_DIAMETER], dtype=np.float64)
        precision = "float64"
    else:
        centred = np.asarray(snap.particles.position, dtype=np.float64)[:, :dim]
        half = 0.5 * box
        if np.any(centred < -half) or np.any(centred > half):
            reject_file(path, f"positions lie outside the box [-{half!r}, {half!r}]")
        positions = np.mod(centred + half, box)
        positions[positions >= box] = 0.0  # np.mod can round up to box for tiny negatives
        diameters = np.asarray(snap.particles.diameter, dtype=np.float64)
        precision = "float32"
    if positions.shape[0] != n or diameters.shape != (n,):
        reject_file(path, f"particles/N is {n} but the file holds {positions.shape[0]} positions and "
                    f"{diameters.shape[0]} diameters")
    source = {"format": "gsd", "files": [str(path)], "frame": int(frame), "precision": precision}
    return validated_packing(path, positions, diameters, box, {"algorithm": "imported", "source": source},
                             tolerance)


def write(packing: Packing, path: str | os.PathLike) -> Path:
    """Write one GSD frame (d = 2 or 3): HOOMD's float32 chunks plus the exact float64 values in its log."""
    path = Path(path)
    if packing.dim not in (2, 3):
        raise PackingFileError(f"{path}: GSD holds 2D or 3D packings, this one has d={packing.dim}")
    hoomd = _hoomd()
    L = packing.box
    frame = hoomd.Frame()
    frame.configuration.dimensions = packing.dim
    frame.configuration.box = [L, L, L if packing.dim == 3 else 0.0, 0.0, 0.0, 0.0]
    frame.particles.N = packing.n
    centred = np.zeros((packing.n, 3))
    centred[:, :packing.dim] = packing.positions - 0.5 * L
    frame.particles.position = centred
    frame.particles.diameter = packing.diameters
    frame.particles.types = ["A"]
    frame.particles.typeid = np.zeros(packing.n, dtype=np.uint32)
    frame.log[LOG_POSITION] = packing.positions
    frame.log[LOG_DIAMETER] = packing.diameters
    frame.log[LOG_BOX] = np.array([L])
    with atomic_output(path, ".gsd") as tmp:
        with hoomd.open(tmp, "w") as traj:
            traj.append(frame)
    return path
