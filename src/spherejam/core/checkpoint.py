"""Checkpoints of long runs, one protocol for every engine: resume if a checkpoint of the same input and parameters
exists, save the full state every ``interval`` seconds, delete the file when the run is done.

A checkpoint is one HDF5 file, written atomically: named arrays (the history columns as ``history_<name>``) plus
JSON-serialisable attributes, tagged with a ``kind`` so that a checkpoint of one engine is never resumed by another,
and with a fingerprint of the input packing and the parameters so that it is never resumed by a different run.
"""

from __future__ import annotations

import hashlib
import json
import logging
import os
import time
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from .atomic import atomic_output, remove_leftovers
from .errors import PackingFileError, StaleCheckpointError
from .packing_io import dumps
from .validation import INTERVAL

if TYPE_CHECKING:
    from .packing import Packing

_HISTORY = "history_"


def fingerprint(packing: Packing, kind: str, parameters: Mapping[str, Any]) -> str:
    """SHA-256 of the engine kind, the input packing (positions, diameters, box) and the parameters."""
    digest = hashlib.sha256()
    digest.update(kind.encode())
    digest.update(np.ascontiguousarray(packing.positions, dtype=np.float64).tobytes())
    digest.update(np.ascontiguousarray(packing.diameters, dtype=np.float64).tobytes())
    digest.update(json.dumps({"box": float(packing.box), **parameters}, sort_keys=True, default=str).encode())
    return digest.hexdigest()


class Checkpoint:
    """The checkpoint file of one run (``path`` None: no checkpointing, every method is a no-op).

    ``interval`` (s, >= 0; 0 saves after every window) is the time between periodic saves."""

    def __init__(self, path: str | os.PathLike | None, kind: str, fingerprint: str, interval: float):
        INTERVAL.check("checkpoint_interval", interval)
        self.path = Path(path) if path is not None else None
        self.kind = kind
        self.fingerprint = fingerprint
        self.interval = float(interval)
        self._last = time.perf_counter()

    def resume(self, compatible: Callable[[Mapping[str, Any]], bool] | None = None
               ) -> tuple[dict[str, np.ndarray], dict[str, Any], dict[str, np.ndarray]] | None:
        """(arrays, attributes, history columns) of an existing checkpoint of this run, or None if there is none.
        Temporary files that an interrupted save left next to the checkpoint are deleted first. ``compatible``
        (the checkpoint's attributes -> bool) may accept a checkpoint of another fingerprint: an engine's earlier
        settings that a resumed run may change; the next save writes this run's fingerprint.

        Raises :class:`PackingFileError` if the file is unreadable or of another engine, and its subclass
        :class:`StaleCheckpointError` if it is of another input or parameters (it names the file; delete it to
        start over)."""
        if self.path is None:
            return None
        for leftover in remove_leftovers(self.path, ".h5"):  # a save killed midway (kill -9, node failure)
            logging.getLogger("spherejam").info("removed %s, the temporary file of an interrupted save", leftover)
        if not self.path.exists():
            return None
        arrays, attrs = load_checkpoint(self.path, self.kind)
        if attrs.get("fingerprint") != self.fingerprint and not (compatible is not None and compatible(attrs)):
            raise StaleCheckpointError(self.path, f"{self.path}: checkpoint of a different input or parameters; "
                                       "delete it to start over")
        history = {k[len(_HISTORY):]: v for k, v in arrays.items() if k.startswith(_HISTORY)}
        arrays = {k: v for k, v in arrays.items() if not k.startswith(_HISTORY)}
        return arrays, attrs, history

    def due(self) -> bool:
        """True when a periodic save is due."""
        return self.path is not None and time.perf_counter() - self._last >= self.interval

    def save(self, arrays: Mapping[str, np.ndarray], attrs: Mapping[str, Any],
             history: Mapping[str, np.ndarray] | None = None) -> None:
        if self.path is None:
            return
        out = dict(arrays)
        out.update({f"{_HISTORY}{k}": v for k, v in (history or {}).items()})
        save_checkpoint(self.path, self.kind, out, {**attrs, "fingerprint": self.fingerprint})
        self._last = time.perf_counter()

    def discard(self) -> None:
        """Delete the file: the run is done and its result written by the caller."""
        if self.path is not None and self.path.exists():
            os.remove(self.path)


def save_checkpoint(path: str | os.PathLike, kind: str, arrays: Mapping[str, np.ndarray], attrs: Mapping[str, Any]):
    import h5py

    with atomic_output(path, ".h5") as tmp:
        with h5py.File(tmp, "w") as f:
            f.attrs["checkpoint_kind"] = kind
            f.attrs["state"] = dumps(dict(attrs))
            for name, value in arrays.items():
                f.create_dataset(name, data=np.asarray(value))
    return Path(path)


def load_checkpoint(path: str | os.PathLike, kind: str) -> tuple[dict[str, np.ndarray], dict[str, Any]]:
    """Load a checkpoint written by :func:`save_checkpoint`; raise :class:`PackingFileError` if it is unusable."""
    import h5py

    path = Path(path)
    try:
        with h5py.File(path, "r") as f:
            found = f.attrs.get("checkpoint_kind")
            if found != kind:
                raise PackingFileError(f"{path}: a checkpoint of kind {found!r}, expected {kind!r}")
            attrs = json.loads(f.attrs["state"])
            arrays = {name: ds[()] for name, ds in f.items()}
    except PackingFileError:
        raise
    except (OSError, KeyError, ValueError) as exc:
        reason = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        raise PackingFileError(f"{path}: unreadable checkpoint ({reason})") from None
    return arrays, attrs
