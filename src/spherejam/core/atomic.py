"""Atomic file output: write to a temporary file in the target folder, then ``os.replace``.

A crash or kill mid-write leaves no file at the final path, so a half-written packing can never be mistaken for a
result (and Snakemake sees the output as missing and reruns the job). The file gets the mode a plain ``open`` would
give it (0666 minus the umask), not ``mkstemp``'s private 0600.

The rename replaces whatever is at the path, so this module is also where the rules about *what* may be replaced
live (docs/robustness.md, "Outputs"):

- a symlink is followed: its target is written, the link stays;
- the null device (``-o /dev/null``) discards the output: the file is written to a temporary folder (so every
  check and error of the write still happens) and deleted;
- anything else that is not a regular file (a device, a FIFO, a socket, a descriptor of this process such as
  ``/dev/stdout``) is never replaced: :class:`~spherejam.core.errors.InputError`;
- a failed write (disk full, quota) raises :class:`~spherejam.core.errors.OutputError`, one line naming the
  command-line argument the path came from (:func:`label_output`), and leaves the old file in place.

:func:`atomic_folder` does the same for a set of files that belong together (tables, a packing-generation folder):
all new or all old; :func:`replaced_folder` replaces a whole folder (an archive) by exchanging it with a new one.
"""

from __future__ import annotations

import contextlib
import errno
import os
import shutil
import signal
import stat
import tempfile
from collections.abc import Iterable
from pathlib import Path

from . import interrupt
from .errors import InputError, OutputError

#: Longest file name prefix a temporary file keeps of its target's name: ``.{name}.XXXXXXXX.tmp{suffix}`` must fit
#: NAME_MAX (255 on every common file system) even for the longest allowed output name.
_PREFIX_CHARS = 200
#: errno values that mean "the file system is full", and the text h5py puts in its messages instead of an errno.
_FULL = {errno.ENOSPC, errno.EDQUOT, errno.EFBIG}
_FULL_TEXT = ("No space left on device", "errno = 28", "Disk quota exceeded", "File too large")

_LABELS: dict[str, str] = {}


def label_output(path: str | os.PathLike, argument: str) -> None:
    """Remember that ``path`` came from the command-line argument ``argument`` (``-o/--output``), so that a write
    error names it. :func:`spherejam.core.output_paths.check_outputs` calls this for every output it checks."""
    _LABELS[os.path.realpath(path)] = argument


def special_kind(path: str | os.PathLike) -> str | None:
    """What ``path`` is if it exists and is not a regular file (symlinks followed): ``"a FIFO"``, ``"a character
    device"``, ...; ``"the null device"`` for /dev/null (the discard idiom); None for a regular or missing file."""
    if _through_descriptor(path):
        return "a path through /proc or /dev/fd (a descriptor such as /dev/stdout)"
    try:
        mode = os.stat(path).st_mode
    except OSError:
        return None
    if stat.S_ISREG(mode) or stat.S_ISDIR(mode):
        return None
    if is_null_device(path):
        return "the null device"
    for test, kind in ((stat.S_ISFIFO, "a FIFO"), (stat.S_ISCHR, "a character device"),
                       (stat.S_ISBLK, "a block device"), (stat.S_ISSOCK, "a socket")):
        if test(mode):
            return kind
    return "not a regular file"


def is_null_device(path: str | os.PathLike) -> bool:
    """``path`` is the null device (the same device numbers as ``os.devnull``, wherever its node lives)."""
    try:
        st, null = os.stat(path), os.stat(os.devnull)
    except OSError:
        return False
    return stat.S_ISCHR(st.st_mode) and st.st_rdev == null.st_rdev


def _through_descriptor(path: str | os.PathLike) -> bool:
    """``path`` is, or links through, ``/proc/<pid>/fd`` or ``/dev/fd`` (``/dev/stdout``): renaming over it would
    replace a symlink of the system, and writing through it would go to whatever this process has open."""
    current = os.path.abspath(path)
    for _ in range(40):  # the kernel's own limit on symlink hops
        if current.startswith(("/proc/", "/dev/fd/")):
            return True
        if not os.path.islink(current):
            return False
        current = os.path.normpath(os.path.join(os.path.dirname(current), os.readlink(current)))
    return False


