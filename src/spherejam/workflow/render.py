"""A packing drawn as spheres in its periodic cell, ray-traced with OVITO (the paper's Fig. 1), or in its container
(docs/containers.md): a box or a slab with its frame, a cylinder from the side (the frame not drawn, so the column
shows by its spheres), a sphere as a ball.

OVITO's Python module (``pip install 'spherejam[render]'``) is optional: it is imported only here, and only when a
picture is made. Its Tachyon renderer needs the Vulkan loader and Mesa's software driver at run time (Debian:
``apt-get install libvulkan1 mesa-vulkan-drivers``); see the README.
"""

from __future__ import annotations

import os
import tempfile
from pathlib import Path

import numpy as np

from ..core.errors import SpherejamError
from ..core.packing import Packing

INSTALL_HINT = ("rendering needs OVITO: pip install 'spherejam[render]' (and on Debian/Ubuntu: "
                "apt-get install libvulkan1 mesa-vulkan-drivers)")
#: Camera direction of the view: from a corner, slightly above, so three faces of the cell show.
CAMERA_DIR = (-1.0, -0.75, -0.55)
#: Camera direction for a cylinder along z: from the side, slightly above, so the column stands upright.
COLUMN_CAMERA_DIR = (-1.0, -0.6, -0.35)


def ovito_available() -> bool:
    """True when OVITO's Python module and its renderer's libraries can be loaded."""
    try:
        import ovito.vis  # noqa: F401
    except Exception:  # ImportError, or OSError for a missing libvulkan
        return False
    return True


def _import_ovito():
    try:
        from ovito.data import DataCollection
        from ovito.pipeline import Pipeline, StaticSource
        from ovito.vis import TachyonRenderer, Viewport
    except Exception as exc:
        raise SpherejamError(f"{INSTALL_HINT} ({type(exc).__name__}: {exc})") from None
    return DataCollection, Pipeline, StaticSource, TachyonRenderer, Viewport


def diameter_colours(diameters: np.ndarray, cmap_name: str = "viridis"):
    """RGB per sphere from its diameter D on ``cmap_name``, and the (D_min, D_max) range of the colour scale."""
    from matplotlib import colormaps

    d = np.asarray(diameters, dtype=float)
    lo, hi = float(d.min()), float(d.max())
    if hi - lo < 1e-12 * hi:  # monodisperse: one colour, the middle of the map
        t = np.full(d.shape, 0.5)
        lo, hi = lo * 0.99, hi * 1.01
    else:
        t = (d - lo) / (hi - lo)
    return colormaps[cmap_name](t)[:, :3], (lo, hi)


def render_spheres(packing: Packing, path: str | os.PathLike, size: tuple[int, int] = (800, 800),
                   cmap_name: str = "viridis") -> Path:
    """Ray-trace the spheres (coloured by diameter) and the cell's edges into the PNG file ``path``.

    The centres are wrapped into the cell, so a sphere that crosses a face sticks out of it, as in the paper.
    """
    if packing.dim != 3:
        raise SpherejamError(f"dimension d={packing.dim}: only 3D packings can be rendered")
    DataCollection, Pipeline, StaticSource, TachyonRenderer, Viewport = _import_ovito()
    c = packing.container
    lengths = [float(x) for x in c.lengths]
    data = DataCollection()
    cell = data.create_cell(np.array([[lengths[0], 0, 0, 0], [0, lengths[1], 0, 0], [0, 0, lengths[2], 0]],
                                     dtype=float), pbc=tuple(bool(p) for p in c.periodic))
    cell.vis.line_width = 0.004 * max(lengths)
    cell.vis.enabled = c.curved is None  # a cylinder or a sphere shows by its spheres, not by its frame
    particles = data.create_particles(count=packing.n)
    particles.create_property("Position", data=packing.positions)
    particles.create_property("Radius", data=0.5 * packing.diameters)
    particles.create_property("Color", data=diameter_colours(packing.diameters, cmap_name)[0])
    pipeline = Pipeline(source=StaticSource(data=data))
    pipeline.add_to_scene()
    try:
        column = c.curved == "cylinder" and c.axis == 2
        viewport = Viewport(type=Viewport.Type.Perspective, camera_dir=COLUMN_CAMERA_DIR if column else CAMERA_DIR)
        viewport.zoom_all(size=size)
        viewport.render_image(size=size, filename=str(path), background=(1.0, 1.0, 1.0),
                              renderer=TachyonRenderer(ambient_occlusion=True, antialiasing_samples=4))
    finally:
        pipeline.remove_from_scene()
    return Path(path)


