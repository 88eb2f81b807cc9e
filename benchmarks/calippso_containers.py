"""CALiPPSO certifies MLS outputs in every container shape (issue 45, "Certified"; docs/containers.md §5).

For each shape of ``containers_common.SHAPES`` (sized for N spheres from the cube side N spheres fill at 0.62): a
Poisson start, MLS (gamma_0 = 10, f = 2, gamma_f = 1e-2, the acceptance benchmarks' protocol), then
``run_calippso`` with its defaults. Prints one table row per shape as it finishes:

    shape, N, LPs, CPU s of the certification, |sqrt(Gamma) - 1| and max |s| of the last LP, contacts (sphere-sphere +
    sphere-wall) against the shape's isostatic count 3 N_s - z + 1 - F (F the partial rattlers' free directions,
    docs/containers.md §4), the escapes the run made (§5), the states of self-stress and floppy modes of the
    certified network by the rank of its rigidity matrix built here (dense SVD; the count as a rank statement: 1 and
    z + F), the force balance (units of the mean force),
    the worst overlap and wall penetration of the certified packing by the brute-force check of containers_common
    (no call to the package's own checks), and whether all of these pass (converged, isostatic, balanced to 1e-10,
    no overlap or penetration beyond 1e-10); the exit status is 0 only if every row passes.

    python benchmarks/calippso_containers.py [--n 300] [--sigma 0] [--seed 1] [--cache DIR]

``--cache`` keeps the MLS outputs (``SHAPE_N_SEED.h5``), so a rerun certifies the same packings. CPU seconds are
those of this process (HiGHS single-threaded), the figure to compare on a shared machine.
"""

from __future__ import annotations

import argparse
import math
import os
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

from containers_common import SHAPES, brute_force, cube_side, provenance, start_packing  # noqa: E402

from spherejam.calippso.run import run_calippso  # noqa: E402
from spherejam.core.packing_io import read_packing, write_packing  # noqa: E402
from spherejam.engines.closest_jamming import find_closest_jamming  # noqa: E402


def mls_output(shape: str, n: int, dist: str, seed: int, cache: Path | None):
    """The MLS output of one shape (from the cache if it is there), and the CPU seconds it took (None if cached)."""
    spec = SHAPES[shape](cube_side(n, dist))
    n_arg = None if shape == "sphere" else n  # the sphere's spec fixes N
    path = None if cache is None else cache / f"{shape}_{n}_{dist}_{seed}.h5"
    if path is not None and path.exists():
        return read_packing(path), None
    cpu = time.process_time()
    start = start_packing(n_arg, dist, spec, seed)
    mls = find_closest_jamming(start, initial_rate=10.0, decrease_factor=2.0, final_rate=1e-2, seed=seed + 1,
                               progress_interval=1e9).packing
    cpu = time.process_time() - cpu
    if path is not None:
        path.parent.mkdir(parents=True, exist_ok=True)
        write_packing(path, mls)
    return mls, cpu


def network_states(r) -> tuple[int, int]:
    """(states of self-stress, floppy modes) of a CALiPPSO result's contact network among non-rattlers: K - rank and
    d N_s - rank of its rigidity matrix (a row per contact, +u on its sphere, -u on its partner, a wall row +u only),
    the rank by a dense SVD with the relative threshold 1e-9."""
    stable = np.flatnonzero(~r.rattlers)
    dim = r.packing.dim
    col = np.full(r.packing.n, -1)
    col[stable] = np.arange(stable.size)
    rows = np.zeros((len(r.pairs) + len(r.wall_contacts), dim * stable.size))
    for k, ((i, j), u) in enumerate(zip(r.pairs, r.contact_vectors)):
        rows[k, dim * col[i]:dim * col[i] + dim] += u
        rows[k, dim * col[j]:dim * col[j] + dim] -= u
    for k, (i, u) in enumerate(zip(r.wall_contacts, r.wall_vectors), start=len(r.pairs)):
        rows[k, dim * col[i]:dim * col[i] + dim] = u
    sv = np.linalg.svd(rows, compute_uv=False)
    rank = int(np.sum(sv > 1e-9 * sv[0]))
    return rows.shape[0] - rank, rows.shape[1] - rank


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=300)
    ap.add_argument("--dist", default="mono", help="a distribution of containers_common.DISTRIBUTIONS")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--shapes", nargs="*", default=list(SHAPES))
    ap.add_argument("--cache", type=Path, default=None)
    args = ap.parse_args(argv)
    print(f"# CALiPPSO in containers: MLS outputs, N = {args.n}, {args.dist}, seed {args.seed}; {provenance()}")
    print("| shape | container | N | MLS CPU s | LPs | CPU s | abs(sqrt(Gamma)-1) | max abs(s) | contacts (walls) "
          "| isostatic count | N_s | F | escapes | self-stresses, floppy (z + F) | force balance | worst overlap "
          "| worst penetration | certified |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|")
    ok = True
    for shape in args.shapes:
        packing, mls_cpu = mls_output(shape, args.n, args.dist, args.seed, args.cache)
        cpu = time.process_time()
        r = run_calippso(packing, progress_interval=1e9)
        cpu = time.process_time() - cpu
        c = r.packing.container
        check = brute_force(r.packing.positions, r.packing.diameters, c)
        iso = c.isostatic_contacts(r.n_stable, r.free_directions)
        states = network_states(r)
        pen = check["worst_penetration"]
        why = [text for bad, text in ((not r.completed, r.stop_reason),
                                      (r.n_contacts != iso, f"N_c - count = {r.n_contacts - iso}"),
                                      (states != (1, c.zero_modes + r.free_directions), "rank"),
                                      (r.force_balance_residual > 1e-10, "forces"),
                                      (check["worst_overlap"] > 1e-10, "overlap"), (pen > 1e-10, "penetration")) if bad]
        ok &= not why
        mls_text = "cached" if mls_cpu is None else f"{mls_cpu:.1f}"
        print(f"| {shape} | `{c.spec}` | {packing.n} | {mls_text} | {r.iterations} | {cpu:.2f} | "
              f"{abs(r.history['sqrt_inflation_minus_1'][-1]):.1e} | {r.history['max_displacement'][-1]:.1e} | "
              f"{r.n_contacts} ({len(r.wall_contacts)}) | {iso} | {r.n_stable} | {r.free_directions} | "
              f"{r.counters.get('escapes', 0)} | {states[0]}, {states[1]} ({c.zero_modes + r.free_directions}) | "
              f"{r.force_balance_residual:.1e} | "
              f"{check['worst_overlap']:.1e} | {'none' if math.isinf(pen) else f'{pen:.1e}'} | "
              f"{'yes' if not why else 'no: ' + ', '.join(why)} |", flush=True)
    print(f"# load average at the end: {os.getloadavg()[0]:.1f}")
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
