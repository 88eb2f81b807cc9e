"""``spherejam dataset | tables | figure | browse``: the results database and what is derived from it."""

from __future__ import annotations

from pathlib import Path

from ..core.errors import InputError, PackingFileError
from ..core.output_paths import check_output_dir, check_outputs, figure_stem, output_file
from . import finite_float


def register(sub) -> None:
    p = sub.add_parser("manifest", help="record a validated experiment config (JSON) for the dataset builder")
    p.add_argument("--config-json", required=True, help="the workflow's config as a JSON string")
    p.add_argument("-o", "--output", type=output_file, required=True)
    p.set_defaults(func=_manifest)

    p = sub.add_parser("dataset", help="assemble results/dataset.nc from an experiment manifest")
    p.add_argument("manifest", type=Path, help="experiment.json written by the workflow")
    p.add_argument("-o", "--output", type=output_file, required=True, help="output netCDF file")
    p.add_argument("--n", type=int, nargs="+", metavar="N",
                   help="only the packings at these N: the dataset of a part of the run, to merge later")
    p.add_argument("--distribution", nargs="+", metavar="KEY",
                   help="only the packings of these size distributions (keys as sigma0.3 or a name): a part")
    p.set_defaults(func=_dataset)

    p = sub.add_parser("merge", help="join the datasets of a run's parts (spherejam dataset --n/--distribution) "
                       "into the dataset of the whole run")
    p.add_argument("parts", type=Path, nargs="+", help="the parts' dataset.nc files (together, every packing once)")
    p.add_argument("-o", "--output", type=output_file, required=True, help="output netCDF file")
    p.set_defaults(func=_merge)

    p = sub.add_parser("tables", help="write Tables 2-4 (CSV, Markdown, LaTeX) from a dataset")
    p.add_argument("dataset", type=Path)
    p.add_argument("--outdir", type=str, required=True, help="folder of the table files (made if missing)")
    p.set_defaults(func=_tables)

    p = sub.add_parser("figure", help="draw one figure (PNG and PDF) from a dataset")
    p.add_argument("name", help="fig2, fig3, fig4, fig5, fig6, fig7, structure, forces or scaling")
    p.add_argument("dataset", type=Path)
    p.add_argument("-o", "--output", type=str, required=True,
                   help="output stem (writes STEM.png and STEM.pdf); a folder (DIR/) writes DIR/NAME.png and .pdf")
    p.set_defaults(func=_figure)

    p = sub.add_parser("archive", help="pack a finished run (dataset, tables, figures, chosen packings) into a "
                                       "folder with a README, to track or publish")
    p.add_argument("results", type=Path, help="the run's results folder (holding dataset.nc)")
    p.add_argument("-o", "--output", type=str, required=True,
                   help="the archive folder: a new one, or an archive this command wrote (replaced as a whole)")
    p.add_argument("--packings", action="append", default=[], metavar="PATTERN",
                   help="also the files of the packings whose key matches this glob, e.g. 'n1000/*' (repeatable)")
    p.add_argument("--stage", action="append", choices=("poisson", "initial", "jammed", "calippso_packing"),
                   help="which file of each chosen packing (repeatable; default jammed)")
    p.add_argument("--no-history", action="store_true",
                   help="copy the packing files without their run histories (most of a jammed file's size)")
    p.add_argument("--max-mb", type=finite_float, default=20.0, help="refuse a larger archive (default 20 MB)")
    p.set_defaults(func=_archive)

    p = sub.add_parser("browse", help="summarise, filter and export an archived results dataset")
    p.add_argument("dataset", type=Path)
    p.add_argument("--protocol", choices=("ls", "fb"), help="only this protocol")
    p.add_argument("--n", type=int, action="append", metavar="N",
                   help="only packings of N spheres (a ladder of N has several; repeatable)")
    p.add_argument("--sigma", type=finite_float, action="append", help="only this sigma (repeatable)")
    p.add_argument("--distribution", action="append", metavar="NAME",
                   help="only this size distribution, by key (sigma0.1 or its config name; repeatable)")
    p.add_argument("--family", action="append", help="only distributions of this family (lognormal, gaussian, ...)")
    p.add_argument("--delta-min", type=finite_float, help="only distributions with relative std delta >= this")
    p.add_argument("--delta-max", type=finite_float, help="only distributions with relative std delta <= this")
    p.add_argument("--rate-min", type=finite_float, help="only gamma >= this")
    p.add_argument("--rate-max", type=finite_float, help="only gamma <= this")
    p.add_argument("--columns", help="comma-separated variables to show (default: a standard set)")
    p.add_argument("--grid", action="store_true", help="show the validation-grid runs instead")
    p.add_argument("--csv", type=output_file, help="export the selection as CSV")
    p.add_argument("--figure", help="redraw this figure from the (unfiltered) dataset")
    p.add_argument("-o", "--output", type=str, help="figure (or --plot) output stem or folder (default: ./<figure>)")
    p.add_argument("--tables", action="store_true", help="print Tables 2-4")
    p.add_argument("--packing", metavar="KEY",
                   help="everything the dataset holds for one packing (key as ls/sigma0.1/rate0.5/r0) and its files")
    p.add_argument("--plot", action="store_true",
                   help="with --packing: draw its MLS history (p and phi against collisions) to -o STEM.png/.pdf")
    p.set_defaults(func=_browse)


