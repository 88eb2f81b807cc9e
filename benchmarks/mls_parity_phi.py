"""Is phi_J of a parity pair computed the same way in both codes? (issue 50, docs/mls_parity.md §6)

For one finished pair (``OUT/<cell>/pair-SSSS`` of ``benchmarks/mls_parity.py``):

* the C++ final packing: positions and *nominal* diameters D from its ``packing.xyzd`` (the code writes D as read,
  not rescaled), box L; its phi_J = 1 - ``Final Porosity`` of ``packing.nfo``;
* ours: the same search rerun from the same start and velocity seed (it is deterministic; the rerun must give the
  recorded phi_J bit for bit), final packing kept in memory.

For each final packing, independently of either code's bookkeeping: the closest pair over ALL pairs (periodic k-d
tree, not the codes' neighbour lists), r_min = min |r_ij| / D_ij with D_ij = (D_i + D_j) / 2 of the mean-1 nominal
diameters, and phi_contact = (sum pi/6 D_i^3 / L^3) r_min^3: the density of the packing with every sphere scaled
by the common factor that makes the closest pair touch. That is how both codes define the scale of a packing
(docs/mls_parity.md §6). A code whose reported phi_J disagreed with phi_contact would be computing phi
differently (nominal against actual diameters, another box), or holding a gap or an overlap.

    PYTHONPATH=src python benchmarks/mls_parity_phi.py /work/runs/parity/N500-sigma0.3-ls0.5/pair-0001
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from pathlib import Path

import numpy as np
from scipy.spatial import cKDTree

from spherejam.formats import packing_generation as pg

from parity.ours import make_start, run_ours  # the script's folder is first on sys.path


def contact_ratio(positions: np.ndarray, nominal: np.ndarray, box: float) -> tuple[float, int, int]:
    """min over all pairs of |r_ij| / ((D_i + D_j) / 2) in the periodic cube of side ``box``, and the pair."""
    x = np.mod(positions, box)
    x[x >= box] = 0.0  # np.mod can round up to box itself
    tree = cKDTree(x, boxsize=box)
    reach = 2.0 * float(nominal.max())  # the closest pair has ratio < 2 in any packing denser than ~0.1
    pairs = tree.query_pairs(reach, output_type="ndarray")
    d = x[pairs[:, 0]] - x[pairs[:, 1]]
    d -= box * np.round(d / box)
    ratio = np.sqrt(np.sum(d * d, axis=1)) / (0.5 * (nominal[pairs[:, 0]] + nominal[pairs[:, 1]]))
    k = int(np.argmin(ratio))
    return float(ratio[k]), int(pairs[k, 0]), int(pairs[k, 1])


def phi_check(positions: np.ndarray, diameters: np.ndarray, box: float, phi_reported: float) -> dict:
    """phi_contact of a final packing (any diameter scale: only D_i / mean(D) is used) against the reported phi_J."""
    nominal = diameters / diameters.mean()
    r_min, i, j = contact_ratio(positions, nominal, box)
    phi_nominal = float(np.sum(math.pi / 6.0 * nominal**3) / box**3)
    phi_contact = phi_nominal * r_min**3
    return {"phi_reported": phi_reported, "phi_contact": phi_contact, "r_min": r_min, "pair": [i, j],
            "relative_difference": (phi_reported - phi_contact) / phi_contact,
            "phi_monodisperse_formula": float(len(nominal) * math.pi / 6.0 * (r_min * nominal.mean()) ** 3 / box**3)}


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("pair", type=Path, help="a finished pair folder OUT/<cell>/pair-SSSS")
    ap.add_argument("--skip-ours", action="store_true", help="check the C++ packing only (no rerun of ours)")
    args = ap.parse_args(argv)
    cpp_rec = json.loads((args.pair / "cpp.json").read_text())
    ours_rec = json.loads((args.pair / "ours.json").read_text())
    folder = args.pair / "cpp"
    data = np.fromfile(folder / pg.XYZD, dtype="<f8").reshape(-1, 4)
    conf = (folder / pg.CONF).read_text()
    box = float(next(line for line in conf.splitlines() if line.startswith("Packing size")).split(":")[1].split()[0])
    out = {"cpp": phi_check(data[:, :3], data[:, 3], box, cpp_rec["phi_J"])}
    if not args.skip_ours:
        m = ours_rec
        start = make_start(m["n"], m["sigma"], m["seed"], m["start_kind"], m["start_rate"])
        res, packing = run_ours(start, m["seed"], m["initial_rate"], m["factor"], m["final_rate"], m["max_collisions"],
                                return_packing=True)
        out["ours"] = phi_check(packing.positions, packing.diameters, float(packing.box), res["phi_J"])
        out["ours"]["phi_J_recorded"] = m["phi_J"]
        out["ours"]["rerun_identical"] = res["phi_J"] == m["phi_J"]
    print(json.dumps(out, indent=1))


if __name__ == "__main__":
    sys.exit(main())
