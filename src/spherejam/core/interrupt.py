"""SIGTERM and SIGINT during a long run: finish the current step, save the checkpoint, stop with a distinct status.

SLURM sends SIGTERM before it kills a job (time limit, preemption), and a user presses Ctrl-C; with the default
checkpoint interval of 300 s either would lose minutes of work. The long-running commands (``ls``, ``mls``, ``fb``,
``calippso``) call :func:`install`; the step loops check :func:`requested` after each step (a window, an iteration,
an LP), save the checkpoint and call :func:`stop`, which raises :class:`Interrupted`; the CLI prints one line and exits
with ``128 + signal number`` (143 for SIGTERM, 130 for SIGINT), the status a shell gives a killed program. Rerunning
the same command (Snakemake's resubmission) resumes from the checkpoint. A second signal stops at once
(``KeyboardInterrupt``), for a step that takes too long.
"""

from __future__ import annotations

import os
import signal

from .errors import SpherejamError

SIGNALS = (signal.SIGTERM, signal.SIGINT)
_received: int | None = None


class Interrupted(SpherejamError):
    """A run stopped on a signal after saving its checkpoint (``checkpoint`` None: there was none to save)."""

    def __init__(self, signum: int, checkpoint: str | os.PathLike | None, where: str):
        self.signum = signum
        self.checkpoint = checkpoint
        name = signal.Signals(signum).name
        saved = (f"checkpoint saved to {checkpoint}; the same command resumes from it" if checkpoint is not None
                 else "nothing saved (no --checkpoint)")
        super().__init__(f"stopped by {name} {where}; {saved}")

    @property
    def exit_status(self) -> int:
        return 128 + self.signum


def install() -> None:
    """Catch SIGTERM and SIGINT from now on (the first one is only recorded; the run stops at its next step)."""
    global _received
    _received = None
    for sig in SIGNALS:
        signal.signal(sig, _record)


def _record(signum, frame) -> None:
    global _received
    if _received is not None:  # the second signal: do not wait for the step to end
        raise KeyboardInterrupt
    _received = signum


def requested() -> int | None:
    """The signal received since :func:`install`, or None."""
    return _received


def stop(checkpoint: str | os.PathLike | None, where: str) -> None:
    """Raise :class:`Interrupted` for the signal received (call after saving the checkpoint; ``where``: "after 12
    windows")."""
    raise Interrupted(_received, checkpoint, where)
