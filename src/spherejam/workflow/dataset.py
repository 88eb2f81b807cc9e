"""The results database: one self-contained xarray dataset with every run's scalars and full provenance.

Two dimensions:

* ``packing``: one entry per generated packing (N, protocol, distribution, gamma, replica), with its initial density
  phi, closest jamming density phi_J (MLS), run counters, structure measures and CALiPPSO certification;
* ``grid_run``: the parameter-validation grid (MLS with other parameter sets on selected LS packings).

Each packing's size distribution is a set of coordinates: ``distribution`` (its key, ``sigma0.1`` or a config
name), ``psd`` (the spec) and the population's descriptors ``psd_delta``, ``psd_skewness``, ``psd_size_ratio``,
``psd_z``; ``sigma`` is the log-normal sigma of a ``sigmas`` run (NaN for a named distribution). The drawn sample's
own descriptors are variables (``sample_delta``, ...). Datasets written before distributions existed get these
coordinates on reading (:func:`open_dataset`), from their sigma. The coordinate ``n`` is each packing's number of
spheres N (a ladder of N has several); a dataset written before it existed gets it from its ``n`` attribute.

An experiment with containers (docs/containers.md) adds the coordinates ``container`` (its name in the config),
``container_spec`` and ``container_shape``, the variables ``container_size`` (the achieved D/<d> of a cylinder or a
sphere, H/<d> of a slab), ``container_length`` (a cylinder's L/<d>), ``phi_core`` and ``wall_contacts`` (from the
structure analysis), ``not_available`` (the stages skipped for the packing, with their reasons) and the porosity
profile of each packing from its wall, ``profile_porosity`` over ``wall_distance`` (the centres of bins of
:data:`spherejam.analysis.profiles.DEFAULT_BIN_WIDTH` mean diameters). A dataset of the
periodic cube alone has none of these, as before containers.

The config, its hash, package versions and git commit are stored as JSON-string attributes, so the file can be
archived and browsed without the packing files (``spherejam browse``).
"""

from __future__ import annotations

import json
import math
import os
import warnings
from pathlib import Path
from typing import Any

import numpy as np

from ..core.atomic import atomic_output
from ..core.errors import InputError, PackingFileError
from ..core.input_paths import regular_file
from ..core.packing_io import FORMAT, dumps
from ..core.provenance import provenance
from ..engines.result import RunStats, stats_from_metadata
from .config import check_config
from .experiment import Experiment, GridRun, Part, Run, fmt, shorthand_key

