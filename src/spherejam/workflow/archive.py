"""A results folder packed for the repository or a paper's supplement: the dataset, the tables, the figures and,
within a size limit, chosen jammed packings, with a README that says what it holds and which code made it.

The archive is a results folder in miniature (the same layout), so ``spherejam browse ARCHIVE/dataset.nc`` with
``--tables``, ``--figure`` and ``--packing`` works on it as on the run itself; a packing left out says where it
was looked for. It is written as a whole beside the target and swapped in
(:func:`~spherejam.core.atomic.replaced_folder`): a failed or killed archive leaves the old one as it was. Only a folder
that holds exactly what this command wrote (its manifest ``archive.json``) is ever replaced.
"""

from __future__ import annotations

import fnmatch
import hashlib
import json
import logging
import os
import shutil
from dataclasses import dataclass
from pathlib import Path

from ..core.atomic import replaced_folder
from ..core.errors import InputError
from .dataset import dataset_config, open_dataset, sizes_in
from .experiment import PACKING_FILES

#: The files of the run's own folders an archive takes: every table and figure the workflow wrote.
KEPT = {"tables": ("*.csv", "*.md", "*.tex"), "figures": ("*.png", "*.pdf")}


@dataclass(frozen=True)
class ArchivePlan:
    """What :func:`write_archive` copies: archive-relative name -> source file, and the total size in bytes."""

    files: dict[str, Path]
    size: int


def plan_archive(results: str | os.PathLike, packings: list[str] = (), stages: tuple[str, ...] = ("jammed",)
                 ) -> ArchivePlan:
    """The files of an archive of the results folder ``results``: its ``dataset.nc``, ``experiment.json``, tables
    and figures, and the ``stages`` files (keys of :data:`PACKING_FILES`) of every packing whose key matches one of
    the glob patterns ``packings`` (``n1000/*``, ``ls/sigma0.3/*``)."""
    results = Path(results)
    dataset = results / "dataset.nc"
    if not dataset.is_file():
        raise InputError(f"results={results}: no dataset.nc there (run the workflow first)")
    for stage in stages:
        if stage not in PACKING_FILES:
            raise InputError(f"--stage={stage!r}: must be one of {', '.join(PACKING_FILES)}")
    files = {"dataset.nc": dataset}
    if (results / "experiment.json").is_file():
        files["experiment.json"] = results / "experiment.json"
    for folder, patterns in KEPT.items():
        for pattern in patterns:
            for path in sorted((results / folder).glob(pattern)):
                files[f"{folder}/{path.name}"] = path
    ds = open_dataset(dataset)
    keys = [str(k) for k in ds["key"].values]
    for pattern in packings:
        chosen = [k for k in keys if fnmatch.fnmatchcase(k, pattern)]
        if not chosen:
            raise InputError(f"--packings={pattern!r}: matches no packing of the dataset (keys look like {keys[0]})")
        for key in chosen:
            for stage in stages:
                path = results / "packings" / key / PACKING_FILES[stage]
                if not path.is_file():
                    raise InputError(f"--packings={pattern!r}: {path} is missing")
                files[f"packings/{key}/{PACKING_FILES[stage]}"] = path
    return ArchivePlan(files, sum(p.stat().st_size for p in files.values()))


