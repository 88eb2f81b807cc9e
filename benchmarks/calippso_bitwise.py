"""CALiPPSO certificates compared bit for bit between two checkouts (issue 45: the rank rule and the escape of
docs/containers.md §4-§5 must leave every generic certificate as it was).

    python benchmarks/calippso_bitwise.py make DIR                  # the periodic-cube inputs (MLS outputs) into DIR
    PYTHONPATH=/path/to/old/src python benchmarks/calippso_bitwise.py run OLD.npz DIR [H5 ...]
    PYTHONPATH=/path/to/new/src python benchmarks/calippso_bitwise.py run NEW.npz DIR [H5 ...]
    python benchmarks/calippso_bitwise.py compare OLD.npz NEW.npz

``make``: MLS (gamma 10 -> 1e-2, f = 2) from Poisson starts in the periodic cube, N = 200 and 500, sigma = 0 and 0.3,
seeds 1-2. ``run`` certifies every ``*.h5`` of DIR and the packings named after it (e.g. the cached container MLS
outputs of ``calippso_containers.py --cache``) with ``run_calippso``'s defaults and saves positions, diameters,
contact pairs, forces, wall forces, rattlers and (N_c, isostatic, LPs, force balance) of each; ``compare`` lists
the arrays that differ in any bit.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np


def make(folder: Path) -> None:
    from spherejam import find_closest_jamming, poisson_packing
    from spherejam.core.packing_io import write_packing

    folder.mkdir(parents=True, exist_ok=True)
    for n in (200, 500):
        for sigma in (0.0, 0.3):
            for seed in (1, 2):
                start = poisson_packing(n, sigma=sigma, seed=seed)
                mls = find_closest_jamming(start, initial_rate=10.0, decrease_factor=2.0, final_rate=1e-2, seed=seed,
                                           progress_interval=1e9).packing
                write_packing(folder / f"cube_{n}_{sigma}_{seed}.h5", mls)


def run(out: str, folder: Path, extra: list[str]) -> None:
    from spherejam.calippso.run import run_calippso
    from spherejam.core.packing_io import read_packing

    arrays = {}
    for path in sorted(folder.glob("*.h5")) + [Path(p) for p in extra]:
        r = run_calippso(read_packing(path), progress_interval=1e9)
        key = path.name
        arrays.update({f"{key}:positions": r.packing.positions, f"{key}:diameters": r.packing.diameters,
                       f"{key}:pairs": r.pairs, f"{key}:forces": r.forces, f"{key}:wall_forces": r.wall_forces,
                       f"{key}:rattlers": r.rattlers,
                       f"{key}:summary": np.array([r.n_contacts, r.isostatic, r.iterations,
                                                   r.force_balance_residual])})
        print(key, r.iterations, r.n_contacts, r.isostatic, flush=True)
    np.savez(out, **arrays)


def compare(old: str, new: str) -> int:
    a, b = np.load(old), np.load(new)
    differ = [k for k in a.files if k not in b.files or a[k].shape != b[k].shape or not np.array_equal(a[k], b[k])]
    print(f"{len(a.files)} arrays compared, {len(differ)} differ: {differ}")
    return 1 if differ else 0


if __name__ == "__main__":
    if sys.argv[1] == "make":
        make(Path(sys.argv[2]))
    elif sys.argv[1] == "run":
        run(sys.argv[2], Path(sys.argv[3]), sys.argv[4:])
    else:
        sys.exit(compare(sys.argv[2], sys.argv[3]))