#: name -> (long_name, units) of the variables this module writes (structure/CALiPPSO add their own).
VARIABLES: dict[str, tuple[str, str]] = {
    "phi": ("packing fraction of the generated packing", "1"),
    "pressure": ("reduced pressure p = PV/(N kB T) at the end of generation (LS only)", "1"),
    "generation_collisions": ("collisions of the LS generation run", "1"),
    "generation_iterations": ("iterations of the FB generation run, or LS pressure windows", "1"),
    "generation_wall_time": ("wall time of the generation run", "s"),
    "phi_J": ("closest jamming density (MLS)", "1"),
    "pressure_J": ("reduced pressure at the end of MLS", "1"),
    "mls_collisions": ("collisions of the MLS run", "1"),
    "mls_stages": ("compression stages of the MLS run", "1"),
    "mls_windows": ("pressure windows of the MLS run", "1"),
    "mls_wall_time": ("wall time of the MLS run", "s"),
    "mls_completed": ("1 if MLS stopped by its own rule (final rate or jammed), 0 if cut by a cap", "1"),
    "mls_stalled_stages": ("MLS compression stages ended by the pressure-stall rule instead of p >= p_max", "1"),
    "grid_phi": ("packing fraction of the source LS packing", "1"),
    "grid_phi_J": ("closest jamming density (MLS with the grid's parameters)", "1"),
    "grid_collisions": ("collisions of the MLS run", "1"),
    "grid_stages": ("compression stages of the MLS run", "1"),
    "grid_wall_time": ("wall time of the MLS run", "s"),
    "grid_completed": ("1 if MLS stopped by its own rule, 0 if cut (collision or wall-time cap)", "1"),
    "sample_delta": ("relative std of the packing's drawn diameters", "1"),
    "sample_skewness": ("skewness of the packing's drawn diameters", "1"),
    "sample_size_ratio": ("d_max/d_min of the packing's drawn diameters", "1"),
    "sample_z": ("M2^2/(M1 M3) of the packing's drawn diameters", "1"),
    "container_size": ("achieved size of the container in mean diameters of the jammed packing: D/<d> of a "
                       "cylinder or a sphere, H/<d> of a slab (NaN otherwise)", "1"),
    "container_length": ("achieved length of a cylinder along its axis, L/<d> (NaN otherwise)", "1"),
    "phi_core": ("packing fraction of the region at least 5 mean diameters from every wall (NaN: no such region)",
                 "1"),
    "wall_contacts": ("sphere-wall contacts of the jammed packing", "1"),
    "not_available": ("stages not run for the packing, with their reasons", ""),
    "profile_porosity": ("porosity of the jammed packing at the distance wall_distance from its wall (radial in a "
                         "cylinder or a sphere, from the nearer wall in a slab or a box), exact sphere-shell volumes",
                         "1"),
    "wall_distance": ("distance from the wall of the bin centre, in mean diameters", "1"),
    "calippso_sampled": ("1 if CALiPPSO certifies this packing (calippso.per_cell's sample, or every packing), else 0",
                         "1"),
}
COORDS: dict[str, tuple[str, str]] = {
    "n": ("number of spheres N of the packing", "1"),
    "protocol": ("generation protocol: ls = Lubachevsky-Stillinger, fb = force-biased", ""),
    "sigma": ("relative standard deviation of the log-normal diameters (sigmas runs; NaN for a named distribution)",
              "1"),
    "distribution": ("size distribution: sigma<value> (the sigmas shorthand) or its name in the config", ""),
    "psd": ("spec of the size distribution (docs/psd.md)", ""),
    "psd_family": ("family of the size distribution", ""),
    "psd_delta": ("relative std of the diameter distribution, std(D)/<D>", "1"),
    "psd_skewness": ("skewness of the diameter distribution", "1"),
    "psd_size_ratio": ("d_max/d_min of the diameter distribution (inf: unbounded)", "1"),
    "psd_z": ("M2^2/(M1 M3) of the diameter distribution (1 for equal spheres)", "1"),
    "rate": ("compression rate gamma; LS: d rho/dt, diameters D_i0 (rho0 + gamma t) with m = kB = 1, T = 0.2; "
             "FB: dimensionless shrink of the outer diameter per iteration (a different quantity: compare rates "
             "within one protocol only)", "1"),
    "inverse_rate": ("inverse compression rate 1/gamma", "1"),
    "replica": ("replica index", "1"),
    "seed": ("seed of the Poisson configuration", "1"),
    "key": ("path of the run below packings/", ""),
    "container": ("container: its name in the config (experiments with containers only)", ""),
    "container_spec": ("spec of the container (docs/containers.md)", ""),
    "container_shape": ("shape of the container: periodic, slab, box, cylinder or sphere", ""),
    "grid_n": ("number of spheres N of the source LS packing", "1"),
    "grid_sigma": ("relative standard deviation of the source LS packing", "1"),
    "grid_rate": ("LS compression rate gamma of the source packing", "1"),
    "grid_inverse_rate": ("inverse LS compression rate 1/gamma of the source packing", "1"),
    "grid_replica": ("replica index of the source packing", "1"),
    "decrease_factor": ("MLS compression-rate decrease factor", "1"),
    "initial_rate": ("MLS initial compression rate", "1"),
    "final_rate": ("MLS final compression rate", "1"),
}


def _attrs(path: Path) -> dict[str, Any]:
    """The scalar attributes of a packing file (not its arrays: those were validated when written)."""
    import h5py

    regular_file(path, "packing file", missing="no such file (the workflow should have produced it)")
    try:
        with h5py.File(path, "r") as f:
            a = dict(f.attrs)
    except OSError as exc:
        raise PackingFileError(f"{path}: unreadable ({str(exc).splitlines()[0]})") from None
    if a.get("format") != FORMAT:
        raise PackingFileError(f"{path}: not a spherejam packing file")
    out = {k: (v.item() if isinstance(v, np.generic) else v) for k, v in a.items()}
    for key in ("parameters", "counters", "metadata"):
        out[key] = json.loads(out.get(key, "{}"))
    return out


def _num(value) -> float:
    try:
        x = float(value)
    except (TypeError, ValueError):
        return math.nan
    return x


def _stats(path: Path, a: dict[str, Any], algorithms: tuple[str, ...]) -> RunStats:
    """The run summary of the packing file at ``path`` (attributes ``a``), made by one of ``algorithms``."""
    if a.get("algorithm") not in algorithms:
        raise PackingFileError(f"{path}: made by {a.get('algorithm')!r}, expected {' or '.join(algorithms)}")
    return stats_from_metadata(a, str(path))


def _generation_scalars(path: Path) -> dict[str, float]:
    a = _attrs(path)
    c = _stats(path, a, ("ls", "fb"))
    sample = (a["metadata"].get("size_distribution") or {}).get("sample") or {}
    return {
        **{f"sample_{k}": _num(sample.get(k)) for k in ("delta", "skewness", "size_ratio", "z")},
        "phi": _num(a.get("phi")),
        "pressure": _num(a.get("reduced_pressure")),
        "generation_collisions": _num(c.collisions),
        "generation_iterations": _num(c.steps),
        "generation_wall_time": _num(c.wall_time),
    }


