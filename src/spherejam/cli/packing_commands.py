"""``spherejam seed | info | check | export | import``: make, inspect, validate and convert packing files."""

from __future__ import annotations

import json
from pathlib import Path

from ..core.output_paths import check_output_dir, check_outputs, output_file
from ..core.validation import BOX_SIDE, FIELDS, OVERLAP_TOLERANCE
from . import EXIT_FAILED, seed_int


def register(sub) -> None:
    p = sub.add_parser("seed", help="make a Poisson packing (uniform centres, diameters of any size distribution)",
                       description="Diameters from --psd SPEC (docs/psd.md): lognormal:sigma=S, gaussian:delta=D, "
                       "uniform:ratio=R, bidisperse:ratio=R,small=X,by=number|volume, powerlaw:exponent=A,ratio=R, "
                       "table:FILE.csv, list:FILE. --sigma S is short for --psd lognormal:sigma=S.")
    p.add_argument("--n", type=FIELDS["n"].arg, default=None,
                   help="number of spheres N (2 ... 10^7); with a list: distribution, N is the list's length")
    psd = p.add_mutually_exclusive_group()
    psd.add_argument("--psd", metavar="SPEC", default=None, help="the size distribution (default lognormal:sigma=0)")
    psd.add_argument("--sigma", type=FIELDS["sigmas[]"].arg, default=None,
                     help="relative std of log-normal diameters, 0 ... 1 (default 0)")
    p.add_argument("--seed", type=seed_int, default=0, help="random seed (default 0)")
    p.add_argument("--dim", type=int, default=3, choices=(2, 3, 4, 5), help="dimension d (default 3)")
    p.add_argument("--container", metavar="SPEC", default=None,
                   help="the container (docs/containers.md): periodic (default), periodic:x=L,y=L,z=L, slab:height=H, "
                        "box:x=L,y=L,z=L, cylinder:diameter=D[,length=L][,capped=yes], sphere:diameter=D; lengths "
                        "in mean diameters of the final packing; a spec giving every length fixes N")
    p.add_argument(
        "--phi-nominal", type=FIELDS["phi_nominal"].arg, default=None,
        help="packing fraction of the mean-1 nominal diameters; fixes the box side (default 0.6); with --container, "
             "the final packing fraction the container is sized for (default 0.62)",
    )
    p.add_argument("-o", "--output", type=output_file, required=True, help="output packing file (.h5)")
    p.set_defaults(func=_seed)

    p = sub.add_parser("info", help="summarise a packing file")
    p.add_argument("path", type=Path)
    p.add_argument("--json", action="store_true", help="print machine-readable JSON")
    p.set_defaults(func=_info)

    p = sub.add_parser("check", help="validate a packing file: format, box, and overlaps")
    p.add_argument("path", type=Path)
    p.add_argument("--tolerance", type=OVERLAP_TOLERANCE.arg, default=1e-10,
                   help="relative overlap tolerance, 0 ... 1 (1e-10)")
    p.set_defaults(func=_check)

    from ..formats import FORMATS, READABLE

    formats = "; ".join(f"{name}: {f.description}" for name, f in FORMATS.items())
    p = sub.add_parser("export", help="convert a packing file to another code's format (docs/formats.md)",
                       description=f"Formats: {formats}.")
    p.add_argument("path", type=Path)
    p.add_argument("--format", choices=tuple(FORMATS), default="xyz", help="output format (default xyz)")
    p.add_argument("-o", "--output", type=str,  # str: a trailing "/" must reach the output check
                   help="output path (default: input with the format's suffix; packing-generation: a folder)")
    p.set_defaults(func=_export)

    p = sub.add_parser("import", help="read another code's packing, validate it, write a spherejam packing file",
                       description=f"Formats: {formats}.")
    p.add_argument("path", type=Path, help="input file (packing-generation: its folder or packing.xyzd)")
    p.add_argument("--format", choices=READABLE, default=None, help="input format (default: from the suffix)")
    p.add_argument("-o", "--output", type=output_file, required=True, help="output packing file (.h5)")
    p.add_argument("--tolerance", type=OVERLAP_TOLERANCE.arg, default=1e-10,
                   help="relative overlap tolerance of the file, 0 ... 1 (1e-10); overlaps it lets through (float32 "
                        "files such as HOOMD's GSD: ~1e-6) are removed by shrinking every diameter by one factor")
    p.add_argument("--box", type=BOX_SIDE.arg, default=None,
                   help="calippso-jl only: side L of the periodic cube, which the file does not hold (default 1)")
    p.add_argument("--frame", type=int, default=None, help="gsd only: frame to read (default -1, the last)")
    p.set_defaults(func=_import)


def _seed(args) -> int:
    from ..core.errors import InputError
    from ..core.packing_io import write_packing
    from ..core.seeding import poisson_packing
    from ..core.size_distribution import lognormal_spec, parse

    from ..core.container import number_for
    from ..core.container import parse as parse_container

    dist = parse(args.psd if args.psd is not None else lognormal_spec(args.sigma or 0.0), "--psd")
    container = parse_container(args.container, "--container") if args.container is not None else None
    n = args.n
    if dist.fixed_n is not None:
        if n is not None and n != dist.fixed_n:
            raise InputError(f"--n={n}: {dist.spec} holds {dist.fixed_n} diameters (leave out --n)")
        n = dist.fixed_n
    elif n is None and (container is None or number_for(container, 1.0) is None):
        raise InputError("--n: required (only a list: distribution, or a container that gives every length, fixes N)")
    check_outputs({"-o/--output": args.output}, inputs=_psd_inputs(dist))
    packing = poisson_packing(n, seed=args.seed, phi_nominal=args.phi_nominal, dim=args.dim, psd=dist,
                              container=container)
    write_packing(args.output, packing)
    sample = packing.metadata["size_distribution"]["sample"]
    size = (f"sigma={dist.sigma:g}" if dist.family == "lognormal"
            else f"psd={dist.spec} delta={sample['delta']:.4f} d_max/d_min={sample['size_ratio']:.3g}")
    where = "" if packing.container.is_periodic_cube else f" container={packing.container.spec}"
    print(f"{args.output}: N={packing.n} d={packing.dim} {size}{where} seed={args.seed} phi={packing.phi:.3e}")
    return 0


