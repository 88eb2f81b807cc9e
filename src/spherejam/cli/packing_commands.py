"""``spherejam seed | info | check | export``: make, inspect, validate and convert packing files."""

from __future__ import annotations

import json
from pathlib import Path

from ..output_paths import check_outputs, output_file
from ..validation import FIELDS, OVERLAP_TOLERANCE
from . import EXIT_FAILED, seed_int


def register(sub) -> None:
    p = sub.add_parser("seed", help="make a Poisson packing (uniform centres, log-normal diameters)")
    p.add_argument("--n", type=FIELDS["n"].arg, required=True, help="number of spheres N (2 ... 10^7)")
    p.add_argument("--sigma", type=FIELDS["sigmas[]"].arg, default=0.0,
                   help="relative std of the diameters, 0 ... 1 (default 0)")
    p.add_argument("--seed", type=seed_int, default=0, help="random seed (default 0)")
    p.add_argument("--dim", type=int, default=3, choices=(2, 3, 4, 5), help="dimension d (default 3)")
    p.add_argument(
        "--phi-nominal", type=FIELDS["phi_nominal"].arg, default=0.6,
        help="packing fraction of the mean-1 nominal diameters; fixes the box side (default 0.6)",
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

    p = sub.add_parser("export", help="convert a packing file (extended XYZ for OVITO)")
    p.add_argument("path", type=Path)
    p.add_argument("--format", choices=("xyz",), default="xyz")
    p.add_argument("-o", "--output", type=output_file, help="output path (default: input with the format's suffix)")
    p.set_defaults(func=_export)


def _seed(args) -> int:
    from ..packing_io import write_packing
    from ..seeding import poisson_packing

    check_outputs({"-o/--output": args.output})
    packing = poisson_packing(args.n, args.sigma, args.seed, phi_nominal=args.phi_nominal, dim=args.dim)
    write_packing(args.output, packing)
    print(f"{args.output}: N={packing.n} d={packing.dim} sigma={args.sigma:g} seed={args.seed} phi={packing.phi:.3e}")
    return 0


def summary(path: Path) -> dict:
    from ..packing_io import read_packing

    packing = read_packing(path, tolerance=None)
    i, j, h = packing.closest_pair()
    m = packing.metadata
    return {
        "path": str(path),
        "n": packing.n,
        "dim": packing.dim,
        "box": packing.box,
        "phi": packing.phi,
        "polydispersity": packing.polydispersity,
        "size_ratio": float(packing.diameters.max() / packing.diameters.min()),
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
    print(f"  N = {s['n']}, d = {s['dim']}, L = {s['box']:.10g}")
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
    from ..packing_io import read_packing

    packing = read_packing(args.path, tolerance=None)
    report = packing.check(args.tolerance)
    print(f"{args.path}: {report}")
    return 0 if report.ok else EXIT_FAILED


def _export(args) -> int:
    from ..packing_io import export_xyz, read_packing

    out = args.output or args.path.with_suffix(".xyz")
    check_outputs({"-o/--output" if args.output else "the default output": out}, inputs={"path": args.path})
    packing = read_packing(args.path)
    export_xyz(packing, out)
    print(f"{out}: extended XYZ, {packing.n} spheres")
    return 0