def _mls_scalars(path: Path, prefix: str = "") -> dict[str, float]:
    a = _attrs(path)
    c = _stats(path, a, ("mls",))
    p = prefix or "mls_"
    out = {
        f"{p}collisions": _num(c.collisions),
        f"{p}stages": _num(c.extras.stages),
        f"{p}wall_time": _num(c.wall_time),
        f"{p}completed": float(c.completed),
    }
    if not prefix:
        out.update(
            phi_J=_num(a.get("phi")), pressure_J=_num(a.get("reduced_pressure")), mls_windows=_num(c.steps),
            mls_stalled_stages=_num(c.extras.stalled_stages),
        )
    else:
        out[f"{p}phi_J"] = _num(a.get("phi"))
    return out


def _json_scalars(path: Path, prefix: str) -> dict[str, float]:
    regular_file(path, "JSON file", missing="no such file (the workflow should have produced it)")
    try:
        data = json.loads(path.read_text())
    except (json.JSONDecodeError, UnicodeDecodeError) as exc:
        raise PackingFileError(f"{path}: corrupt JSON ({exc})") from None
    flat = data.get("scalars", data) if isinstance(data, dict) else data
    if not isinstance(flat, dict):
        raise PackingFileError(f"{path}: a JSON {type(flat).__name__}; expected an object of the packing's scalars")
    if not prefix:  # an analysis file written before the rename
        flat = {RENAMED.get(k, k): v for k, v in flat.items()}
    # every variable the dataset takes from the file is a number (null: not estimable); anything else would become
    # NaN without a word. Other entries (paths, the packing's description, scans) are not read.
    names = _structure_variables()
    known = {k.removeprefix(prefix) for k in names if k.startswith(prefix)} if prefix else {
        k for k in names if not k.startswith("calippso_")}
    for key, value in flat.items():
        if key in known and not (value is None or isinstance(value, (int, float, bool))):
            raise PackingFileError(f"{path}: {key}={_short_json(value)}: must be a number (or null)")
    return {f"{prefix}{k}": _num(v) for k, v in flat.items() if isinstance(v, (int, float, bool)) or v is None}


def _short_json(value) -> str:
    text = json.dumps(value)
    return text if len(text) <= 40 else text[:37] + "..."


def collect_runs(exp: Experiment, part: Part | None = None) -> tuple[list[Run], list[dict[str, float]]]:
    rows = []
    runs = exp.runs(part=part)
    for run in runs:
        row = _generation_scalars(exp.path(run, "initial"))
        row.update(_mls_scalars(exp.path(run, "jammed")))
        if exp.config.get("analysis", {}).get("enabled", True):
            row.update(_json_scalars(exp.path(run, "structure"), ""))
        if exp.config.get("calippso", {}).get("enabled", True):
            row["calippso_sampled"] = float(exp.certifies(run))  # calippso.per_cell's sample, or every packing
        if exp.certifies(run):
            row.update(_json_scalars(exp.path(run, "calippso"), "calippso_"))
            _no_certificate_without_forces(row)
        rows.append(row)
    return runs, rows


def collect_containers(exp: Experiment, runs: list[Run]) -> dict[str, tuple]:
    """The container coordinates and variables of the packings ``runs`` (:data:`VARIABLES`; an experiment with
    containers only): the achieved size from each jammed packing, the core phi, wall contacts and porosity profile
    from its structure analysis, and the stages skipped with their reasons."""
    from ..analysis.profiles import DEFAULT_BIN_WIDTH
    from ..core.packing_io import read_packing

    analysed = exp.config.get("analysis", {}).get("enabled", True)
    size, length, core, wall, skipped, profiles = [], [], [], [], [], []
    for run in runs:
        entry = exp.container(run.container)
        record: dict = {}
        if analysed:
            data = json.loads(exp.path(run, "structure").read_text())
            record = data.get("container") or {}
            reasons = dict(data.get("not_available") or {})
        else:
            reasons = {"structure": "not run (analysis.enabled: false)"}
        if entry.is_periodic_cube:
            achieved, porosity = {}, []
        elif record:
            achieved = record.get("achieved") or {}
            porosity = _full_bins((record.get("profile") or {}), DEFAULT_BIN_WIDTH)
        else:
            packing = read_packing(exp.path(run, "jammed"), tolerance=None)
            achieved, porosity = packing.container.in_diameters(packing.mean_diameter), []
        size.append(_num(achieved.get("diameter", achieved.get("height"))))
        length.append(_num(achieved.get("length")))
        core_phi = (record.get("core") or {}).get("phi") if record else None
        core.append(_num(core_phi))
        wall.append(_num(record.get("wall_contacts")) if record else math.nan)
        skipped.append("; ".join(f"{k}: {v}" for k, v in reasons.items()))
        profiles.append(porosity)
    bins = max((len(p) for p in profiles), default=0)
    table = np.full((len(runs), bins), math.nan)
    for i, p in enumerate(profiles):
        table[i, :len(p)] = p
    return {
        "coords": {
            "container": ("packing", np.array([run.container for run in runs], dtype=str)),
            "container_spec": ("packing", np.array([exp.container(r.container).spec for r in runs], dtype=str)),
            "container_shape": ("packing", np.array([exp.container(r.container).shape for r in runs], dtype=str)),
            "wall_distance": ("wall_distance", (np.arange(bins) + 0.5) * DEFAULT_BIN_WIDTH),
        },
        "data_vars": {
            "container_size": ("packing", np.array(size)),
            "container_length": ("packing", np.array(length)),
            "phi_core": ("packing", np.array(core)),
            "wall_contacts": ("packing", np.array(wall)),
            "not_available": ("packing", np.array(skipped, dtype=str)),
            "profile_porosity": (("packing", "wall_distance"), table),
        },
    }


