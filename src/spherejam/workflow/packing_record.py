"""One packing of an archived results dataset: what the dataset holds about it, its files, its MLS history.

``spherejam browse DATASET --packing KEY`` uses this module. The dataset (``results/dataset.nc``) is
self-contained; the packing files may or may not be next to it. They are looked for below the dataset's folder
first (a results folder copied or archived as a whole) and then in the ``results`` folder of the dataset's config
(the workflow's own run); what is not found is reported, not guessed.
"""

from __future__ import annotations

import json
import math
import os
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from ..core.errors import InputError, PackingFileError
from . import experiment

#: Files of one packing below ``<results>/packings/<key>/`` (the workflow's stages).
PACKING_FILES = tuple(experiment.PACKING_FILES.values())


@dataclass
class PackingFiles:
    """Where a packing's files were looked for and which were found."""

    results: Path | None  # the results folder that holds the packing's folder, None if none was found
    searched: list[Path]
    files: dict[str, Path]  # name -> path of the files that exist
    missing: list[str]
    logs: list[Path]
    grid_files: list[Path]


def packing_index(ds, key: str) -> int:
    """Index along ``packing`` of the entry whose ``key`` is ``key``; InputError naming a few keys otherwise."""
    keys = [str(k) for k in ds["key"].values]
    if key in keys:
        return keys.index(key)
    examples = ", ".join(keys[:3])
    raise InputError(f"--packing={key!r}: no such packing in the dataset ({len(keys)} packings, keys like "
                     f"{examples}; list them with --columns key)")


def _value(v) -> Any:
    v = v.item() if hasattr(v, "item") else v
    if isinstance(v, bytes):
        v = v.decode()
    return v


def entry(ds, key: str) -> dict[str, dict[str, Any]]:
    """Everything the dataset holds for packing ``key``: its coordinates and variables (with long names and units),
    and the validation-grid runs made on it (by ``grid_run`` index)."""
    i = packing_index(ds, key)
    row = ds.isel(packing=i)
    out: dict[str, dict[str, Any]] = {"coordinates": {}, "variables": {}, "grid_runs": {}}
    for name in ds.coords:
        if ds[name].dims == ("packing",):
            out["coordinates"][name] = _value(row[name].values)
    for name in ds.data_vars:
        if ds[name].dims == ("packing",):
            a = ds[name].attrs
            out["variables"][name] = (_value(row[name].values), a.get("long_name", ""), a.get("units", ""))
    if "grid_run" in ds.dims and str(out["coordinates"].get("protocol")) == "ls":
        c = out["coordinates"]
        match = ((ds.grid_sigma.values == c["sigma"]) & (ds.grid_rate.values == c["rate"])
                 & (ds.grid_replica.values == c["replica"]))
        if "grid_n" in ds:  # older datasets have one N
            match &= ds.grid_n.values == c["n"]
        for g in np.flatnonzero(match):
            grow = ds.isel(grid_run=int(g))
            out["grid_runs"][int(g)] = {n: _value(grow[n].values) for n in list(ds.coords) + list(ds.data_vars)
                                        if ds[n].dims == ("grid_run",)}
    return out


def locate(dataset_path: str | os.PathLike, ds, key: str) -> PackingFiles:
    """Find the files of packing ``key`` next to the dataset or in its config's results folder."""
    dataset_path = Path(dataset_path)
    config = json.loads(ds.attrs.get("config", "{}"))
    candidates = [dataset_path.resolve().parent]
    configured = Path(config.get("results", "results"))
    if configured.resolve() not in candidates:
        candidates.append(configured.resolve())
    searched = [c / "packings" / key for c in candidates]
    results = next((c for c, s in zip(candidates, searched) if s.is_dir()), None)
    files: dict[str, Path] = {}
    logs: list[Path] = []
    grid_files: list[Path] = []
    if results is not None:
        folder = results / "packings" / key
        files = {name: folder / name for name in PACKING_FILES if (folder / name).is_file()}
        paths = experiment.Paths(results)
        jobs = [job for job in experiment.JOB_FOLDERS if job != "mls_grid"]  # the packing's own jobs, in order
        logs = [Path(log) for log in dict.fromkeys(paths.log(job, key) for job in jobs) if Path(log).is_file()]
        grid_dir = results / "validation" / key
        if grid_dir.is_dir():
            grid_files = sorted(grid_dir.glob("*.h5"))
    missing = [name for name in PACKING_FILES if name not in files]
    return PackingFiles(results, searched, files, missing, logs, grid_files)


