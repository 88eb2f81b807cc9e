"""The output-path policy of every command: check all outputs before any work, never overwrite an input.

A command calls :func:`check_outputs` once, right after parsing its arguments and before reading or computing
anything, with every file it will write and every file it reads, each under the name of its command-line argument::

    check_outputs({"-o/--output": args.output, "--summary": args.summary},
                  inputs={"path": args.path}, also={"--checkpoint": args.checkpoint})

File outputs are parsed with ``type=output_file``. :func:`check_outputs` raises
:class:`~spherejam.core.errors.InputError` (the CLI prints one line and exits 2) naming the argument and the path when
an output

- is empty, an existing directory, or ends with a path separator;
- exists and is not a regular file (a device, a FIFO, a socket, ``/dev/stdout``): it is never replaced; the null
  device (``-o /dev/null``) is allowed and means "discard" (:mod:`spherejam.core.atomic`);
- has a name longer than the file system allows;
- is the same file as an input (resolved paths, or ``os.path.samefile`` for hard links) or as another output;
- lies below an existing non-directory, or its nearest existing folder is not writable (missing folders are
  created later by :func:`spherejam.core.atomic.atomic_output`, so they only have to be creatable).

Outputs are then written through :func:`spherejam.core.atomic.atomic_output` (temporary file, then rename), so a failure
midway leaves the old file (or none) in place. ``also`` holds files a command both reads and writes (a checkpoint):
they must be writable and must not be an input or an output, but may exist.
"""

from __future__ import annotations

import os
from collections.abc import Mapping
from pathlib import Path

from .atomic import is_null_device, label_output, special_kind
from .errors import InputError

PathLike = str | os.PathLike


def check_outputs(outputs: Mapping[str, PathLike | None], inputs: Mapping[str, PathLike | None] | None = None,
                  also: Mapping[str, PathLike | None] | None = None) -> dict[str, Path]:
    """Check every output path of a command before it does any work; return them resolved, by argument name.

    ``outputs``, ``inputs`` and ``also`` map argument names (``"-o/--output"``) to paths; ``None`` entries (an
    option not given) are skipped.
    """
    ins = {name: Path(p) for name, p in (inputs or {}).items() if p is not None}
    outs = {name: p for name, p in outputs.items() if p is not None}
    both = {name: p for name, p in (also or {}).items() if p is not None}
    resolved: dict[str, Path] = {}
    for name, raw in {**outs, **both}.items():
        path = _check_one(name, raw)
        if is_null_device(path):
            if name in both:
                raise InputError(f"{name}={str(raw)!r}: the null device cannot hold a file that is read back; "
                                 "leave the option out instead")
            resolved[name] = path
            continue
        for in_name, in_path in ins.items():
            if _same(path, in_path):
                raise InputError(f"{name}={str(raw)!r}: is the same file as the input ({in_name} {in_path}); "
                                 "refusing to overwrite it")
        for other, done in resolved.items():
            if _same(path, done) and not is_null_device(done):
                raise InputError(f"{name}={str(raw)!r}: is also given as {other}")
        resolved[name] = path
    return resolved


def check_output_dir(name: str, raw: PathLike, inputs: Mapping[str, PathLike | None] | None = None,
                     files: tuple[str, ...] = ()) -> Path:
    """Check a folder a command writes into: an existing directory or creatable, and writable.

    ``files`` are the names the command will write inside it; each is checked against the inputs.
    """
    text = os.fspath(raw)
    if text == "":
        raise InputError(f"{name}='': an empty path")
    _check_length(name, text, Path(os.path.abspath(text)))
    path = Path(text).resolve()
    if path.exists() and not path.is_dir():
        raise InputError(f"{name}={text!r}: exists and is not a directory")
    _check_creatable(name, text, path)
    label_output(path, name)
    if files:
        check_outputs({f"{name} file {f}": path / f for f in files}, inputs)
    return path