def _full_bins(profile: dict, width: float) -> list[float]:
    """The porosity of a profile's bins of the full ``width`` from the wall (the last, shorter bin left out)."""
    edges, porosity = profile.get("edges") or [], profile.get("porosity") or []
    return [float(p) for p, a, b in zip(porosity, edges[:-1], edges[1:]) if abs((b - a) - width) < 1e-9]


def _no_certificate_without_forces(row: dict[str, float]) -> None:
    """A row's CALiPPSO verdict by the run's own rule (:func:`~spherejam.calippso.run.has_force_network`): a
    summary written before that rule, "converged" with no contact or an infinite force balance, is not certified."""
    from ..calippso.run import has_force_network

    if row.get("calippso_converged") == 1 and not has_force_network(row.get("calippso_n_contacts", math.nan),
                                                                      row.get("calippso_force_balance_residual",
                                                                              math.nan)):
        row["calippso_converged"] = 0.0
        row["calippso_is_isostatic"] = 0.0


def collect_grid(exp: Experiment, part: Part | None = None) -> tuple[list[GridRun], list[dict[str, float]]]:
    rows = []
    runs = exp.grid_runs(part)
    for g in runs:
        row = _mls_scalars(exp.grid_path(g), prefix="grid_")
        row["grid_phi"] = _num(_attrs(exp.path(g.source, "initial")).get("phi"))
        rows.append(row)
    return runs, rows


FORCE_BINS = np.geomspace(1e-4, 10.0, 41)  # f / <f>
GAP_BINS = np.geomspace(1e-12, 1e-1, 45)  # h = r / D_ij - 1
POOLED = "dist_distribution"  # the dimension of the pooled force and gap distributions: one per size distribution
PACKING_DIM = "packing"


def _pdf(values: np.ndarray, edges: np.ndarray) -> np.ndarray:
    """Probability density on ``edges``, normalised by the number of all values (also those outside)."""
    counts, _ = np.histogram(values, bins=edges)
    return counts / max(len(values), 1) / np.diff(edges)


def collect_distributions(exp: Experiment, part: Part | None = None) -> dict[str, tuple]:
    """Contact-force and gap distributions of the CALiPPSO-certified packings at the largest N, pooled per size
    distribution (a ``sigmas`` key or a named one; dimension ``dist_distribution``, with ``dist_sigma`` NaN for a
    named one), with the small-argument power-law exponents fitted on the pooled samples; of a part, the
    distributions it holds at the largest N (possibly none)."""
    from ..analysis.distributions import force_exponent, gap_exponent
    from ..core.packing_io import read_group

    dists = [d for d in exp.distributions if part is None or (exp.largest_n, d.key) in part.cells]
    rows = {k: [] for k in ("force_pdf", "extended_force_pdf", "gap_pdf", "force_exponent", "gap_exponent",
                            "n_forces", "n_gaps", "n_packings")}
    for dist in dists:
        forces, extended, gaps = [], [], []
        for run in exp.largest_runs():
            if run.dist != dist.key or not exp.certifies(run):
                continue
            c = read_group(exp.path(run, "calippso_packing"), "contacts")
            if c:
                forces.append(c["forces"])
                extended.append(c["forces"][c["extended"].astype(bool)])
                gaps.append(c["gaps"])
        f = np.concatenate(forces) if forces else np.array([])
        fe = np.concatenate(extended) if extended else np.array([])
        g = np.concatenate(gaps) if gaps else np.array([])
        rows["force_pdf"].append(_pdf(f, FORCE_BINS))
        rows["extended_force_pdf"].append(_pdf(fe, FORCE_BINS))
        rows["gap_pdf"].append(_pdf(g, GAP_BINS))
        rows["force_exponent"].append(_safe_exponent(force_exponent, fe))
        rows["gap_exponent"].append(_safe_exponent(gap_exponent, g))
        rows["n_forces"].append(len(f))
        rows["n_gaps"].append(len(g))
        rows["n_packings"].append(len(forces))
    dims = {"force_pdf": (POOLED, "force_bin"), "extended_force_pdf": (POOLED, "force_bin"),
            "gap_pdf": (POOLED, "gap_bin")}
    out = {k: (dims.get(k, (POOLED,)), np.array(v, dtype=float)) for k, v in rows.items()}
    out["_coords"] = {
        POOLED: (POOLED, np.array([d.key for d in dists], dtype=str)),
        "dist_sigma": (POOLED, np.array([d.sigma for d in dists], dtype=float)),
        "force_bin_centre": ("force_bin", np.sqrt(FORCE_BINS[1:] * FORCE_BINS[:-1])),
        "gap_bin_centre": ("gap_bin", np.sqrt(GAP_BINS[1:] * GAP_BINS[:-1])),
    }
    return out