def temp_prefix(path: str | os.PathLike) -> str:
    """The name prefix of ``path``'s temporary files (also how leftovers of a killed write are recognised)."""
    return f".{Path(path).name[:_PREFIX_CHARS]}."


def remove_leftovers(path: str | os.PathLike, suffix: str = "") -> list[Path]:
    """Delete temporary files that a killed write to ``path`` left next to it (``.NAME.XXXXXXXX.tmpSUFFIX``);
    returns them. Only for files that one process owns at a time (a checkpoint)."""
    path = Path(os.path.realpath(path))  # the folder and name atomic_output writes into
    if not path.parent.is_dir():
        return []
    removed = []
    for p in path.parent.glob(f"{_glob_escape(temp_prefix(path))}*.tmp{_glob_escape(suffix)}"):
        middle = p.name[len(temp_prefix(path)):-len(f".tmp{suffix}")]
        if len(middle) == 8 and p.is_file():  # mkstemp's 8 random characters, nothing else
            with contextlib.suppress(FileNotFoundError):
                p.unlink()
                removed.append(p)
    return removed


def _glob_escape(text: str) -> str:
    return "".join(f"[{c}]" if c in "*?[" else c for c in text)


@contextlib.contextmanager
def atomic_output(path: str | os.PathLike, suffix: str = ""):
    """Yield a temporary path next to ``path``; on success move it onto ``path``, on error delete it."""
    target = Path(os.path.realpath(path))
    kind = special_kind(path)
    if kind == "the null device":
        with tempfile.TemporaryDirectory(prefix="spherejam-discard.") as folder, _write_errors(path):
            yield Path(folder) / f"discarded{suffix}"
        return
    if kind is not None:
        raise InputError(f"{_label(path)}: is {kind}, not a regular file; refusing to replace it")
    with _write_errors(path):
        target.parent.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(prefix=temp_prefix(target), suffix=f".tmp{suffix}", dir=target.parent)
        try:
            os.fchmod(fd, 0o666 & ~_umask())
        finally:
            os.close(fd)
    try:
        with _write_errors(path):  # inside: a full disk is recognised before the partial file is deleted
            yield Path(tmp)
            interrupt.check()  # a signal (even one a library swallowed) never ends with a new output in place
            os.replace(tmp, target)
    except BaseException:
        with contextlib.suppress(FileNotFoundError):
            os.unlink(tmp)
        raise


def _fresh_folder_beside(folder: Path) -> Path:
    """A new, empty temporary folder in ``folder``'s parent (created if missing), named after ``folder``."""
    with _write_errors(folder):
        folder.parent.mkdir(parents=True, exist_ok=True)
        return Path(tempfile.mkdtemp(prefix=temp_prefix(folder), suffix=".tmp", dir=folder.parent))


@contextlib.contextmanager
def atomic_folder(folder: str | os.PathLike, names: Iterable[str]):
    """Yield a temporary folder; write the files ``names`` into it. On success they replace those in ``folder``
    together (a missing ``folder`` is renamed into place in one step, so it appears complete or not at all); on
    error the temporary folder is deleted and ``folder`` is as it was (a missing one is not created)."""
    folder = Path(os.path.realpath(folder))
    names = tuple(names)
    tmp = _fresh_folder_beside(folder)
    try:
        with _write_errors(folder):
            yield tmp
        missing = [n for n in names if not (tmp / n).is_file()]
        if missing:
            raise OutputError(f"{_label(folder)}: {', '.join(missing)} not written")
        interrupt.check()
        if not folder.exists():
            os.chmod(tmp, 0o777 & ~_umask())
            os.rename(tmp, folder)
            return
        # Every file is complete on disk before the first rename; renames within one folder need no space, so
        # only a kill during these few renames (microseconds) could leave a mixed set.
        for name in names:
            os.replace(tmp / name, folder / name)
        tmp.rmdir()
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise


