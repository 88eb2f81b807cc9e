"""The one driver of every engine run: its options, the step loop with its stop checks, the checkpoint protocol, the
progress output and the assembly of the typed result.

An engine supplies a :class:`Stepper` (LS/MLS: one pressure window under a rate controller; FB: one iteration) and
:func:`drive` runs it:

1. resume from the checkpoint of the same input and parameters if there is one, else start fresh;
2. stop checks before the first step (``Stepper.stop_before``), then step until the stepper's own rule or a budget
   stops the run (``max_wall_time``: seconds of this call, checked after each step, for every engine);
3. after every step: progress, a checkpoint save when one is due (``checkpoint_interval``), the caller's callback;
4. at the stop: a checkpoint save if the stop is resumable (:data:`~.result.RESUMABLE_STOPS`), else the
   checkpoint is deleted once the stepper has assembled and audited the packing; the :class:`~.result.RunStats`.
"""

from __future__ import annotations

import logging
import os
import time
from abc import ABC, abstractmethod
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..core import interrupt
from ..core.history import History
from ..core.progress import Progress
from ..core.checkpoint import Checkpoint
from ..core.validation import INTERVAL, SECONDS
from ..core.packing import Packing
from .result import RESUMABLE_STOPS, Extras, RunResult, RunStats, is_completed

log = logging.getLogger("spherejam")


@dataclass(frozen=True)
class RunOptions:
    """The run options every engine takes, checked here (``checkpoint_interval`` by the checkpoint protocol,
    :class:`spherejam.core.checkpoint.Checkpoint`, when :func:`drive` starts, before any work).

    max_wall_time : float or None
        Stop after this many seconds of *this call* (a resumed run, e.g. the next SLURM job, gets its full
        budget). The checkpoint is kept, so a later call continues.
    checkpoint : path or None
        HDF5 checkpoint: resumed from if one of the same input and parameters exists, saved every
        ``checkpoint_interval`` seconds (>= 0; 0 = after every step) and at a resumable stop, deleted otherwise
        when the run ends.
    progress_interval : float
        Seconds (>= 0) between progress log lines (logger ``spherejam``).
    """

    max_wall_time: float | None = None
    checkpoint: str | os.PathLike | None = None
    checkpoint_interval: float = 300.0
    progress_interval: float = 10.0

    def __post_init__(self):
        if self.max_wall_time is not None:
            SECONDS.check("max_wall_time", self.max_wall_time)
        INTERVAL.check("progress_interval", self.progress_interval)


class Stepper(ABC):
    """One engine's state and its step, as :func:`drive` runs it.

    ``kind`` tags its checkpoints, ``label`` its progress lines, ``step_name`` what a step is ("window",
    "iteration"); ``history`` is a :class:`History` (rebuilt by :meth:`load` on resume)."""

    kind: str
    label: str
    step_name: str
    history: History

    @abstractmethod
    def start(self, wall_time: Callable[[], float]) -> None:
        """Set up a fresh run (``wall_time()``: seconds since the call began)."""

    @abstractmethod
    def load(self, arrays: dict[str, np.ndarray], attrs: dict[str, Any], history: dict[str, np.ndarray]) -> None:
        """Continue from a checkpoint written from :meth:`state`."""

    @abstractmethod
    def state(self) -> tuple[dict[str, np.ndarray], dict[str, Any]]:
        """Arrays and JSON attributes that :meth:`load` needs to continue bitwise identically."""

    def stop_before(self) -> str | None:
        """A stop reason that holds before any (further) step, or None."""
        return None

    @abstractmethod
    def step(self, wall_time: Callable[[], float]) -> str | None:
        """One window or iteration; ``wall_time()`` is the run's wall time so far. Returns the stepper's own stop
        reason (rule, target or step budget) or None."""

    @abstractmethod
    def report(self, progress: Progress, stop: str | None, wall_time: float) -> None:
        """The progress update after a step."""

    def finish(self, wall_time: float) -> None:  # noqa: B027 - an optional hook: most steppers add nothing
        """Called once after the last step (and any checkpoint save), before the result is assembled."""

    @property
    @abstractmethod
    def steps(self) -> int: ...

    @property
    @abstractmethod
    def collisions(self) -> int | None: ...

    @property
    @abstractmethod
    def phi_initial(self) -> float: ...

    @property
    @abstractmethod
    def phi(self) -> float:
        """The packing fraction of the current state."""

    @abstractmethod
    def extras(self) -> Extras: ...

    @abstractmethod
    def result(self, stats: RunStats) -> Packing:
        """The run's packing with ``stats`` in its metadata, audited (raise SimulationError if it fails)."""


def drive(stepper: Stepper, options: RunOptions, fingerprint: str,
          callback: Callable[[], None] | None = None) -> RunResult:
    """Run ``stepper`` (see the module docstring). ``fingerprint`` (:func:`spherejam.core.checkpoint.fingerprint`
    of the input and the parameters that determine the result) keeps a checkpoint from resuming another run;
    ``callback()`` runs after every step (an exception aborts the run and keeps the checkpoint)."""
    call_start = time.perf_counter()
    ckpt = Checkpoint(options.checkpoint, stepper.kind, fingerprint, options.checkpoint_interval)
    saved = ckpt.resume()
    wall_before = 0.0 if saved is None else float(saved[1]["wall_time"])

    def this_call() -> float:
        return time.perf_counter() - call_start

    def wall_time() -> float:
        return wall_before + this_call()

    if saved is None:
        stepper.start(wall_time)
    else:
        arrays, attrs, history = saved
        stepper.load(arrays, attrs["engine"], history)

    def save() -> None:
        arrays, attrs = stepper.state()
        ckpt.save(arrays, {"engine": attrs, "wall_time": wall_time()}, stepper.history.as_arrays())

    def out_of_time() -> str | None:
        limit = options.max_wall_time
        return "max_wall_time" if limit is not None and this_call() >= limit else None

    bar = Progress(stepper.label, options.progress_interval)
    stop = stepper.stop_before()  # the clock is read after steps only: every call makes progress
    while stop is None:
        stop = stepper.step(wall_time) or out_of_time()
        stepper.report(bar, stop, wall_time())
        if stop is None and ckpt.due():
            save()
        if stop is None and interrupt.requested() is not None:  # SIGTERM/SIGINT: save and stop
            save()
            interrupt.stop(options.checkpoint, f"after {stepper.steps} {stepper.step_name}s")
        if callback is not None:
            callback()
    if stop in RESUMABLE_STOPS:
        save()
    stepper.finish(wall_time())
    stats = RunStats(stop_reason=stop, completed=is_completed(stop), steps=stepper.steps,
                     collisions=stepper.collisions, wall_time=wall_time(), resumed=saved is not None,
                     phi_initial=stepper.phi_initial, phi_final=stepper.phi, extras=stepper.extras())
    packing = stepper.result(stats)
    if stop not in RESUMABLE_STOPS:
        ckpt.discard()
    collisions = "" if stats.collisions is None else f" collisions={stats.collisions:,}"
    bar.update(f"done: phi={stats.phi_final:.6f} {stepper.step_name}s={stats.steps}{collisions} "
               f"wall={stats.wall_time:.1f} s ({stop})", force=True)
    return RunResult(packing=packing, history=stepper.history.as_arrays(), stats=stats)