def pooled_by_distribution(ds):
    """A dataset whose force and gap distributions were pooled per sigma (dimension ``dist_sigma``, before named
    distributions were pooled too), with the ``dist_distribution`` dimension of today."""
    if "dist_sigma" not in ds.dims:
        return ds
    keys = np.array([shorthand_key(float(s)) for s in ds["dist_sigma"].values], dtype=str)
    return ds.assign_coords({POOLED: ("dist_sigma", keys)}).swap_dims({"dist_sigma": POOLED})


def _safe_exponent(fit, values) -> float:
    try:
        return float(fit(values).exponent)
    except Exception:  # noqa: BLE001 - too few small values to fit: no exponent, not an error
        return math.nan


DISTRIBUTION_VARIABLES = {
    "force_pdf": ("probability density of contact forces f/<f>, CALiPPSO packings pooled per distribution", "1"),
    "extended_force_pdf": ("probability density of extended contact forces (no buckler contacts)", "1"),
    "gap_pdf": ("probability density of gaps h = r/D - 1 between non-contacting near neighbours", "1"),
    "force_exponent": ("small-force exponent theta_e of the pooled extended forces (mean field 0.42311)", "1"),
    "gap_exponent": ("small-gap exponent gamma_h of the pooled gaps, g(h) ~ h^-gamma_h (mean field 0.41269)", "1"),
    "n_forces": ("contact forces pooled", "1"),
    "n_gaps": ("gaps pooled", "1"),
    "n_packings": ("CALiPPSO-certified packings pooled (calippso.per_cell's sample, or every packing)", "1"),
    "dist_distribution": ("size distribution of the pooled packings (its key)", ""),
    "dist_sigma": ("log-normal sigma of the pooled packings (NaN for a named distribution)", "1"),
    "force_bin_centre": ("geometric centre of the force bin, f/<f>", "1"),
    "gap_bin_centre": ("geometric centre of the gap bin, h", "1"),
}


def _describe(ds, extra: dict[str, tuple[str, str]]) -> None:
    table = {**COORDS, **VARIABLES, **extra}
    for name in list(ds.variables):
        base = name.removeprefix("calippso_") if name not in table else name
        long_name, units = table.get(name, table.get(base, (name.replace("_", " "), "")))
        if name.startswith("calippso_") and name not in table:
            long_name = f"CALiPPSO: {long_name}"
        ds[name].attrs.setdefault("long_name", long_name)
        if units:
            ds[name].attrs.setdefault("units", units)


def _structure_variables() -> dict[str, tuple[str, str]]:
    from ..analysis import distributions, structure
    from ..calippso import run as calippso

    # CALiPPSO's names (its summary and, for a converged run, the fitted exponents) are prefixed in the dataset;
    # unprefixed they would shadow the generated packing's ``phi``.
    certificate = {**calippso.VARIABLES, **distributions.VARIABLES}
    return {
        **structure.VARIABLES,
        **{f"calippso_{k}": (f"CALiPPSO: {name}", units) for k, (name, units) in certificate.items()},
    }


