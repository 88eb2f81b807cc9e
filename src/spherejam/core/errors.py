"""Exceptions raised by spherejam.

Every error a user can cause (bad argument, bad config, bad file) is a ``SpherejamError``; the CLI turns it into
a one-line message and a non-zero exit code instead of a traceback.
"""

from __future__ import annotations


class SpherejamError(Exception):
    """Base class of all errors spherejam reports to users."""


class InputError(SpherejamError, ValueError):
    """A parameter, argument or config value is invalid."""


class PackingFileError(SpherejamError, OSError):
    """A packing, checkpoint or dataset file is missing, malformed or fails validation."""


class StaleCheckpointError(PackingFileError):
    """A checkpoint exists for this output but was written for another input or other parameters.

    The library refuses to resume it (a hand-run resume must not silently restart); the workflow, which reruns a
    job precisely because its input changed, discards it (``--discard-stale-checkpoint``)."""

    def __init__(self, path, message: str):
        super().__init__(message)
        self.path = path


class OverlapError(SpherejamError):
    """A packing has overlapping spheres beyond the tolerance (it must never become a result)."""


class OutputError(SpherejamError, OSError):
    """An output could not be written (the file system is full); the old file, if any, is kept."""


class SimulationError(SpherejamError, RuntimeError):
    """An engine detected an internal inconsistency (lost event, NaN, failed solve)."""


def require(condition: bool, field: str, value, rule: str) -> None:
    """Raise :class:`InputError` naming ``field`` and ``value`` unless ``condition`` holds.

    ``rule`` says what the value must be, e.g. ``"must be > 0"``.
    """
    if not condition:
        raise InputError(f"{field}={value!r}: {rule}")
