"""MLS parity: our closest-jamming search against the paper's own C++ code (``-lsgd``) on identical starts (issue 24).

Each *pair* is one start packing made by OUR code (Poisson seed s -> FB at gamma = ``--start-rate``, or LS at that
rate), given to both codes; with ``--start FILE`` every pair starts from that packing instead (any format
``spherejam`` reads, e.g. a workflow's ``initial.h5``) and only the velocity seed s differs:

* ours: :func:`spherejam.find_closest_jamming` (gamma_0, f, final rate as given, p_max = 1e12, 50 equilibration
  windows, velocity seed s);
* the C++ code (VasiliBaranov/packing-generation, built by you outside this repo, path in ``--exe``): the start is
  written in its input format (``packing.xyzd``: little-endian float64 ``x y z D`` per sphere, with the nominal
  diameters D = d / mean(d), i.e. exactly our engine's nominal diameters, so both codes grow the spheres at the same
  d D_i / dt = gamma D_i; ``generation.conf`` with ``Generation start: 0``, ``Seed: s`` and the three MLS rates), run
  with ``-lsgd`` in that folder. phi_J is read from its ``packing.nfo`` (``1 - Final Porosity``). Per-window figures
  (collisions, rate, scale factor, pressure) need a binary that prints, once per window, a line
  ``PARITY collisions C rate G ratio R pressure P time T cpu S``; a stock binary gives phi_J, stop and CPU only.

Searches are cut at a number of collisions and recorded as ``capped``: the C++ run at
``--max-collisions-per-particle`` x N (SIGINT once its log passes that count, so it needs the PARITY lines), ours at
``--ours-max-collisions-per-particle`` x N (``max_collisions``: deterministic; default the C++ cap). A capped result
is redone by a later call with a higher cap; the summary shows phi at the cap as a lower bound of phi_J and counts
a capped search as costlier than its cap. CPU seconds per search are measured here: ``time.process_time`` around
our call (after a warm-up search, so no compilation is charged), and the child's user + system time
(``resource.getrusage(RUSAGE_CHILDREN)``) for the C++ process.

One JSON file per pair and code (``OUT/<cell>/pair-SSSS/{ours,cpp}.json``, written atomically); a rerun skips what is
done, so the command is resumable. ``--summarize`` prints the table of every cell in OUT (docs/mls_parity.md).
This file is the command line and the loop over pairs; its parts are in ``benchmarks/parity/``.

    nice -n 15 python benchmarks/mls_parity.py --out /tmp/parity --exe <PackingGeneration.exe> \\
        --n 500 --sigma 0 --pairs 10 --ours-max-collisions-per-particle 1e6
    python benchmarks/mls_parity.py --out /tmp/parity --summarize
    python benchmarks/mls_parity.py --out /tmp/parity --export-records benchmarks/records/parity  # compact copies
    python benchmarks/mls_parity.py --out /tmp/parity --exe <exe> --start <initial.h5> --initial-rate 10 --seeds 1 2
"""

from __future__ import annotations

import argparse
import hashlib
import json
import sys
import time
from pathlib import Path

import numpy as np

from spherejam.core.atomic import atomic_output
from spherejam.core.packing_io import read_packing
from spherejam.formats import packing_generation as pg

# the parts of this script, in benchmarks/parity/ beside it (the script's folder is first on sys.path)
from parity.cpp import collect_cpp, nominal_density, run_cpp, write_cpp_input
from parity.locks import claim
from parity.ours import classify, make_start, run_ours, warm_up
from parity.report import summarize
from parity.stages import compact


def _done(path: Path, cap: int) -> bool:
    """A result exists, and unless it was capped below ``cap`` it need not be redone."""
    if not path.is_file():
        return False
    res = json.loads(path.read_text())
    if res["code"] == "ours":
        classify(res, res["max_collisions"])
    return not (res["capped"] and res["max_collisions"] < cap)


def _write_json(path: Path, data: dict) -> None:
    with atomic_output(path) as tmp:
        tmp.write_text(json.dumps(data))