def build_dataset(manifest_path: str | os.PathLike, sizes=None, dists=None):
    """Assemble the dataset of the experiment described by a manifest (see :func:`write_manifest`); with ``sizes``
    (N) or ``dists`` (distribution keys), the dataset of that part of it (:func:`merge_datasets` joins parts)."""
    import xarray as xr

    manifest_path = regular_file(manifest_path, "manifest file")
    try:
        manifest = json.loads(manifest_path.read_text())
    except (OSError, ValueError) as exc:  # ValueError: bad JSON, or a binary file (UnicodeDecodeError)
        reason = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        raise PackingFileError(f"{manifest_path}: unreadable manifest ({reason})") from None
    if not isinstance(manifest, dict) or not isinstance(manifest.get("config"), dict) or "config_hash" not in manifest:
        raise PackingFileError(f"{manifest_path}: not an experiment manifest (needs 'config' and 'config_hash'; "
                               "write one with `spherejam manifest`)")
    try:
        config = check_config(manifest["config"])
    except InputError as exc:
        raise PackingFileError(f"{manifest_path}: config {exc}") from None
    exp = Experiment(config)
    part = None if sizes is None and dists is None else exp.part(sizes, dists)

    runs, rows = collect_runs(exp, part)
    names = sorted({k for r in rows for k in r})
    data_vars = {name: ("packing", np.array([r.get(name, math.nan) for r in rows], dtype=float)) for name in names}
    coords = {
        "n": ("packing", np.array([exp.size(r) for r in runs], dtype=np.int64)),
        "protocol": ("packing", np.array([r.protocol for r in runs], dtype=str)),
        "sigma": ("packing", np.array([r.sigma for r in runs])),
        **distribution_coords(exp, [r.dist for r in runs]),
        "rate": ("packing", np.array([r.rate for r in runs])),
        "inverse_rate": ("packing", 1.0 / np.array([r.rate for r in runs])),
        "replica": ("packing", np.array([r.replica for r in runs], dtype=np.int64)),
        "seed": ("packing", np.array([r.seed(exp.master_seed) for r in runs], dtype=np.int64)),
        "key": ("packing", np.array([r.key for r in runs], dtype=str)),
    }
    if exp.has_containers:
        walls = collect_containers(exp, runs)
        coords.update(walls["coords"])
        data_vars.update(walls["data_vars"])
    grid_runs, grid_rows = collect_grid(exp, part)
    if grid_runs:
        gnames = sorted({k for r in grid_rows for k in r})
        data_vars.update(
            {n: ("grid_run", np.array([r.get(n, math.nan) for r in grid_rows], dtype=float)) for n in gnames}
        )
        coords.update(
            grid_n=("grid_run", np.array([exp.size(g.source) for g in grid_runs], dtype=np.int64)),
            grid_sigma=("grid_run", np.array([g.source.sigma for g in grid_runs])),
            grid_rate=("grid_run", np.array([g.source.rate for g in grid_runs])),
            grid_inverse_rate=("grid_run", 1.0 / np.array([g.source.rate for g in grid_runs])),
            grid_replica=("grid_run", np.array([g.source.replica for g in grid_runs], dtype=np.int64)),
            decrease_factor=("grid_run", np.array([g.decrease_factor for g in grid_runs])),
            initial_rate=("grid_run", np.array([g.initial_rate for g in grid_runs])),
            final_rate=("grid_run", np.array([g.final_rate for g in grid_runs])),
        )
    if exp.config.get("calippso", {}).get("enabled", True):
        dist = collect_distributions(exp, part)
        if dist["n_forces"][1].size:  # a part without the largest N pools nothing
            coords.update(dist.pop("_coords"))
            data_vars.update(dist)
    ds = xr.Dataset(data_vars=data_vars, coords=coords)
    extra = {**_structure_variables(), **DISTRIBUTION_VARIABLES}
    _describe(ds, extra)
    prov = provenance()
    ds.attrs.update(
        title="spherejam results: jammed hard-sphere packings and RCP limits",
        Conventions="CF-1.10",
        source=f"spherejam {prov['spherejam_version']}",
        references="V. Baranau and U. Tallarek, Soft Matter 10, 3826 (2014)",
        n=np.array(exp.sizes, dtype=np.int64) if exp.n_ladder else int(exp.sizes[0]),
        config=dumps(config),
        config_hash=manifest["config_hash"],
        git_commit=prov["git_commit"],
        package_versions=dumps(prov["package_versions"]),
        created=prov["created"],
        history=f"{prov['created']}: built by spherejam dataset from {manifest_path.name}"
        + ("" if part is None else f" (part: {part.label})"),
    )
    return ds


GRID_DIM = "grid_run"
GRID_ORDER = ("grid_n", "grid_sigma", "grid_rate", "grid_replica", "decrease_factor", "initial_rate", "final_rate")


def _grid_label(values) -> tuple:
    return tuple(int(v) if isinstance(v, (int, np.integer)) else fmt(float(v)) for v in values)


#: The dimensions a part's dataset is merged along, and the other dimensions of each one's variables.
_MERGED_DIMS = {PACKING_DIM: ("wall_distance",), GRID_DIM: (), POOLED: ("force_bin", "gap_bin")}


def _along(ds, dim: str):
    """The variables and coordinates of ``ds`` over ``dim`` and its own other dimensions (None if ``ds`` has no
    ``dim``)."""
    if dim not in ds.dims:
        return None
    keep = {dim, *_MERGED_DIMS[dim]}
    return ds.drop_dims([d for d in ds.dims if d not in keep])