def _format(value) -> str:
    if isinstance(value, float):
        return "nan" if math.isnan(value) else f"{value:.10g}"
    return str(value)


def describe(dataset_path, ds, key: str) -> list[str]:
    """The lines ``spherejam browse --packing`` prints."""
    e = entry(ds, key)
    lines = [f"packing {key} of {dataset_path}"]
    lines += [f"  {name} = {_format(v)}" for name, v in e["coordinates"].items() if name != "key"]
    width = max((len(n) for n in e["variables"]), default=0)
    for name, (value, long_name, units) in e["variables"].items():
        unit = f" [{units}]" if units and units != "1" else ""
        lines.append(f"  {name:<{width}s} = {_format(value):<16s} {long_name}{unit}")
    for g, values in e["grid_runs"].items():
        text = ", ".join(f"{n} {_format(v)}" for n, v in values.items() if not n.startswith("grid_") or
                         n in ("grid_phi_J", "grid_collisions", "grid_completed"))
        lines.append(f"  validation-grid run {g}: {text}")
    found = locate(dataset_path, ds, key)
    if found.results is None:
        lines.append("  packing files: not found; looked in " + ", ".join(str(s) for s in found.searched))
    else:
        lines.append(f"  packing files (in {found.results / 'packings' / key}):")
        lines += [f"    {path}" for path in found.files.values()]
        if found.missing:
            lines.append(f"    missing: {', '.join(found.missing)}")
        lines += [f"    log: {path}" for path in found.logs]
        lines += [f"    validation grid: {path}" for path in found.grid_files]
    return lines


def mls_history_figure(jammed: str | os.PathLike, title: str = ""):
    """p and phi against the cumulative collisions of the MLS run that made ``jammed`` (a packing file), one
    colour per compression stage (labelled with its rate gamma), equilibration stages in grey."""
    from ..core.packing_io import read_packing
    from .plotting import pyplot

    _, history = read_packing(jammed, with_history=True)
    needed = ("collisions", "pressure", "phi", "rate", "stage")
    if any(k not in history for k in needed):
        raise PackingFileError(f"{jammed}: no MLS history (needs the columns {', '.join(needed)})")
    collisions = np.cumsum(history["collisions"])
    p, phi, rate, stage = history["pressure"], history["phi"], history["rate"], history["stage"].astype(int)
    plt = pyplot()
    fig, (ax_p, ax_phi) = plt.subplots(2, 1, sharex=True, figsize=(7.5, 6.0), constrained_layout=True)
    compress = sorted({int(s) for s, r in zip(stage, rate) if r > 0})
    cmap = plt.get_cmap("viridis")
    for s in np.unique(stage):
        m = stage == s
        r = float(rate[m][0])
        if r > 0:
            k = compress.index(int(s))
            colour, label = cmap(k / max(len(compress) - 1, 1)), f"γ = {r:.3g}"
        else:
            colour, label = "0.6", ("equilibration (γ = 0)" if s == stage[rate == 0][0] else None)
        ax_p.plot(collisions[m], p[m], ".-", color=colour, ms=3, lw=0.8, label=label)
        ax_phi.plot(collisions[m], phi[m], ".-", color=colour, ms=3, lw=0.8)
    ax_p.set_yscale("log")
    ax_p.set_ylabel("reduced pressure p")
    ax_phi.set_ylabel("packing fraction φ")
    ax_phi.set_xlabel("collisions (cumulative)")
    ax_p.set_title(title or f"MLS history of {jammed}", fontsize=9)
    handles, labels = ax_p.get_legend_handles_labels()
    order = sorted(range(len(labels)), key=lambda k: labels[k].startswith("equilibration"))  # rates first
    ax_p.legend([handles[k] for k in order], [labels[k] for k in order], fontsize=6,
                ncol=max(1, math.ceil((len(compress) + 1) / 10)), loc="lower right")
    return fig
