"""Checkpoints of long runs: the full engine state in one HDF5 file, written atomically.

A checkpoint holds named arrays plus JSON-serialisable attributes, tagged with a ``kind`` so that a checkpoint of
one engine is never resumed by another.
"""

from __future__ import annotations

import json
import os
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

from .atomic import atomic_output
from .errors import PackingFileError
from .packing_io import dumps


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