def merge_datasets(parts: list, names: list[str] | None = None):
    """The dataset of a whole run from the datasets of its parts (``spherejam dataset --n/--distribution``), each
    built from the same config: the same packings in the same order as :func:`build_dataset` of the whole run, so
    that the tables and figures are those of a run made in one go. Raises :class:`PackingFileError` for parts of
    different configs, a packing in two parts, or a cell of the experiment in no part."""
    import xarray as xr

    if not parts:
        raise InputError("merge: give the datasets of the parts")
    names = names or [f"part {i + 1}" for i in range(len(parts))]
    first = parts[0]
    for ds, name in zip(parts, names):
        if ds.attrs.get("config_hash") != first.attrs.get("config_hash"):
            raise PackingFileError(f"{name}: config_hash={ds.attrs.get('config_hash')}: a part of another experiment "
                                   f"({names[0]} has {first.attrs.get('config_hash')})")
    exp = Experiment(dataset_config(first))
    seen: dict[str, str] = {}
    for ds, name in zip(parts, names):
        for key in ds["key"].values.tolist():
            if key in seen:
                raise PackingFileError(f"{name}: packing {key} is also in {seen[key]}")
            seen[key] = name
    expected: dict[tuple[int, str], list[str]] = {}
    for run in exp.runs():
        expected.setdefault((exp.cell_n(run), run.dist), []).append(run.key)
    order = [k for keys in expected.values() for k in keys]
    stray = sorted(set(seen) - set(order))
    if stray:
        raise PackingFileError(f"{seen[stray[0]]}: packing {stray[0]} is not one of the experiment's")
    missing = [f"n{n}/{d}" for (n, d), keys in expected.items() if any(k not in seen for k in keys)]
    if missing:
        raise PackingFileError(f"merge: no part holds {', '.join(missing)}: build its dataset too (spherejam "
                               "dataset --n N --distribution KEY) and merge it")
    def concat(sets, dim):
        return xr.concat(sets, dim=dim, data_vars="minimal", coords="minimal", compat="equals", join="outer")

    merged = []
    packings = concat([_along(ds, PACKING_DIM) for ds in parts], PACKING_DIM)
    position = {k: i for i, k in enumerate(packings["key"].values.tolist())}
    merged.append(packings.isel({PACKING_DIM: [position[k] for k in order]}))
    grids = [g for g in (_along(ds, GRID_DIM) for ds in parts) if g is not None]
    if grids:
        grid = concat(grids, GRID_DIM)
        labels = [_grid_label(v) for v in zip(*(grid[c].values for c in GRID_ORDER))]
        want = [_grid_label((exp.size(g.source), g.source.sigma, g.source.rate, g.source.replica, g.decrease_factor,
                             g.initial_rate, g.final_rate)) for g in exp.grid_runs()]
        merged.append(grid.isel({GRID_DIM: [labels.index(w) for w in want]}))
    pooled = [d for d in (_along(ds, POOLED) for ds in parts) if d is not None]
    if pooled:
        dist = concat(pooled, POOLED)
        keys = dist[POOLED].values.tolist()
        merged.append(dist.isel({POOLED: [keys.index(d.key) for d in exp.distributions if d.key in keys]}))
    ds = xr.merge(merged, combine_attrs="drop_conflicts", join="exact")
    prov = provenance()
    commits = sorted({str(p.attrs.get("git_commit")) for p in parts})
    ds.attrs.update(
        {k: first.attrs[k] for k in first.attrs if k not in ("git_commit", "created", "history", "package_versions")},
        git_commit=commits[0] if len(commits) == 1 else ", ".join(commits),
        package_versions=first.attrs.get("package_versions", ""),
        created=prov["created"],
        history="\n".join([*(str(p.attrs.get("history", "")) for p in parts),
                            f"{prov['created']}: merged by spherejam merge from {len(parts)} parts"]),
    )
    return ds


def distribution_coords(exp: Experiment, keys: list[str]) -> dict[str, tuple]:
    """The ``packing`` coordinates of the size distributions ``keys`` (one per packing)."""
    info = {}
    for d in exp.distributions:
        model = d.model()
        desc = model.descriptors()
        info[d.key] = (d.spec, model.family, desc.delta, desc.skewness, desc.size_ratio, desc.z)
    cols = list(zip(*[info[k] for k in keys])) if keys else [()] * 6
    names = ("psd", "psd_family", "psd_delta", "psd_skewness", "psd_size_ratio", "psd_z")
    out = {"distribution": ("packing", np.array(keys, dtype=str))}
    for name, values in zip(names, cols):
        out[name] = ("packing", np.array(values, dtype=str if name in ("psd", "psd_family") else float))
    return out


def with_distributions(ds):
    """A dataset written before distributions existed, with their coordinates derived from its sigma."""
    from ..core.size_distribution import lognormal_spec, parse

    if "distribution" in ds.coords or "distribution" in ds.variables:
        return ds
    sigmas = ds["sigma"].values.astype(float)
    desc = {s: parse(lognormal_spec(s)).descriptors() for s in set(sigmas.tolist())}
    return ds.assign_coords(
        distribution=("packing", np.array([f"sigma{float(s):g}" for s in sigmas], dtype=str)),
        psd=("packing", np.array([lognormal_spec(s) for s in sigmas], dtype=str)),
        psd_family=("packing", np.array(["lognormal"] * sigmas.size, dtype=str)),
        psd_delta=("packing", np.array([desc[s].delta for s in sigmas])),
        psd_skewness=("packing", np.array([desc[s].skewness for s in sigmas])),
        psd_size_ratio=("packing", np.array([desc[s].size_ratio for s in sigmas])),
        psd_z=("packing", np.array([desc[s].z for s in sigmas])),
    )


def container_keys(ds) -> list[str]:
    """The containers of a dataset's packings in their order (none for a dataset without containers)."""
    if "container" not in ds.variables:
        return []
    return list(dict.fromkeys(str(k) for k in ds["container"].values))