def _manifest(args) -> int:
    import json

    from ..workflow.manifest import write_manifest

    check_outputs({"-o/--output": args.output})
    try:
        config = json.loads(args.config_json)
    except json.JSONDecodeError as exc:
        raise InputError(f"--config-json: not valid JSON ({exc})") from None
    if not isinstance(config, dict):
        raise InputError(f"--config-json: a JSON {type(config).__name__}, expected an object of config keys")
    write_manifest(config, args.output)
    print(f"{args.output}: experiment with {len(config.get('sigmas', []))} sigmas, N = {config.get('n')}")
    return 0


def _dataset(args) -> int:
    from ..workflow.dataset import build_dataset, write_dataset

    check_outputs({"-o/--output": args.output}, inputs={"manifest": args.manifest})
    ds = build_dataset(args.manifest, args.n, args.distribution)
    write_dataset(ds, args.output)
    _summary(args.output, ds)
    return 0


def _summary(path: Path, ds) -> None:
    print(f"{path}: {ds.sizes.get('packing', 0)} packings, {ds.sizes.get('grid_run', 0)} grid runs, "
          f"{len(ds.data_vars)} variables")


def _merge(args) -> int:
    from ..workflow.dataset import merge_datasets, open_dataset, write_dataset

    check_outputs({"-o/--output": args.output}, inputs={f"part {i + 1}": p for i, p in enumerate(args.parts)})
    ds = merge_datasets([open_dataset(p) for p in args.parts], [str(p) for p in args.parts])
    write_dataset(ds, args.output)
    _summary(args.output, ds)
    return 0


def _archive(args) -> int:
    import shlex
    import sys

    from ..workflow.archive import write_archive

    command = "spherejam " + " ".join(shlex.quote(a) for a in sys.argv[1:]) if sys.argv[1:2] == ["archive"] else (
        "spherejam archive")
    plan = write_archive(args.results, args.output, args.packings, tuple(args.stage or ("jammed",)), args.max_mb,
                         command, args.no_history)
    size = sum(p.stat().st_size for p in Path(args.output).rglob("*") if p.is_file())
    print(f"{args.output}: {len(plan.files) + 2} files, {size / 1e6:.1f} MB")
    return 0


def _tables(args) -> int:
    from ..workflow.dataset import open_dataset
    from ..workflow.tables import TABLE_FILES, write_tables

    outdir = check_output_dir("--outdir", args.outdir, inputs={"dataset": args.dataset}, files=TABLE_FILES)
    ds = open_dataset(args.dataset)
    try:
        paths = write_tables(ds, outdir)
    except KeyError as exc:
        raise PackingFileError(f"{args.dataset}: no variable {exc} (not a complete spherejam dataset)") from None
    for path in paths:
        print(path)
    return 0


