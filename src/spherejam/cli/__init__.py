"""The ``spherejam`` command line.

Each subcommand lives in its own module under :mod:`spherejam.cli` and exposes ``register(subparsers)``; heavy
modules (numba engines) are imported only when their command runs, so ``spherejam --help`` stays fast.
Errors a user can cause print one line ``spherejam <cmd>: error: ...`` and exit with status 2 (bad input) or 1
(a check failed); the long runs (``ls``, ``mls``, ``fb``, ``calippso``) stopped by SIGTERM or SIGINT save their
checkpoint and exit with 128 + the signal number (:mod:`spherejam.core.interrupt`). Every command checks its output
paths before any work (:mod:`spherejam.core.output_paths`) and takes its numeric limits from
:mod:`spherejam.core.validation`. A closed pipe (``spherejam info x | head -1``) ends the command quietly with status
141, as a killed-by-SIGPIPE program would.
"""

from __future__ import annotations

import argparse
import importlib
import logging
import os
import sys

from ..core import interrupt
from ..core.errors import InputError, PackingFileError, SpherejamError
from ..core.progress import live_status
from ..core.provenance import spherejam_version

#: Modules providing subcommands, in the order they appear in ``--help``.
COMMAND_MODULES = ("packing_commands", "psd", "rcp", "run", "workflow_commands", "analyze", "calippso", "fb", "ls",
                   "mls", "cost", "render", "view")

EXIT_BAD_INPUT = 2
EXIT_FAILED = 1
EXIT_BROKEN_PIPE = 141
#: Commands that run for long and stop on SIGTERM/SIGINT with a checkpoint saved (core/interrupt.py).
INTERRUPTIBLE = ("ls", "mls", "fb", "calippso")


class OneLineParser(argparse.ArgumentParser):
    """argparse that reports bad arguments in one line (no usage dump) with exit status 2."""

    def error(self, message: str):
        sys.stderr.write(f"{self.prog}: error: {message}\n")
        raise SystemExit(EXIT_BAD_INPUT)


def build_parser() -> argparse.ArgumentParser:
    parser = OneLineParser(prog="spherejam", description=__doc__.splitlines()[0])
    parser.add_argument("--version", action="version", version=f"spherejam {spherejam_version()}")
    parser.add_argument("-q", "--quiet", action="store_true", help="only warnings and errors on stderr")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", parser_class=OneLineParser)
    sub.required = True
    for name in COMMAND_MODULES:
        importlib.import_module(f"{__name__}.{name}").register(sub)
    for command in sub.choices.values():  # `spherejam mls ... --quiet` as well as `spherejam --quiet mls ...`
        command.add_argument("-q", "--quiet", action="store_true", default=argparse.SUPPRESS,
                             help="no progress display or log lines, only warnings and errors")
    return parser


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    try:
        # a command that hands the options it does not know to another program (`run`: Snakemake) gets them as
        # args.extra; every other command refuses them, as parse_args would
        args, extra = parser.parse_known_args(argv)
        if extra and not getattr(args, "passthrough", False):
            parser.error(f"unrecognized arguments: {' '.join(extra)}")
        args.extra = extra
    except SystemExit as exc:  # a usage error (2), --help or --version (0): returned like every other outcome
        return int(exc.code or 0)
    # Only spherejam's own progress lines at INFO: other packages' INFO lines (freud's "Using SciPy's fftpack")
    # are not ours to show, quiet or not.
    logging.basicConfig(level=logging.WARNING, format="%(message)s", stream=sys.stderr)
    logging.getLogger("spherejam").setLevel(logging.WARNING if args.quiet else logging.INFO)
    # the long runs stop at their next step with a checkpoint; every other command stops at once, writing nothing
    previous = interrupt.install(at_once=args.command not in INTERRUPTIBLE)
    try:
        return _run(args)
    finally:
        # a caller of main() gets its handlers back; the spherejam process itself is ending: a signal from here on
        # only sets the exit status (no traceback from the interpreter's shutdown)
        interrupt.restore(previous if argv is not None else interrupt.quiet_exit_handlers())


def _run(args) -> int:
    try:
        with live_status(enabled=not args.quiet):  # the live progress line, on a terminal only
            code = int(args.func(args) or 0)
        sys.stdout.flush()  # a closed pipe shows here, not in the interpreter's exit
        interrupt.check()  # a signal whose exception a library swallowed: not a success
        return code
    except BrokenPipeError:
        # the reader went away: say nothing, and point stdout at /dev/null so the exit-time flush cannot fail again
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return EXIT_BROKEN_PIPE
    except (interrupt.Interrupted, interrupt.Stopped) as exc:
        sys.stderr.write(f"spherejam {args.command}: {exc}\n")
        return exc.exit_status
    except (InputError, PackingFileError) as exc:
        sys.stderr.write(f"spherejam {args.command}: error: {exc}\n")
        return EXIT_BAD_INPUT
    except SpherejamError as exc:
        sys.stderr.write(f"spherejam {args.command}: error: {exc}\n")
        return EXIT_FAILED
    except KeyboardInterrupt:
        sys.stderr.write(f"spherejam {args.command}: interrupted\n")
        return 130
    except MemoryError:
        sys.stderr.write(f"spherejam {args.command}: error: out of memory\n")
        return EXIT_FAILED
    except OSError as exc:  # disk full, a file vanished mid-run: the system's reason and the file, in one line
        where = f"{exc.filename}: " if exc.filename else ""
        sys.stderr.write(f"spherejam {args.command}: error: {where}{exc.strerror or exc}\n")
        return EXIT_FAILED


# helpers shared by the command modules --------------------------------------------------------------------------


def finite_float(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a number") from None
    if value != value or value in (float("inf"), float("-inf")):
        raise argparse.ArgumentTypeError(f"{text!r} must be finite")
    return value


def seed_int(text: str) -> int:
    """An argparse type: a seed, 0 <= seed < 2^63 (stored as a signed 64-bit integer)."""
    from ..core.validation import FIELDS

    return FIELDS["seed"].arg(text)


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
