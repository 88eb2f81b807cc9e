"""``--discard-stale-checkpoint``: the workflow's answer to a checkpoint of an older input.

Snakemake reruns a job when its input or parameters changed, and the job then finds the checkpoint of the previous
run at its checkpoint path. The library refuses that checkpoint (:class:`~spherejam.core.errors.StaleCheckpointError`)
because a hand-run resume must never restart silently. The rules pass this option: the stale file is deleted, the
deletion is logged, and the run starts over once. A checkpoint of the same input still resumes as before.
"""

from __future__ import annotations

import logging
import os
from collections.abc import Callable
from typing import TypeVar

from ..core.errors import StaleCheckpointError

T = TypeVar("T")
log = logging.getLogger("spherejam")


def add_option(p) -> None:
    p.add_argument("--discard-stale-checkpoint", action="store_true",
                   help="delete a checkpoint of another input or parameters and start over, instead of stopping "
                        "(the workflow's rules set it)")


def run_discarding_stale(args, run: Callable[[], T]) -> T:
    """``run()``; with ``--discard-stale-checkpoint``, a stale checkpoint is deleted (logged) and ``run()`` repeated.

    Checkpoints are resumed before any work, so the first attempt costs nothing but reading the file."""
    try:
        return run()
    except StaleCheckpointError as exc:
        if not args.discard_stale_checkpoint:
            raise
        log.warning("discarded stale checkpoint %s (written for another input or other parameters); starting over",
                    exc.path)
        os.remove(exc.path)
        return run()