def _figure(args) -> int:
    from ..workflow.dataset import open_dataset
    from ..workflow.figures import FIGURES, draw, save_figure

    if args.name not in FIGURES:
        raise InputError(f"figure={args.name!r}: must be one of {', '.join(FIGURES)}")
    stem, outputs = _figure_outputs(args.output, args.name)
    check_outputs(outputs, inputs={"dataset": args.dataset})
    ds = open_dataset(args.dataset)
    for path in save_figure(_draw(draw, args.name, ds, args.dataset), stem):
        print(path)
    return 0


def _figure_outputs(output: str, name: str) -> tuple[Path, dict[str, Path]]:
    """The figure's stem (a folder gets NAME inside it) and its two files, by argument, for check_outputs."""
    stem = figure_stem(output, name)
    return stem, {f"-o/--output ({ext})": stem.with_name(f"{stem.name}.{ext}") for ext in ("png", "pdf")}


def _draw(draw, name: str, ds, dataset: Path):
    try:
        return draw(name, ds)
    except KeyError as exc:
        raise PackingFileError(f"{dataset}: no variable {exc} (not a complete spherejam dataset)") from None


DEFAULT_COLUMNS = ("phi", "phi_J", "pressure_J", "mls_collisions", "mls_wall_time", "z_nonrattler",
                   "calippso_delta_phi", "calippso_is_isostatic")
#: Which of the dataset's two isostaticity flags is the verdict (docs/algorithms.md §6.3), printed by ``browse``.
CERTIFICATE = ("jamming is certified by calippso_is_isostatic (CALiPPSO's LP contacts, balanced forces); "
               "isostatic_at_tolerance only counts gaps below one tolerance")
GRID_COLUMNS = ("grid_phi", "grid_phi_J", "grid_collisions", "grid_stages", "grid_wall_time")