def _psd_inputs(dist) -> dict:
    """The file a table: or list: distribution reads (an output must not overwrite it)."""
    source = dist.provenance().get("file")
    return {"--psd": Path(source)} if source else {}


def summary(path: Path) -> dict:
    from ..core.packing_io import read_packing

    packing = read_packing(path, tolerance=None)
    i, j, h = packing.closest_pair()
    m = packing.metadata
    return {
        "path": str(path),
        "n": packing.n,
        "dim": packing.dim,
        "box": packing.box,
        "container": packing.container.to_dict(),
        "phi": packing.phi,
        "polydispersity": packing.polydispersity,
        "size_ratio": float(packing.diameters.max() / packing.diameters.min()),
        "container_in_diameters": packing.container.in_diameters(packing.mean_diameter),
        "closest_pair": [i, j],
        "min_gap": h - 1.0,
        "algorithm": m.get("algorithm"),
        "seed": m.get("seed"),
        "reduced_pressure": m.get("reduced_pressure"),
        "parameters": m.get("parameters", {}),
        "counters": m.get("counters", {}),
        "provenance": m.get("provenance", {}),
    }


def _info(args) -> int:
    s = summary(args.path)
    if args.json:
        print(json.dumps(s, indent=2, default=str))
        return 0
    print(f"{s['path']}")
    c = s["container"]
    if c["spec"] == "periodic" and len(set(c["lengths"])) == 1:
        print(f"  N = {s['n']}, d = {s['dim']}, L = {s['box']:.10g}")
    else:
        size = ", ".join(f"{k} = {v:.6g}" for k, v in s["container_in_diameters"].items())
        print(f"  N = {s['n']}, d = {s['dim']}, container {c['spec']} (asked); achieved in mean diameters: {size}")
    print(f"  phi = {s['phi']:.10f}   polydispersity sigma = {s['polydispersity']:.4f}"
          f"   size ratio = {s['size_ratio']:.3f}")
    print(f"  closest pair {s['closest_pair']}: normalised gap {s['min_gap']:.3e}")
    print(f"  algorithm = {s['algorithm']}, seed = {s['seed']}, reduced pressure = {s['reduced_pressure']}")
    if s["parameters"]:
        print(f"  parameters: {json.dumps(s['parameters'], sort_keys=True)}")
    if s["counters"]:
        print(f"  counters: {json.dumps(s['counters'], sort_keys=True)}")
    prov = s["provenance"]
    if prov:
        print(f"  made by spherejam {prov.get('spherejam_version')} (git {prov.get('git_commit')})"
              f" at {prov.get('created')}")
    return 0


def _check(args) -> int:
    from ..core.packing_io import read_packing

    packing = read_packing(args.path, tolerance=None)
    report = packing.check(args.tolerance)
    print(f"{args.path}: {report}")
    return 0 if report.ok else EXIT_FAILED


def _export(args) -> int:
    from ..core.packing_io import read_packing
    from ..formats import FORMATS, default_output, write
    from ..formats.packing_generation import CONF, NFO, XYZD

    out = args.output if args.output is not None else default_output(args.path, args.format)
    name = "-o/--output" if args.output is not None else "the default output"
    if args.format == "packing-generation":  # a folder of three files
        check_output_dir(name, out, inputs={"path": args.path}, files=(XYZD, NFO, CONF))
    else:
        check_outputs({name: out}, inputs={"path": args.path})
    packing = read_packing(args.path)
    written = write(packing, Path(out), args.format)
    note = f", box scaled from L = {packing.box!r} to 1" if args.format == "calippso-jl" else ""
    print(f"{', '.join(map(str, written))}: {FORMATS[args.format].description}, {packing.n} spheres{note}")
    return 0


def _import(args) -> int:
    from ..core.errors import InputError
    from ..core.packing_io import write_packing
    from ..formats import guess_format, read
    from ..formats.packing_generation import CONF, NFO, XYZD, file_set

    fmt = args.format or guess_format(args.path)
    inputs = {"path": args.path}
    if fmt == "packing-generation":  # the folder's three files are all inputs
        inputs.update(zip((XYZD, NFO, CONF), file_set(args.path)))
    check_outputs({"-o/--output": args.output}, inputs=inputs)
    options = {}
    if args.box is not None:
        if fmt != "calippso-jl":
            raise InputError(f"--box={args.box!r}: only the calippso-jl format needs a box side")
        options["box"] = args.box
    if args.frame is not None:
        if fmt != "gsd":
            raise InputError(f"--frame={args.frame!r}: only the gsd format has frames")
        options["frame"] = args.frame
    packing = read(args.path, fmt, tolerance=args.tolerance, **options)
    write_packing(args.output, packing)  # never with overlaps: formats.read removed what --tolerance let through
    note = packing.metadata["source"].get("note")
    where = f"L={packing.box:.10g}" if packing.container.is_periodic_cube else f"container {packing.container.spec}"
    print(f"{args.output}: {packing.n} spheres from {fmt} {args.path}, d={packing.dim}, {where}, "
          f"phi={packing.phi:.10f}" + (f" ({note})" if note else ""))
    return 0
