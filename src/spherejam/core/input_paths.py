"""The input-file policy of every reader: only a regular file is opened.

A FIFO given as an input blocks its reader for ever (nothing ever writes into it), a device is read as if it were a
file (``/dev/zero`` never ends), a folder gives a reader's own obscure error. Every reader of a file a user names —
packings, datasets, manifests, analysis and CALiPPSO files inside a results folder, PSD files, config files — calls
:func:`regular_file` before it opens the path, and so refuses these in one line naming the file and what it is
(docs/robustness.md, "Inputs")."""

from __future__ import annotations

import os
from pathlib import Path

from .atomic import special_kind
from .errors import PackingFileError


def regular_file(path: str | os.PathLike, what: str = "file", error: type[Exception] = PackingFileError,
                 missing: str | None = None) -> Path:
    """``path`` if it is a regular file (symlinks followed); else raise ``error``: ``<path>: no such <what>``
    (or ``missing``), ``is a directory, not a <what>``, or ``is a FIFO, not a <what>`` (any special file)."""
    path = Path(path)
    if not os.path.exists(path):
        raise error(f"{path}: {missing or f'no such {what}'}")
    if path.is_dir():
        raise error(f"{path}: is a directory, not a {what}")
    if not path.is_file():  # a FIFO would block the reader for ever, a device would be read as a file
        raise error(f"{path}: is {special_kind(path) or 'not a regular file'}, not a {what}")
    return path


__all__ = ["regular_file"]
