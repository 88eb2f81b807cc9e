"""``spherejam view PACKING -o packing.html``: one self-contained interactive 3D page of a packing."""

from __future__ import annotations

from pathlib import Path

from ..core.output_paths import check_outputs, output_file


def register(sub) -> None:
    p = sub.add_parser("view", help="write one self-contained HTML page to turn a packing round in a browser",
                       description="Writes an HTML file with the packing and a small WebGL viewer inlined (no "
                       "network needed): rotate by dragging, zoom with the wheel, colour by diameter, coordination "
                       "or rattler, the periodic box drawn, a slab along x, y or z to look inside.")
    p.add_argument("path", type=Path, help="packing file (.h5)")
    p.add_argument("-o", "--output", type=output_file, required=True, help="the HTML file to write")
    p.add_argument("--title", help="title of the page (default: the file name, N and phi)")
    p.set_defaults(func=_view)


def _view(args) -> int:
    from ..core.packing_io import read_packing
    from ..workflow.packing_view import write_view

    check_outputs({"-o/--output": args.output}, inputs={"path": args.path})
    packing = read_packing(args.path)
    title = args.title or f"{args.path.name}: N = {packing.n}, phi = {packing.phi:.4f}"
    size = write_view(packing, args.output, title)
    print(f"{args.output}: {size / 1e3:.0f} kB, N = {packing.n}")
    return 0