@contextlib.contextmanager
def replaced_folder(folder: str | os.PathLike):
    """Yield a fresh temporary folder beside ``folder`` (same parent: a fresh name, never a fixed one a user may
    hold); fill it. On success it takes ``folder``'s place in one step: renamed in if ``folder`` is missing,
    exchanged with it if not (``renameat2(RENAME_EXCHANGE)``), and then the old folder is deleted. At every instant
    either the old or the new folder is at the path, also under kill -9. The caller decides beforehand that the
    existing ``folder`` may be replaced (:mod:`spherejam.workflow.archive` checks its manifest). On error or a
    signal the temporary folder is deleted and ``folder`` is as it was."""
    folder = Path(os.path.realpath(folder))  # a symlink is followed: its target is replaced, the link stays
    tmp = _fresh_folder_beside(folder)
    try:
        with _write_errors(folder):
            yield tmp
        interrupt.check()
        os.chmod(tmp, 0o777 & ~_umask())
        if _swap_in(tmp, folder):  # tmp now holds the old folder
            shutil.rmtree(tmp)
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)  # the new folder, or (after the swap) the old one
        raise


_RENAME_NOREPLACE, _RENAME_EXCHANGE, _AT_FDCWD = 1, 2, -100


def _swap_in(new: Path, target: Path) -> bool:
    """Put the folder ``new`` at ``target`` in one step; True if ``target`` existed (``new`` then holds it)."""
    exists = os.path.lexists(target)
    flag = _RENAME_EXCHANGE if exists else _RENAME_NOREPLACE
    if _renameat2(new, target, flag):
        return exists
    # no renameat2 on this system or file system: two renames with the signals held back between them (only a
    # kill -9 in those microseconds could leave the path empty; the old folder is then beside it)
    old = Path(tempfile.mkdtemp(prefix=temp_prefix(target), suffix=".old", dir=target.parent)) if exists else None
    blocked = signal.pthread_sigmask(signal.SIG_BLOCK, interrupt.SIGNALS)
    try:
        if old is not None:
            os.rename(target, old)  # onto the empty folder mkdtemp made: a fresh name
        os.rename(new, target)
        if old is not None:
            os.rename(old, new)
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, blocked)
    return exists


def _renameat2(source: Path, target: Path, flag: int) -> bool:
    """``renameat2(source, target, flag)``; False where the system or the file system does not offer it."""
    import ctypes

    try:
        call = ctypes.CDLL(None, use_errno=True).renameat2
    except (AttributeError, OSError):
        return False
    if call(_AT_FDCWD, os.fsencode(source), _AT_FDCWD, os.fsencode(target), flag) == 0:
        return True
    err = ctypes.get_errno()
    if err in (errno.ENOSYS, errno.EINVAL, errno.ENOTSUP):
        return False
    raise OSError(err, os.strerror(err), os.fspath(target))


@contextlib.contextmanager
def _write_errors(path: str | os.PathLike):
    """Turn a full file system into one line naming the argument (h5py reports it as an OSError whose message
    holds the errno in text form, over several lines; numpy without an errno at all)."""
    try:
        yield
    except OSError as exc:
        if isinstance(exc, OutputError) or not (_is_full(exc) or _no_space_left(path)):
            raise
        raise OutputError(f"{_label(path)}: no space left on the file system; nothing written (an existing file "
                          "is kept)") from None


def _is_full(exc: BaseException) -> bool:
    while exc is not None:
        if isinstance(exc, OSError) and (exc.errno in _FULL or any(t in str(exc) for t in _FULL_TEXT)):
            return True
        exc = exc.__cause__ or exc.__context__
    return False


def _no_space_left(path: str | os.PathLike) -> bool:
    """The file system of ``path`` has no free block (numpy reports a short write as "N requested and M written",
    without an errno)."""
    folder = Path(os.path.realpath(path)).parent
    while not folder.is_dir():
        folder = folder.parent
    try:
        return os.statvfs(folder).f_bavail == 0
    except OSError:
        return False


def _label(path: str | os.PathLike) -> str:
    argument = _LABELS.get(os.path.realpath(path))
    return f"{argument}={os.fspath(path)!r}" if argument else os.fspath(path)


def _umask() -> int:
    """The process umask (reading it means setting it; it is put back at once)."""
    mask = os.umask(0o022)
    os.umask(mask)
    return mask