def readme(ds, plan: ArchivePlan, command: str, stripped: bool = False) -> str:
    """The archive's README.md: what it holds, which code and config made it, and how to look at it."""
    config = dataset_config(ds)
    sizes = sizes_in(ds)
    n_packings = len({Path(name).parent for name in plan.files if name.startswith("packings/")})
    figures = sorted({Path(n).stem for n in plan.files if n.startswith("figures/")})
    lines = [
        "# spherejam results archive",
        "",
        f"Made by `{command}` from a finished workflow run.",
        "",
        "| | |",
        "|---|---|",
        f"| code | spherejam, git commit `{ds.attrs.get('git_commit', 'unknown')}` ({ds.attrs.get('source', '')}) |",
        f"| config | hash `{ds.attrs.get('config_hash', '')}`; the whole config is the dataset's attribute `config` "
        "and `experiment.json` |",
        f"| dataset created | {ds.attrs.get('created', '')} |",
        f"| N | {', '.join(map(str, sizes))} |",
        f"| size distributions | {', '.join(sorted(set(str(d) for d in ds['distribution'].values)))} |",
        f"| packings | {ds.sizes['packing']} in the dataset; the files of {n_packings} of them here |",
        f"| master seed | {config.get('seed')} |",
        "",
        "Contents: `dataset.nc` (every packing's scalars and provenance), `tables/` (Tables 2-4 next to the paper's, "
        "`comparison.md`" + (", `finite_size.md`" if "tables/finite_size.md" in plan.files else "") + "), "
        f"`figures/` ({', '.join(figures)})" + (", `packings/` (jammed packings, spherejam HDF5"
                                                  + ("; without their run histories" if stripped else "") + ")"
                                                  if n_packings else "") + ". `archive.json` lists every file "
        "with its SHA-256: `spherejam archive` replaces this folder only while it holds exactly those files.",
        "",
        "Look at it without running anything:",
        "",
        "```bash",
        "spherejam browse dataset.nc                 # summary and the packings",
        "spherejam browse dataset.nc --tables        # Tables 2-4 beside the paper's",
        "spherejam browse dataset.nc --figure fig5   # redraw a figure from the dataset",
        "spherejam browse dataset.nc --packing KEY   # one packing's record (and its files, where archived)",
        "```",
        "",
    ]
    return "\n".join(lines)


def copy_without_history(source: Path, target: Path) -> None:
    """Copy a packing file without its run history (the per-window arrays of LS/MLS, most of a jammed file's size):
    positions, diameters, every other group and every attribute, provenance included, are kept as they are."""
    import h5py

    with h5py.File(source, "r") as fin, h5py.File(target, "w") as fout:
        for key, value in fin.attrs.items():
            fout.attrs[key] = value
        for name in fin:
            if name != "history":
                fin.copy(name, fout)


def _size(folder: Path) -> int:
    return sum(p.stat().st_size for p in folder.rglob("*") if p.is_file())


#: The manifest an archive holds: every file the archive command wrote, with its SHA-256. It is how an existing folder
#: is recognised as an archive that may be replaced; nothing else is (docs/robustness.md, "Replacing a folder").
MANIFEST = "archive.json"
MANIFEST_FORMAT = "spherejam-archive-1"
_OUTPUT = "-o/--output"


