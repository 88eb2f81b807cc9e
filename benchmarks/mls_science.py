"""Science checks of the closest-jamming (MLS) search (issue 4), too slow for the unit tests.

For each seed: Poisson packing -> LS at a fast rate (1/gamma < 5) -> MLS with the paper's parameters; optionally
also LS at a slow rate (1/gamma >= 100) -> MLS. Prints, per packing, phi after LS, phi_J, the MLS stages, collisions,
wall time, the coordination number Z of the non-rattlers (contacts: gap tolerance chosen from the pressure by
:func:`spherejam.analysis.contacts.analyze_contacts`, and the reference code's fixed 1e-7) and the crystalline fraction
(:func:`spherejam.analysis.bond_order.crystalline_fraction`: monodisperse searches can nucleate crystals, paper
§IV.A), then a
summary against the paper's band of its sigma (Table 3, :mod:`spherejam.workflow.paper_reference`; sigma = 0: phi_J in
[0.6356, 0.6406] for fast packings of N = 1e4, the minimum being the one surviving phi_min row, LS or FB).

    python benchmarks/mls_science.py --n 1000 --seeds 1 2 3 4 5 --slow-seeds 1
    python benchmarks/mls_science.py --n 10000 --seeds 1 --checkpoint-dir runs/   # ~1.5 h per packing, one core

With ``--checkpoint-dir`` each MLS search checkpoints there every 2 minutes and a rerun of the same command resumes
it (the wall time is summed over the runs); seeds already in the ``--json`` file are skipped. With ``--save-dir``
each jammed packing is written there (spherejam HDF5 with its per-window history), e.g. to certify it afterwards
with ``spherejam calippso`` or ``benchmarks/bench_calippso.py --start``.
"""

from __future__ import annotations

import argparse
import json
import logging
import time
from pathlib import Path

import numpy as np

from spherejam.analysis.contacts import analyze_contacts
from spherejam.analysis.bond_order import crystalline_fraction
from spherejam.core.packing_io import write_packing
from spherejam.core.seeding import poisson_packing
from spherejam.engines.closest_jamming import find_closest_jamming
from spherejam.engines.lubachevsky_stillinger import run_ls
from spherejam.workflow import paper_reference


def paper_band(sigma: float) -> tuple[float, float] | None:
    """The paper's Table 3 band at sigma: (surviving phi_min^fast row, LS or FB; LS phi_max^fast), None if absent."""
    mins = paper_reference.table3_min_unattributed()
    maxs = paper_reference.table3()
    lo = mins[np.isclose(mins.sigma, sigma)].phi_min
    hi = maxs[np.isclose(maxs.sigma, sigma) & (maxs.protocol == "LS")].phi_max
    return (float(lo.iloc[0]), float(hi.iloc[0])) if len(lo) and len(hi) else None