def export_records(out: Path, dest: Path) -> None:
    """Compact copies of every finished search in ``out`` (docs/mls_parity.md: the committed records)."""
    for path in sorted(out.glob("*/pair-*/*.json")):
        target = dest / path.relative_to(out)
        target.parent.mkdir(parents=True, exist_ok=True)
        _write_json(target, compact(json.loads(path.read_text())))


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", type=Path, required=True, help="scratch folder (one sub-folder per cell)")
    ap.add_argument("--summarize", action="store_true", help="print the table of every cell in --out and exit")
    ap.add_argument("--export-records", type=Path, metavar="DIR",
                    help="write a compact copy (stages instead of the per-window history) of every result in --out "
                         "to DIR/<cell>/<pair>/<code>.json and exit; --summarize reads such a folder too")
    ap.add_argument("--exe", help="the C++ PackingGeneration binary")
    ap.add_argument("--n", type=int, default=500)
    ap.add_argument("--sigma", type=float, default=0.0)
    ap.add_argument("--pairs", type=int, default=10, help="number of start packings (pairs)")
    ap.add_argument("--first-seed", type=int, default=1)
    ap.add_argument("--seeds", type=int, nargs="*", help="explicit pair seeds (overrides --pairs/--first-seed)")
    ap.add_argument("--start-kind", choices=("fb", "ls"), default="fb")
    ap.add_argument("--start-rate", type=float, default=1e-3, help="gamma of the FB (or LS) start")
    ap.add_argument("--start", type=Path, help="one start packing for every pair (overrides --n, --sigma, "
                    "--start-kind and --start-rate; the pair seed is then the velocity seed only)")
    ap.add_argument("--initial-rate", type=float, default=1e-2)
    ap.add_argument("--factor", type=float, default=2.0)
    ap.add_argument("--final-rate", type=float, default=1e-4)
    ap.add_argument("--max-collisions-per-particle", type=float, default=2e5, help="cap per C++ search")
    ap.add_argument("--ours-max-collisions-per-particle", type=float, default=None,
                    help="cap per search of ours (default: the C++ cap; ours is cheaper per collision)")
    ap.add_argument("--stall-windows", default="default",
                    help="our stall rule: 'default' (the production value), 'none' (off) or an integer")
    ap.add_argument("--codes", nargs="*", choices=("ours", "cpp"), default=["ours", "cpp"])
    args = ap.parse_args(argv)
    if args.export_records:
        export_records(args.out, args.export_records)
        return
    if args.summarize:
        summarize(args.out)
        return
    if "cpp" in args.codes and not args.exe:
        ap.error("--exe is required to run the C++ code")
    options = {} if args.stall_windows == "default" else {
        "stall_windows": None if args.stall_windows == "none" else int(args.stall_windows)}
    given = read_packing(args.start) if args.start else None
    if given is not None:
        args.n, args.sigma = given.n, round(float(np.std(given.diameters) / np.mean(given.diameters)), 3)
        tag = hashlib.sha1(str(args.start.resolve()).encode()).hexdigest()[:8]
        cell = args.out / f"N{args.n}-start-{tag}"
    else:
        cell = args.out / f"N{args.n}-sigma{args.sigma:g}-{args.start_kind}{args.start_rate:g}"
    cell.mkdir(parents=True, exist_ok=True)
    seeds = args.seeds or list(range(args.first_seed, args.first_seed + args.pairs))
    caps = {"cpp": int(args.max_collisions_per_particle * args.n),
            "ours": int((args.ours_max_collisions_per_particle or args.max_collisions_per_particle) * args.n)}
    common = {"stall_windows": args.stall_windows, "n": args.n, "sigma": args.sigma,
              "start_kind": None if args.start else args.start_kind,
              "start_rate": None if args.start else args.start_rate,
              "initial_rate": args.initial_rate, "factor": args.factor, "final_rate": args.final_rate,
              "start_file": str(args.start) if args.start else None}
    for seed in seeds:
        folder = cell / f"pair-{seed:04d}"
        todo = [c for c in args.codes if not _done(folder / f"{c}.json", caps[c])]
        if not todo:
            continue
        start = given if given is not None else make_start(args.n, args.sigma, seed, args.start_kind,
                                                           args.start_rate)
        meta = dict(common, seed=seed, phi_start=float(start.phi))
        folder.mkdir(parents=True, exist_ok=True)
        for code in todo:
            lock = folder / f"{code}.lock"
            if not claim(lock):
                print(f"    seed {seed} {code}: another worker is on it, skipped", flush=True)
                continue
            try:
                if not _done(folder / f"{code}.json", caps[code]):  # another worker may have just finished it
                    _run_one(args, code, folder, seed, start, meta, caps[code], options)
            finally:
                lock.unlink(missing_ok=True)


def _run_one(args, code: str, folder: Path, seed: int, start, meta: dict, cap: int, options: dict) -> None:
    """One search of one pair (the C++ run, or ours), recorded in ``folder/<code>.json``."""
    print(f"[{time.strftime('%H:%M:%S')}] {folder.parent.name} seed {seed}: {code} from phi = {start.phi:.5f}",
          flush=True)
    if code == "cpp" and (folder / "cpp" / pg.NFO).is_file() and (folder / "cpp" / "log.txt").is_file():
        res = collect_cpp(folder / "cpp", nominal_density(start))  # finished, but not recorded
    elif code == "cpp":
        phi_nom = write_cpp_input(start, folder / "cpp", seed, args.initial_rate, args.factor, args.final_rate)
        res = run_cpp(args.exe, folder / "cpp", phi_nom, cap)
    else:
        warm_up()
        res = run_ours(start, seed, args.initial_rate, args.factor, args.final_rate, cap, **options)
    res.update(meta, max_collisions=cap)
    _write_json(folder / f"{code}.json", res)
    print(f"    phi_J = {res['phi_J']} stop = {res['stop']} collisions = {res['collisions']} "
          f"CPU = {res['cpu_s']:.1f} s windows = {res['windows']}", flush=True)


if __name__ == "__main__":
    sys.exit(main())