def output_file(text: str) -> Path:
    """The argparse ``type=`` of a file output: like ``Path``, but an empty path or one ending with a separator (which
    ``Path`` would silently turn into a file name) is refused at parse time, naming the option."""
    import argparse

    if text == "":
        raise argparse.ArgumentTypeError("'': an empty path")
    if text.endswith(("/", os.sep)):
        raise argparse.ArgumentTypeError(f"{text!r}: names a directory, not a file")
    return Path(text)


def figure_stem(raw: PathLike, default_name: str) -> Path:
    """The output stem of a figure: ``raw`` itself, or ``raw/<default_name>`` if ``raw`` is a folder (an existing
    directory or a path ending with a separator), so that ``-o figs/`` writes ``figs/fig2.png``."""
    text = os.fspath(raw)
    if text == "":
        raise InputError("-o/--output='': an empty path")
    if is_null_device(text):  # STEM.png beside /dev/null would be a new file in /dev, not a discarded figure
        raise InputError(f"-o/--output={text!r}: a figure is written as STEM.png and STEM.pdf; the null device is "
                         "not a stem")
    if text.endswith(("/", os.sep)) or Path(text).is_dir():
        return Path(text) / default_name
    return Path(text)


def _check_one(name: str, raw: PathLike) -> Path:
    text = os.fspath(raw)
    if text == "":
        raise InputError(f"{name}='': an empty path")
    if text.endswith(("/", os.sep)):
        raise InputError(f"{name}={text!r}: names a directory, not a file")
    _check_length(name, text, Path(os.path.abspath(text)))
    kind = special_kind(text)
    if kind is not None and kind != "the null device":
        raise InputError(f"{name}={text!r}: is {kind}, not a regular file; spherejam writes whole files and never "
                         "replaces a special file (-o /dev/null discards an output)")
    path = Path(text).resolve()
    if kind == "the null device":  # nothing is written there: no folder or length to check, never "the same file"
        return path
    if path.is_dir():
        raise InputError(f"{name}={text!r}: is an existing directory, not a file")
    _check_creatable(name, text, path.parent)  # the rename needs only the folder writable, not the old file
    label_output(text, name)
    return path


def _check_length(name: str, text: str, path: Path) -> None:
    """Every component of ``path`` fits the file system's NAME_MAX, and the whole its PATH_MAX."""
    ancestor = path
    while not _exists(ancestor):
        ancestor = ancestor.parent
    try:
        name_max, path_max = os.pathconf(ancestor, "PC_NAME_MAX"), os.pathconf(ancestor, "PC_PATH_MAX")
    except (OSError, ValueError):
        name_max, path_max = 255, 4096
    for part in path.parts:
        if len(os.fsencode(part)) > name_max:
            raise InputError(f"{name}={_short(text)}: the name {_short(part)} has {len(os.fsencode(part))} bytes; "
                             f"the file system allows {name_max}")
    if len(os.fsencode(str(path))) >= path_max:
        raise InputError(f"{name}={_short(text)}: the path has {len(os.fsencode(str(path)))} bytes; the file "
                         f"system allows {path_max - 1}")


def _exists(path: Path) -> bool:
    try:
        os.stat(path)
    except OSError:  # missing, or a name too long to look up
        return False
    return True


def _short(text: str) -> str:
    return repr(text) if len(text) <= 60 else repr(text[:40] + "..." + text[-12:])


def _check_creatable(name: str, text: str, folder: Path) -> None:
    """``folder`` exists as a writable directory, or can be made (its nearest existing ancestor is one)."""
    ancestor = folder
    while not ancestor.exists():
        ancestor = ancestor.parent
    if not ancestor.is_dir():
        raise InputError(f"{name}={text!r}: {ancestor} is not a directory")
    if not os.access(ancestor, os.W_OK | os.X_OK):
        raise InputError(f"{name}={text!r}: folder {ancestor} is not writable")


def _same(a: Path, b: Path) -> bool:
    a, b = Path(a), Path(b)
    if a.resolve() == b.resolve():
        return True
    try:
        return os.path.samefile(a, b)
    except OSError:  # one of them does not exist yet
        return False
