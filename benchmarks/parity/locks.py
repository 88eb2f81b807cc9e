"""One worker per pair and code: a lock file holding the worker's PID."""

from __future__ import annotations

import os
from pathlib import Path


def claim(path: Path) -> bool:
    """Take the lock file ``path`` for this process (False: a live process holds it).

    Two workers on overlapping seeds must not run the same search: the C++ code reads and writes fixed file names in
    its folder. A lock whose process has died is taken over.
    """
    path.parent.mkdir(parents=True, exist_ok=True)
    for _ in range(2):
        try:
            fd = os.open(path, os.O_CREAT | os.O_EXCL | os.O_WRONLY)
        except FileExistsError:
            try:
                pid = int(path.read_text() or "0")
                os.kill(pid, 0)
                return False  # alive
            except (ValueError, ProcessLookupError):
                path.unlink(missing_ok=True)  # stale
                continue
            except PermissionError:
                return False
        with os.fdopen(fd, "w") as f:
            f.write(str(os.getpid()))
        return True
    return False
