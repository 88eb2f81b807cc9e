"""``spherejam analyze``: contacts, rattlers, isostaticity, Q6, Voronoi and pore-size entropy of a packing file; in a
container also the porosity profile, the core phi and the structure by layer at the wall (docs/containers_structure.md).
"""

from __future__ import annotations

import json
import math
from pathlib import Path

from ..core.output_paths import check_outputs, output_file
from ..core.validation import PORE_SAMPLES
from . import finite_float, seed_int


def register(sub) -> None:
    p = sub.add_parser(
        "analyze", help="structure of a packing: contacts, rattlers, isostaticity, Q6, Voronoi, pore-size entropy"
    )
    p.add_argument("path", type=Path, help="packing file (.h5, actual diameters)")
    p.add_argument("--json", action="store_true", help="print machine-readable JSON")
    p.add_argument("-o", "--output", type=output_file, help="also write the JSON record to this file (atomically)")
    p.add_argument(
        "--pressure", type=finite_float,
        help="reduced pressure p for the contact-tolerance rule (default: the file's reduced_pressure)",
    )
    p.add_argument(
        "--contact-tolerance", type=finite_float,
        help="fixed relative gap tolerance for contacts (default: the plateau rule, see spherejam.analysis.contacts)",
    )
    p.add_argument("--seed", type=seed_int, default=0, help="seed of the pore-size sampling (default 0)")
    p.add_argument(
        "--pore-samples", type=PORE_SAMPLES.arg,
        help="number of random points for the pore-size entropy, 1 ... 1e9 (default: the convergence rule, >= 1e7)",
    )
    p.add_argument("--scan", action="store_true", help="also print Z over the tolerance grid (the plateau)")
    p.set_defaults(func=_analyze)


def _finite_or_none(value: float):
    return value if math.isfinite(value) else None


def _analyze(args) -> int:
    from ..analysis.contacts import tolerance_scan
    from ..analysis.structure import VARIABLES, analyze, unavailable
    from ..core.atomic import atomic_output
    from ..core.packing_io import read_packing

    check_outputs({"-o/--output": args.output}, inputs={"path": args.path})
    packing = read_packing(args.path)
    container: dict = {}
    result = analyze(
        packing, pressure=args.pressure, contact_tolerance=args.contact_tolerance, seed=args.seed,
        pore_samples=args.pore_samples, container=container,
    )
    skipped = unavailable(packing)
    # top level: exactly the scalars of structure.VARIABLES (the workflow reads them into the dataset)
    record = {k: _finite_or_none(v) for k, v in result.items()}
    record["packing"] = {"path": str(args.path), "n": packing.n, "dim": packing.dim, "phi": packing.phi}
    if skipped:
        record["not_available"] = skipped
    if container:
        record["container"] = container
    if args.scan:
        scan = tolerance_scan(packing, pressure=args.pressure)
        record["tolerance_scan"] = {k: [_finite_or_none(float(x)) for x in v] for k, v in scan.items()}
    text = json.dumps(record, indent=2)
    if args.output:
        with atomic_output(args.output, ".json") as tmp:
            tmp.write_text(text + "\n")
    if args.json:
        print(text)
        return 0
    print(f"{args.path}: N = {packing.n}, d = {packing.dim}, phi = {packing.phi:.10f}")
    for name, value in result.items():
        print(f"  {name:24s} {value:<14.8g} {VARIABLES[name][0]}")
    for part, reason in skipped.items():
        print(f"  {part:24s} {reason}")
    if container:
        core, achieved = container["core"], ", ".join(f"{k} = {v:.4g}" for k, v in container["achieved"].items())
        print(f"  container {container['spec']}: {achieved} mean diameters; {container['wall_contacts']} wall "
              f"contacts; isostatic count {container['isostatic_contacts']}")
        phi_core = "not estimable" if core["phi"] is None else f"{core['phi']:.6f}"
        print(f"  core phi ({core['distance']:g} d from every wall, {core['volume_fraction']:.3f} of the volume): "
              f"{phi_core}")
        layers = container["layers"]
        print("  layer  n      contacts  wall  rattlers  q6_local  crystalline")
        for m, n in enumerate(layers["n"]):
            row = [layers[k][m] for k in ("contacts_mean", "wall_contacts_mean", "rattler_fraction", "q6_local",
                                          "crystalline_fraction")]
            print(f"  {m:5d}  {n:5d}  " + "  ".join("     n/a" if x is None else f"{x:8.4f}" for x in row))
    if args.scan:
        s = record["tolerance_scan"]
        print("  tolerance      Z(all)    Z(non-rattlers)  rattlers  K'-K0")
        for row in zip(s["contact_tolerance"], s["z_mean"], s["z_nonrattler"], s["rattler_fraction"],
                       s["isostatic_excess"]):
            g, z, znr, rf, ex = (math.nan if x is None else x for x in row)
            print(f"  {g:9.3e}  {z:8.4f}  {znr:15.4f}  {rf:8.4f}  {ex:+6.0f}")
    return 0
