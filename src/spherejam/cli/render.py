"""``spherejam render``: a picture of a packing (spheres coloured by diameter in the periodic cell), via OVITO."""

from __future__ import annotations

from pathlib import Path

from ..core.output_paths import check_outputs, output_file
from ..core.validation import IMAGE_SIZE
from . import finite_float


def register(sub) -> None:
    p = sub.add_parser("render", help="ray-trace a 3D packing into PNG/PDF with OVITO (needs spherejam[render])")
    p.add_argument("path", type=Path, help="packing file (.h5)")
    p.add_argument("-o", "--output", type=output_file, action="append", required=True,
                   help="image file, .png or .pdf (repeat for both; the scene is rendered once)")
    p.add_argument("--size", type=IMAGE_SIZE.arg, default=800,
                   help="rendered image side in pixels, 16 ... 8192 (800)")
    p.add_argument("--sigma", type=finite_float,
                   help="nominal sigma to print (default: the sample's std(D)/mean)")
    p.add_argument("--title", help="title instead of the default (N, phi, sigma)")
    p.set_defaults(func=_render)


def _render(args) -> int:
    from ..core.packing_io import read_packing
    from ..workflow.render import write_images

    check_outputs({f"-o/--output #{k + 1}": out for k, out in enumerate(args.output)}, inputs={"path": args.path})
    packing = read_packing(args.path)
    for path in write_images(packing, args.output, (args.size, args.size), args.sigma, args.title):
        print(path)
    return 0
