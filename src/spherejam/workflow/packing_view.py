"""A packing as one self-contained interactive HTML page (``spherejam view``).

The page (``packing_view.html`` beside this module) is a small WebGL2 viewer written for spherejam: every sphere is
one instance of a quad whose fragment shader ray-casts the sphere (exact silhouette and depth at any zoom, four
vertices per sphere); rotate by dragging, zoom with the wheel, colour by diameter, coordination or rattler, the
periodic box drawn, a slab along x, y or z to look inside. Nothing is fetched: the script is inline and the packing is
a JSON block with its arrays as base64 little-endian float32/uint8, about 17 bytes a sphere (N = 1000: ~30 kB).

Coordination and rattlers are those of :func:`spherejam.analysis.contacts.analyze_contacts` at its default contact
tolerance (chosen from the gaps and the packing's reduced pressure): a rattler has fewer than d + 1 contacts in the
(d+1)-core of the contact graph.
"""

from __future__ import annotations

import base64
import html
import json
from pathlib import Path

import numpy as np

from ..core.errors import InputError

TEMPLATE = Path(__file__).with_name("packing_view.html")


def _b64(array: np.ndarray, dtype: str) -> str:
    return base64.b64encode(np.ascontiguousarray(array, dtype=dtype).tobytes()).decode("ascii")


def view_data(packing, title: str) -> dict:
    """The page's JSON: N, the frame's edges and the container, phi, the title and the per-sphere arrays (base64)."""
    from ..analysis.contacts import analyze_contacts

    if packing.dim != 3:
        raise InputError(f"dim={packing.dim}: the viewer draws 3D packings only")
    contacts = analyze_contacts(packing)
    return {
        "n": packing.n,
        "lengths": [float(x) for x in packing.container.lengths],
        "container": None if packing.container.is_periodic_cube else {
            "spec": packing.container.spec, "curved": packing.container.curved,
            "radius": float(packing.container.radius), "axis": int(packing.container.axis)},
        "phi": float(packing.phi),
        "title": title,
        "contact_tolerance": float(contacts.coordination.contact_tolerance),
        "n_rattlers": int(np.count_nonzero(contacts.rattler)),
        "positions": _b64(packing.positions, "<f4"),
        "diameters": _b64(packing.diameters, "<f4"),
        "contacts": _b64(np.minimum(contacts.contacts_per_particle, 255), "u1"),
        "rattler": _b64(contacts.rattler, "u1"),
    }


def packing_html(packing, title: str) -> str:
    """The whole page for ``packing``."""
    data = json.dumps(view_data(packing, title), separators=(",", ":"))
    data = data.replace("<", "\\u003c")  # no "</script>" can end the JSON block early
    head, tail = TEMPLATE.read_text(encoding="utf-8").split("__DATA__")  # the title is filled in the head only
    return head.replace("__TITLE__", html.escape(title)) + data + tail


def write_view(packing, path: str | Path, title: str) -> int:
    """Write the page to ``path`` (atomically); returns its size in bytes."""
    from ..core.atomic import atomic_output

    text = packing_html(packing, title).encode("utf-8")
    with atomic_output(path, ".html") as tmp:
        Path(tmp).write_bytes(text)
    return len(text)