def _browse(args) -> int:
    import json

    import numpy as np
    import pandas as pd

    from ..workflow.dataset import open_dataset

    if args.plot and args.packing is None:
        raise InputError("--plot: needs --packing KEY (the packing whose MLS history to draw)")
    if args.figure is not None and args.packing is not None:
        raise InputError("--figure: not with --packing (redraw a figure, or look at one packing)")
    outputs, stem = {"--csv": args.csv}, None
    if args.figure is not None:  # also --figure "": named as what it is, not as a stray -o
        from ..workflow.figures import FIGURES

        if args.figure not in FIGURES:
            raise InputError(f"--figure={args.figure!r}: must be one of {', '.join(FIGURES)}")
        stem, figure_files = _figure_outputs(args.figure if args.output is None else args.output, args.figure)
        outputs.update(figure_files)
    elif args.plot and args.packing is not None:
        default = f"mls_{args.packing.replace('/', '_')}"
        stem, figure_files = _figure_outputs(default if args.output is None else args.output, default)
        outputs.update(figure_files)
    elif args.output is not None:
        raise InputError("-o/--output: only with --figure or --plot")
    check_outputs(outputs, inputs={"dataset": args.dataset})
    ds = open_dataset(args.dataset)
    if args.packing is not None or args.plot:
        return _browse_packing(args, ds, stem)
    cfg = json.loads(ds.attrs["config"])
    print(f"{args.dataset}: {ds.attrs.get('title', '')}")
    named = cfg.get("distributions") or {}
    print(f"  N = {cfg.get('n')}, sigmas = {cfg.get('sigmas')}"
          + (f", distributions = {named}" if named else "") + f", {ds.sizes['packing']} packings, "
          f"{ds.sizes.get('grid_run', 0)} validation-grid runs")
    print(f"  config hash {ds.attrs.get('config_hash')}, git {ds.attrs.get('git_commit')},"
          f" created {ds.attrs.get('created')}")
    print(f"  {CERTIFICATE}")
    dim = "grid_run" if args.grid else "packing"
    if args.grid and "grid_run" not in ds.dims:
        raise InputError("--grid: this dataset has no validation-grid runs")
    sub = ds[[v for v in ds.data_vars if dim in ds[v].dims]]
    sig, rate = ("grid_sigma", "grid_rate") if args.grid else ("sigma", "rate")
    mask = np.ones(ds.sizes[dim], dtype=bool)
    if args.n:
        size = "grid_n" if args.grid else "n"
        known = sorted({int(v) for v in ds[size].values}) if size in ds.variables else [int(ds.attrs["n"])]
        unknown = [n for n in args.n if n not in known]
        if unknown:
            raise InputError(f"--n={unknown[0]}: not in this dataset (have N = {', '.join(map(str, known))})")
        if size in ds.variables:
            mask &= np.isin(ds[size].values, args.n)
    if args.protocol and not args.grid:
        mask &= ds.protocol.values == args.protocol
    if args.sigma:
        mask &= np.isin(np.round(ds[sig].values, 12), np.round(args.sigma, 12))
    selectors = [(args.distribution, "distribution"), (args.family, "psd_family")]
    bounds = [(args.delta_min, np.greater_equal), (args.delta_max, np.less_equal)]
    if any(v for v, _ in selectors) or any(v is not None for v, _ in bounds):
        if args.grid:
            raise InputError("--distribution/--family/--delta-*: select packings, not validation-grid runs")
        for wanted, coord in selectors:
            if wanted:
                known = sorted(set(ds[coord].values.tolist()))
                unknown = [w for w in wanted if w not in known]
                if unknown:
                    raise InputError(f"--{coord.removeprefix('psd_')}={unknown[0]!r}: not in this dataset "
                                     f"(have {', '.join(known)})")
                mask &= np.isin(ds[coord].values, wanted)
        for value, keep in bounds:
            if value is not None:
                mask &= keep(ds["psd_delta"].values, value - 1e-12 if keep is np.greater_equal else value + 1e-12)
    if args.rate_min is not None:
        mask &= ds[rate].values >= args.rate_min
    if args.rate_max is not None:
        mask &= ds[rate].values <= args.rate_max
    sub = sub.isel({dim: np.flatnonzero(mask)})
    df = sub.to_dataframe().reset_index(drop=True)
    coords = [c for c in sub.coords if c not in ("key",) and not c.startswith("psd")]  # the key names the psd
    if args.columns:
        wanted = [c.strip() for c in args.columns.split(",") if c.strip()]
        missing = [c for c in wanted if c not in df.columns]
        if missing:
            raise InputError(f"--columns: unknown variable(s) {', '.join(missing)}; have {', '.join(sub.data_vars)}")
    else:
        wanted = [c for c in (GRID_COLUMNS if args.grid else DEFAULT_COLUMNS) if c in df.columns]
    shown = df[[c for c in coords if c in df.columns] + wanted]
    with pd.option_context("display.max_rows", 60, "display.width", 160, "display.float_format", "{:.6g}".format):
        print(shown.to_string(index=False) if len(shown) else "  (no runs match the filter)")
    if args.csv:
        from ..core.atomic import atomic_output

        with atomic_output(args.csv, ".csv") as tmp:
            df.to_csv(tmp, index=False)
        print(f"wrote {len(df)} rows to {args.csv}")
    if args.tables:
        from ..workflow.tables import compute_tables, formatted

        for name, t in compute_tables(ds).items():
            print(f"\n{name}\n{formatted(name, t).to_string()}")
    if args.figure is not None:
        from ..workflow.figures import draw, save_figure

        for path in save_figure(_draw(draw, args.figure, ds, args.dataset), stem):
            print(path)
    return 0


def _browse_packing(args, ds, stem: Path | None) -> int:
    from ..workflow.packing_record import describe, locate, mls_history_figure

    for line in describe(args.dataset, ds, args.packing):
        print(line)
    if args.plot:
        from ..workflow.figures import save_figure

        found = locate(args.dataset, ds, args.packing)
        if "jammed.h5" not in found.files:
            where = ", ".join(str(s) for s in found.searched) if found.results is None else str(
                found.results / "packings" / args.packing)
            raise InputError(f"--plot: the MLS output jammed.h5 of {args.packing} is not there (looked in {where}); "
                             "copy the packing files next to the dataset")
        fig = mls_history_figure(found.files["jammed.h5"], title=f"MLS history of {args.packing}")
        for path in save_figure(fig, stem):
            print(path)
    return 0