def reference_packings(ds):
    """The packings the paper's figures and the finite-size scaling are drawn from: of a dataset with containers,
    those in its first periodic cube (else in its first container); of one without, all."""
    keys = container_keys(ds)
    if not keys:
        return ds
    specs = dict(zip((str(k) for k in ds["container"].values), (str(s) for s in ds["container_spec"].values)))
    key = next((k for k in keys if specs[k] == "periodic"), keys[0])
    return ds.isel(packing=np.flatnonzero(ds["container"].values == key))


def sizes_in(ds) -> list[int]:
    """The numbers of spheres N of a dataset's packings, ascending (one, or a ladder)."""
    if "n" in ds.variables:
        return sorted({int(n) for n in ds["n"].values})
    n = ds.attrs.get("n", dataset_config(ds).get("n") if "config" in ds.attrs else None)
    return [] if n is None else sorted(int(x) for x in np.atleast_1d(n))


def at_n(ds, n: int):
    """The part of a dataset at one N: its packings (and validation-grid runs) with N = ``n``."""
    ds = ds.isel(packing=np.flatnonzero(ds["n"].values == n))
    if "grid_n" in ds.variables:
        ds = ds.isel(grid_run=np.flatnonzero(ds["grid_n"].values == n))
    return ds


def write_dataset(ds, path: str | os.PathLike) -> Path:
    """Write ``ds`` atomically as netCDF4 (h5netcdf engine)."""
    ds = _without_string_widths(ds)
    with atomic_output(path, ".nc") as tmp:
        ds.to_netcdf(tmp, engine="h5netcdf")
    return Path(path)


def _without_string_widths(ds):
    """``ds`` with no fixed string width in its variables' encodings. A dataset opened from a file remembers each
    string variable's width there (``<U6`` for "sigma0"), and a concatenation keeps the first part's: written with
    it, a merged "sigma0.3" became "sigma0" and longer keys were cut. The width must follow the data."""
    ds = ds.copy()
    for name in ds.variables:
        dtype = ds.variables[name].encoding.get("dtype")
        if dtype is not None and np.dtype(dtype).kind in "US":
            ds.variables[name].encoding.pop("dtype")
    return ds


def _refuse_packing_file(path: Path) -> None:
    """A packing file given where a dataset belongs: say so, and which command reads it."""
    import h5py

    from ..core.packing_io import FORMAT

    try:
        with h5py.File(path, "r") as f:
            is_packing = f.attrs.get("format") == FORMAT
    except OSError:  # not HDF5 at all: the netCDF reader's message says so
        return
    if is_packing:
        raise PackingFileError(f"{path}: a spherejam packing file, not a results dataset (`spherejam info` describes "
                               "it)")


#: Dataset variables renamed since datasets were first archived: old name -> new. The geometric count was read as a
#: verdict on jamming next to CALiPPSO's, which it is not (docs/algorithms.md §6.3).
RENAMED = {"is_isostatic": "isostatic_at_tolerance"}


def open_dataset(path: str | os.PathLike):
    """Load a results dataset fully into memory, with a clear error for a missing or foreign file."""
    import xarray as xr

    path = regular_file(path, "dataset file", missing="no such dataset")
    _refuse_packing_file(path)
    try:
        with warnings.catch_warnings():  # the backends' warnings about foreign files come before our one line
            warnings.simplefilter("ignore")
            ds = xr.load_dataset(path, engine="h5netcdf")
    except Exception as exc:  # noqa: BLE001 - netCDF backends raise many types
        raise PackingFileError(f"{path}: not a readable netCDF dataset ({str(exc).splitlines()[0]})") from None
    if "config" not in ds.attrs or "packing" not in ds.dims:
        raise PackingFileError(f"{path}: not a spherejam results dataset (no 'config' attribute or 'packing' dim)")
    missing = [v for v in ("protocol", "sigma", "rate") if v not in ds.variables]
    if missing:
        raise PackingFileError(f"{path}: not a spherejam results dataset (no variable {', '.join(missing)})")
    try:
        config = json.loads(ds.attrs["config"])
    except (TypeError, ValueError):
        config = None
    if not isinstance(config, dict):
        raise PackingFileError(f"{path}: its 'config' attribute is not a JSON mapping")
    renamed = {old: new for old, new in RENAMED.items() if old in ds.variables and new not in ds.variables}
    ds = ds.rename(renamed)
    for new in renamed.values():  # the old description is what made it look like a verdict
        ds[new].attrs["long_name"] = _structure_variables()[new][0]
    single = ds.attrs.get("n", config.get("n"))
    if "n" not in ds.variables and isinstance(single, (int, np.integer)):  # written before N was an axis: one N
        ds = ds.assign_coords(n=("packing", np.full(ds.sizes["packing"], int(single), dtype=np.int64)))
        ds["n"].attrs.update(long_name=COORDS["n"][0], units=COORDS["n"][1])
    return pooled_by_distribution(with_distributions(ds))


def dataset_config(ds) -> dict[str, Any]:
    return json.loads(ds.attrs["config"])
