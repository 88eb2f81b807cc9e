"""SIGTERM and SIGINT during a long run: finish the current step, save the checkpoint, stop with a distinct status.

SLURM sends SIGTERM before it kills a job (time limit, preemption), and a user presses Ctrl-C; with the default
checkpoint interval of 300 s either would lose minutes of work. The long-running commands (``ls``, ``mls``, ``fb``,
``calippso``) call :func:`install`; the step loops check :func:`requested` after each step (a window, an iteration,
an LP), save the checkpoint and call :func:`stop`, which raises :class:`Interrupted`; the CLI prints one line and exits
with ``128 + signal number`` (143 for SIGTERM, 130 for SIGINT), the status a shell gives a killed program. Rerunning
the same command (Snakemake's resubmission) resumes from the checkpoint. A second signal stops at once
(``KeyboardInterrupt``), for a step that takes too long.

Every other command has nothing to resume and stops at once (``install(at_once=True)``): the handler raises
:class:`Stopped`, whose unwinding deletes the temporary files of the outputs being written
(:mod:`spherejam.core.atomic`), and exits 143 or 130 alike. The signal is also recorded, because an exception raised
inside a library's cleanup code can be swallowed there: :func:`check` raises it again, and the atomic writers call it
before the rename that would put an output in place, so a signal never ends with a new output and exit 0.
"""

from __future__ import annotations

import os
import signal
import threading

from .errors import SpherejamError

SIGNALS = (signal.SIGTERM, signal.SIGINT)
_received: int | None = None
_at_once = False


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


class Stopped(BaseException):
    """A command without a checkpoint stopped on a signal; nothing it was writing was put in place. A BaseException,
    as KeyboardInterrupt is, so that code catching ``Exception`` (a logging handler, a reader's error path) lets it
    pass."""

    def __init__(self, signum: int):
        self.signum = signum
        super().__init__(f"stopped by {signal.Signals(signum).name}; no output written (an existing one is kept)")

    @property
    def exit_status(self) -> int:
        return 128 + self.signum


def install(at_once: bool = False) -> dict:
    """Catch SIGTERM and SIGINT from now on; returns the handlers replaced (for :func:`restore`). The first signal is
    only recorded (the run stops at its next step), or with ``at_once`` raises :class:`Stopped` where it lands."""
    global _received, _at_once
    _received = None
    _at_once = at_once
    if threading.current_thread() is not threading.main_thread():  # Python delivers signals to the main thread only
        return {}
    return {sig: signal.signal(sig, _record) for sig in SIGNALS}


def restore(previous: dict) -> None:
    """Put back the handlers :func:`install` replaced, and forget the signal received."""
    global _received, _at_once
    for sig, handler in previous.items():
        signal.signal(sig, handler)
    _received, _at_once = None, False


def quiet_exit_handlers() -> dict:
    """Handlers for a process that is ending: a signal exits at once with 128 + its number, without a traceback."""
    return {sig: _exit_now for sig in SIGNALS}


def _exit_now(signum, frame) -> None:
    os._exit(128 + signum)


def _record(signum, frame) -> None:
    global _received
    first = _received is None
    if first:
        _received = signum
    if _at_once:
        raise Stopped(_received)
    if not first:  # the second signal: do not wait for the step to end
        raise KeyboardInterrupt


def check() -> None:
    """Raise :class:`Stopped` if a command that stops at once has received a signal (its exception may have been
    swallowed by a library); the atomic writers call this before putting an output in place."""
    if _at_once and _received is not None:
        raise Stopped(_received)


def requested() -> int | None:
    """The signal received since :func:`install`, or None."""
    return _received


def stop(checkpoint: str | os.PathLike | None, where: str) -> None:
    """Raise :class:`Interrupted` for the signal received (call after saving the checkpoint; ``where``: "after 12
    windows")."""
    raise Interrupted(_received, checkpoint, where)