def _sha256(path: Path) -> str:
    digest = hashlib.sha256()
    with open(path, "rb") as fh:
        for block in iter(lambda: fh.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()


def archive_target(out: str | os.PathLike, results: str | os.PathLike) -> Path:
    """The folder ``-o`` names (a symlink followed), checked before anything is read or written: not empty, not the
    results folder or a folder holding it, and either missing or an archive this command wrote, unchanged since
    (:func:`check_replaceable`). Raises :class:`InputError` naming the option."""
    text = os.fspath(out)
    if text.strip() == "":
        raise InputError(f"{_OUTPUT}={text!r}: an empty path")
    target = Path(os.path.realpath(text))
    if target.parent == target:
        raise InputError(f"{_OUTPUT}={text!r}: the root folder cannot be an archive")
    source = Path(os.path.realpath(results))
    if target == source or target in source.parents:
        raise InputError(f"{_OUTPUT}={text!r}: is the results folder {results} or holds it; an archive is written "
                         "beside the run, choose another folder")
    if os.path.lexists(target):
        if not target.is_dir():
            raise InputError(f"{_OUTPUT}={text!r}: exists and is not a folder")
        check_replaceable(target, text)
    ancestor = target.parent
    while not ancestor.exists():
        ancestor = ancestor.parent
    if not ancestor.is_dir() or not os.access(ancestor, os.W_OK | os.X_OK):
        raise InputError(f"{_OUTPUT}={text!r}: folder {ancestor} is not writable")
    return target


def check_replaceable(folder: Path, text: str) -> None:
    """Refuse (one line, :class:`InputError`) unless ``folder`` holds exactly the files its archive manifest lists,
    each with the content the archive command wrote: a user's folder, another results run, or an archive with a note
    added or a file edited is never replaced."""
    refuse = f"{_OUTPUT}={text!r}: exists and"
    manifest = folder / MANIFEST
    try:
        data = json.loads(manifest.read_text()) if manifest.is_file() and not manifest.is_symlink() else None
    except (OSError, ValueError):
        data = None
    if not isinstance(data, dict) or data.get("format") != MANIFEST_FORMAT or not isinstance(data.get("files"), dict):
        raise InputError(f"{refuse} is not a spherejam archive (no {MANIFEST} written by spherejam archive); nothing "
                         "replaced: choose a new folder")
    listed = data["files"]
    folders = {str(Path(name).parent) for name in listed} | {"."}
    folders |= {str(parent) for name in listed for parent in Path(name).parents}
    for root, dirs, files in os.walk(folder):
        rel_root = Path(root).relative_to(folder)
        for name in sorted(dirs):
            rel = rel_root / name
            if (folder / rel).is_symlink() or str(rel) not in folders:
                raise InputError(f"{refuse} holds {rel}/, which spherejam archive did not write; nothing replaced: "
                                 "move it out or choose a new folder")
        for name in sorted(files):
            rel = str(rel_root / name)
            if rel == MANIFEST:
                continue
            path = folder / rel
            if rel not in listed or path.is_symlink() or not path.is_file():
                raise InputError(f"{refuse} holds {rel}, which spherejam archive did not write; nothing replaced: "
                                 "move it out or choose a new folder")
            if _sha256(path) != listed[rel]:
                raise InputError(f"{refuse} its {rel} was changed since spherejam archive wrote it; nothing "
                                 "replaced: move it out or choose a new folder")


def write_archive(results: str | os.PathLike, out: str | os.PathLike, packings: list[str] = (),
                  stages: tuple[str, ...] = ("jammed",), max_mb: float = 20.0, command: str = "spherejam archive",
                  strip_history: bool = False) -> ArchivePlan:
    """Copy :func:`plan_archive` of ``results`` to the folder ``out``, with its README.md and manifest
    (:data:`MANIFEST`); ``strip_history`` leaves the run histories out of the packing files. An existing ``out`` is
    replaced as a whole, and only if it is an archive this command wrote (:func:`archive_target`), by exchanging it
    with the new one built beside it (:func:`~spherejam.core.atomic.replaced_folder`). Refuses one larger than
    ``max_mb`` megabytes, leaving an archive already there as it was."""
    target = archive_target(out, results)
    plan = plan_archive(results, list(packings), stages)
    if plan.size > max_mb * 1e6 and not strip_history:  # stripped, the size is known once written
        raise InputError(f"--max-mb={max_mb:g}: the archive would hold {plan.size / 1e6:.1f} MB; choose fewer "
                         "--packings (or raise the limit)")
    ds = open_dataset(Path(results) / "dataset.nc")
    text = readme(ds, plan, command, strip_history)
    with replaced_folder(target) as tmp:
        logging.getLogger("spherejam").info("%s: copying %d files (%.1f MB) into %s", out, len(plan.files),
                                            plan.size / 1e6, tmp.name)
        for name, source in plan.files.items():
            (tmp / name).parent.mkdir(parents=True, exist_ok=True)
            if strip_history and name.startswith("packings/") and name.endswith(".h5"):
                copy_without_history(source, tmp / name)
            else:
                shutil.copy2(source, tmp / name)
        (tmp / "README.md").write_text(text)
        if _size(tmp) > max_mb * 1e6:
            raise InputError(f"--max-mb={max_mb:g}: the archive would hold {_size(tmp) / 1e6:.1f} MB; choose "
                             "fewer --packings (or raise the limit)")
        files = {str(p.relative_to(tmp)): _sha256(p) for p in sorted(tmp.rglob("*")) if p.is_file()}
        (tmp / MANIFEST).write_text(json.dumps({"format": MANIFEST_FORMAT, "command": command, "files": files},
                                               indent=1) + "\n")
    return plan


__all__ = ["MANIFEST", "ArchivePlan", "archive_target", "check_replaceable", "plan_archive", "readme",
           "write_archive"]