def one(n: int, sigma: float, seed: int, rate: float, checkpoint_dir: Path | None = None,
        save_dir: Path | None = None) -> dict:
    start = poisson_packing(n, sigma, seed=seed)
    t0 = time.perf_counter()
    ls = run_ls(start, rate, seed=seed, progress_interval=1e9)
    t1 = time.perf_counter()
    cpu1 = time.process_time()
    checkpoint = None
    if checkpoint_dir is not None:
        checkpoint = checkpoint_dir / f"mls_n{n}_sigma{sigma:g}_seed{seed}_rate{rate:g}.h5"
    mls = find_closest_jamming(ls.packing, seed=seed, progress_interval=120.0, checkpoint=checkpoint,
                               checkpoint_interval=120.0)
    t2 = time.perf_counter()
    mls_cpu = time.process_time() - cpu1
    if save_dir is not None:
        write_packing(save_dir / f"mls_n{n}_sigma{sigma:g}_seed{seed}_rate{rate:g}.h5", mls.packing, mls.history)
    auto = analyze_contacts(mls.packing).coordination
    fixed = analyze_contacts(mls.packing, contact_tolerance=1e-7).coordination
    crystalline, largest = crystalline_fraction(mls.packing)
    c = mls.stats
    return {
        "n": n, "sigma": sigma, "seed": seed, "ls_rate": rate, "phi_ls": ls.packing.phi,
        "ls_collisions": ls.stats.collisions, "ls_wall": t1 - t0,
        "phi_J": c.phi_final, "stages": c.extras.stages, "stalled_stages": c.extras.stalled_stages,
        "stop": c.stop_reason, "mls_collisions": c.collisions,
        "mls_wall": c.wall_time, "mls_wall_this_run": t2 - t1, "mls_cpu_this_run": mls_cpu,
        "resumed": c.resumed, "pressure": mls.packing.metadata["reduced_pressure"],
        "z_auto": auto.z_nonrattler, "tol_auto": auto.contact_tolerance, "rattlers_auto": auto.rattler_fraction,
        "excess_auto": auto.isostatic_excess, "z_1e-7": fixed.z_nonrattler, "rattlers_1e-7": fixed.rattler_fraction,
        "crystalline": crystalline, "largest_crystal": largest,
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=1000)
    ap.add_argument("--sigma", type=float, default=0.0)
    ap.add_argument("--seeds", type=int, nargs="*", default=[1, 2, 3, 4, 5])
    ap.add_argument("--fast-rate", type=float, default=0.5, help="LS rate of the fast packings (1/gamma = 2)")
    ap.add_argument("--slow-seeds", type=int, nargs="*", default=[])
    ap.add_argument("--slow-rate", type=float, default=0.01, help="LS rate of the slow packings (1/gamma = 100)")
    ap.add_argument("--json", help="append one JSON line per packing to this file (seeds in it are skipped)")
    ap.add_argument("--checkpoint-dir", type=Path, help="checkpoint (and resume) the MLS searches here")
    ap.add_argument("--save-dir", type=Path, help="write each jammed packing here (HDF5, with its history)")
    args = ap.parse_args()
    logging.basicConfig(level=logging.INFO, format="%(message)s")

    done = []
    if args.json and Path(args.json).exists():
        done = [json.loads(line) for line in Path(args.json).read_text().splitlines() if line.strip()]
    for folder in (args.checkpoint_dir, args.save_dir):
        if folder is not None:
            folder.mkdir(parents=True, exist_ok=True)
    rows = []
    for label, rate, seeds in (("fast", args.fast_rate, args.seeds), ("slow", args.slow_rate, args.slow_seeds)):
        for seed in seeds:
            old = [r for r in done if (r["n"], r["sigma"], r["seed"], r["ls_rate"]) == (args.n, args.sigma, seed, rate)]
            if old:
                rows.append(old[-1])
                print(f"{label} seed {seed}: already in {args.json}, phi_J={old[-1]['phi_J']:.5f}", flush=True)
                continue
            row = dict(one(args.n, args.sigma, seed, rate, args.checkpoint_dir, args.save_dir), kind=label)
            rows.append(row)
            print(f"{label} N={row['n']} sigma={row['sigma']} seed={seed} 1/gamma={1 / rate:g}: "
                  f"phi_LS={row['phi_ls']:.5f} phi_J={row['phi_J']:.5f} (+{row['phi_J'] - row['phi_ls']:.5f}) "
                  f"stages={row['stages']} stop={row['stop']} MLS collisions={row['mls_collisions']:,} "
                  f"wall={row['mls_wall']:.0f}s (this run {row['mls_wall_this_run']:.0f}s, "
                  f"cpu {row['mls_cpu_this_run']:.0f}s) "
                  f"p={row['pressure']:.3g} "
                  f"Z={row['z_auto']:.3f} "
                  f"(tol {row['tol_auto']:.1e}, rattlers {row['rattlers_auto']:.3f}, K'-K0={row['excess_auto']}) "
                  f"Z(1e-7)={row['z_1e-7']:.3f} crystalline={row['crystalline']:.3f} "
                  f"(largest crystal {row['largest_crystal']:.3f})", flush=True)
            if args.json:
                with open(args.json, "a") as f:
                    # numpy scalars as plain numbers: a row that fails to serialise would lose hours of work
                    f.write(json.dumps(row, default=lambda o: o.item() if hasattr(o, "item") else str(o)) + "\n")
    fast = [r["phi_J"] for r in rows if r["kind"] == "fast"]
    if fast:
        band = paper_band(args.sigma)
        paper = f"paper sigma={args.sigma:g}, N=1e4: [{band[0]}, {band[1]}]" if band else "no paper band at this sigma"
        print(f"fast: phi_J mean {np.mean(fast):.5f} min {np.min(fast):.5f} max {np.max(fast):.5f} ({paper})")
    slow = [r["phi_J"] - r["phi_ls"] for r in rows if r["kind"] == "slow"]
    if slow:
        print(f"slow: phi_J - phi_LS = {', '.join(f'{d:.5f}' for d in slow)}")


if __name__ == "__main__":
    main()
