"""Live progress of long runs: one status line on a terminal, the periodic log lines elsewhere.

The engines and CALiPPSO report through :class:`Progress` only. Each update carries the log message
and, for the live line, named values (``fields``) and an optional bar (fraction in [0, 1] and its caption). Inside
:func:`live_status` with a terminal on stderr the values go to a ``rich`` status line redrawn a few times a second
and the periodic log lines are dropped (the forced ones, such as "done", still print, above the line); without a
terminal nothing changes (Snakemake and SLURM logs keep their lines); ``--quiet`` disables both.
"""

from __future__ import annotations

import contextlib
import logging
import math
import os
import sys
import time
from collections.abc import Mapping
from typing import Any

_log = logging.getLogger("spherejam")

#: Redraws per second of the status line (the engines update it after every window or iteration).
REFRESH_PER_SECOND = 4
BAR_WIDTH = 12

_active: StatusLine | None = None


def _text(value: Any) -> str:
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        return str(value)
    if isinstance(value, int):
        return f"{value:,}"
    return f"{value:.4g}" if math.isfinite(value) else str(value)


class StatusLine:
    """A ``rich`` live line on ``stream``: label, bar, named values and elapsed time of the latest update."""

    def __init__(self, stream):
        from rich.console import Console

        self.console = Console(file=stream, force_terminal=True)  # we decided it is a terminal
        self._state: tuple | None = None
        self._live = None
        self._handlers: list[tuple[logging.StreamHandler, Any]] = []

    def show(self, label: str, elapsed: float, fields: Mapping[str, Any], bar: tuple[float, str] | None) -> None:
        self._state = (label, elapsed, dict(fields), bar)  # one assignment: the refresh thread reads it whole
        if self._live is None:
            self._start()

    def _start(self) -> None:
        from rich.live import Live

        stdout_shared = _is_terminal(sys.stdout)
        self._live = Live(self, console=self.console, refresh_per_second=REFRESH_PER_SECOND, transient=False,
                          redirect_stdout=stdout_shared, redirect_stderr=True)
        self._live.start()
        # log lines (forced progress lines, warnings) must go through the live console to print above the line
        for handler in logging.getLogger().handlers:
            if isinstance(handler, logging.StreamHandler) and handler.stream in (sys.__stderr__, self.console.file):
                self._handlers.append((handler, handler.stream))
                handler.setStream(sys.stderr)

    def close(self) -> None:
        if self._live is not None:
            self._live.stop()
            self._live = None
        for handler, stream in self._handlers:
            handler.setStream(stream)
        self._handlers.clear()

    def __rich__(self):
        from rich.text import Text

        line = Text(no_wrap=True, overflow="ellipsis")  # a narrow terminal cuts the end rather than wrapping
        if self._state is None:
            return line
        label, elapsed, fields, bar = self._state
        line.append(label, style="bold")
        line.append(f" {elapsed:,.0f} s ", style="dim")
        if bar is not None:
            fraction, caption = bar
            fraction = min(max(float(fraction), 0.0), 1.0) if math.isfinite(fraction) else 0.0
            filled = round(fraction * BAR_WIDTH)
            line.append("━" * filled, style="green")
            line.append("━" * (BAR_WIDTH - filled), style="bright_black")
            line.append(f" {caption} {fraction:.2f} ")
        line.append("  ".join(f"{k} {_text(v)}" for k, v in fields.items()))
        return line


def _is_terminal(stream) -> bool:
    try:
        return bool(stream.isatty()) and os.environ.get("TERM", "") != "dumb"
    except (AttributeError, ValueError):
        return False


def current() -> StatusLine | None:
    """The active status line, or None (no terminal, ``--quiet``, or outside :func:`live_status`)."""
    return _active


@contextlib.contextmanager
def live_status(enabled: bool = True, stream=None):
    """Show the engines' progress as a live status line while inside, if ``enabled`` and ``stream`` (default
    stderr) is a terminal; otherwise do nothing, so :class:`spherejam.engines.driver.Progress` keeps its log lines."""
    global _active
    stream = sys.stderr if stream is None else stream
    if not enabled or not _is_terminal(stream) or _active is not None:
        yield None
        return
    line = StatusLine(stream)
    _active = line
    try:
        yield line
    finally:
        _active = None
        line.close()


def log_fraction(p: float, p_max: float) -> float:
    """log p / log p_max: how far a compression is on the way to its pressure threshold (p >= 1, p_max > 1)."""
    if not (p > 1 and p_max > 1):
        return 0.0
    return math.log(p) / math.log(p_max)


def per_second(count: float, seconds: float) -> float:
    """``count`` per second of wall time (a throughput, not a compression rate), 0 before any time has passed."""
    return count / seconds if seconds > 0 else 0.0


class Progress:
    """Progress of a run: a log line (to the ``spherejam`` logger) at most every ``interval`` seconds, or, on a
    terminal, the live status line of :mod:`spherejam.core.progress` fed with every update's ``fields`` and ``bar``."""

    def __init__(self, label: str, interval: float = 10.0):
        self.label = label
        self.interval = interval
        self.start = time.perf_counter()
        self._last = -float("inf")

    @property
    def elapsed(self) -> float:
        return time.perf_counter() - self.start

    def update(self, message: str, force: bool = False, fields: dict[str, Any] | None = None,
               bar: tuple[float, str] | None = None) -> None:
        """Report ``message``; ``fields`` (name -> value) and ``bar`` (fraction in [0, 1], caption) are what the
        live status line shows. Updates without fields always go to the log."""
        line = current() if fields is not None else None
        if line is not None:
            line.show(self.label, self.elapsed, fields, bar)
            if not force:
                return
        now = time.perf_counter()
        if force or now - self._last >= self.interval:
            self._last = now
            _log.info("%s [%7.1f s] %s", self.label, now - self.start, message)