def _trim(image: np.ndarray, margin: int = 8) -> np.ndarray:
    """The image cropped to its non-white content plus ``margin`` pixels."""
    ink = np.any(image[..., :3] < 0.99, axis=-1)
    rows, cols = np.flatnonzero(ink.any(axis=1)), np.flatnonzero(ink.any(axis=0))
    if rows.size == 0:
        return image
    r0, r1 = max(rows[0] - margin, 0), min(rows[-1] + margin + 1, image.shape[0])
    c0, c1 = max(cols[0] - margin, 0), min(cols[-1] + margin + 1, image.shape[1])
    return image[r0:r1, c0:c1]


def figure(packing: Packing, size: tuple[int, int] = (800, 800), sigma: float | None = None, title: str | None = None):
    """A matplotlib Figure: the rendered packing, a diameter colour bar, and a title with N, phi and sigma.

    ``sigma`` is the nominal polydispersity to print; by default the sample's relative std of D is printed.
    """
    from matplotlib.colors import Normalize

    from .plotting import pyplot

    plt = pyplot()

    with tempfile.TemporaryDirectory() as tmp:
        png = render_spheres(packing, Path(tmp) / "spheres.png", size)
        image = _trim(plt.imread(png))
    d = packing.diameters
    if title is None:
        spread = f"σ = {sigma:g}" if sigma is not None else f"σ (sample) = {d.std() / d.mean():.3f}"
        # an MLS result is a closest jammed configuration: its phi is the closest jamming density phi_J
        jammed = packing.metadata.get("algorithm") == "mls"
        what = "closest jammed configuration\n" if jammed else ""
        title = f"{what}N = {packing.n}, {'$φ_J$' if jammed else 'φ'} = {packing.phi:.4f}, {spread}"
        if not packing.container.is_periodic_cube:
            achieved = ", ".join(f"{k} = {v:.3g}" for k, v in
                                 packing.container.in_diameters(packing.mean_diameter).items())
            title += f"\n{packing.container.shape}: {achieved} ⟨d⟩"
    dpi = 150
    h, w = image.shape[0] / dpi, image.shape[1] / dpi  # inches at the figure's resolution
    pad = max(0.0, 4.4 - (w + 1.2))  # a tall, narrow column: room for the title on both sides
    width = w + 1.2 + pad
    fig = plt.figure(figsize=(width, h + 0.6), dpi=dpi)
    ax = fig.add_axes((0.5 * pad / width, 0.0, w / width, h / (h + 0.6)))
    ax.imshow(image)
    ax.set_axis_off()
    _, (lo, hi) = diameter_colours(d)
    cax = fig.add_axes(((0.5 * pad + w + 0.15) / width, 0.15, 0.15 / width, 0.6))
    fig.colorbar(plt.cm.ScalarMappable(Normalize(lo, hi), "viridis"), cax=cax, label="diameter D")
    fig.suptitle(title, fontsize=9)
    return fig


IMAGE_FORMATS = ("png", "pdf")


def write_images(packing: Packing, outputs, size: tuple[int, int] = (800, 800), sigma: float | None = None,
                 title: str | None = None) -> list[Path]:
    """Render once and write the figure to every path in ``outputs`` (format from the suffix: .png or .pdf)."""
    from ..core.atomic import atomic_output
    from ..core.errors import InputError

    outputs = [Path(p) for p in outputs]
    for p in outputs:
        if p.suffix.lstrip(".").lower() not in IMAGE_FORMATS:
            raise InputError(f"output={str(p)!r}: must end with .png or .pdf")
    import matplotlib.pyplot as plt

    fig = figure(packing, size, sigma, title)
    try:
        for p in outputs:
            with atomic_output(p, p.suffix) as tmp:
                fig.savefig(tmp, format=p.suffix.lstrip(".").lower(), dpi=150)
    finally:
        plt.close(fig)
    return outputs
