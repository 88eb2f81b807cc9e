"""Build the CALiPPSO benchmark inputs (docs/calippso.md §9) as packing files (kept only as unfinished runs' state).

    python benchmarks/calippso_fixtures.py                  # all of them, smallest first, into benchmarks/fixtures/
    python benchmarks/calippso_fixtures.py --only ls1024_p1e5 ls1024_p1e12
    python benchmarks/calippso_fixtures.py --list           # names and recipes

Each fixture is made by spherejam's Lubachevsky-Stillinger engine (d = 3) from a Poisson start, with the seed, the
compression rate gamma and the stop pressure of its recipe, and written through core.atomic (a half-written file
never appears). An existing file is kept, so an interrupted build continues with the next missing fixture; the LS run
itself checkpoints beside the file (``NAME.h5.ckpt``) and resumes. The inputs and checkpoints of unfinished whole
runs at N = 1e4 are kept in benchmarks/records/calippso/state/ (its README says how to resume them), since the
development machines are not kept between sittings.

- ``ls1024_p1e5``: plain LS to p = 1e5 (the reference's example inputs are LS outputs at p = 1e5; a fast one,
  whose true pressure is ~10 times lower: it creeps);
- ``lsmls1024_p1e5``: the CALiPPSO.jl-style start, LS to p = 1e5 then the MLS loop with p_max = 1e5 (rates 1e-2 ->
  1e-4), so that p = 1e5 is the packing's own pressure, as in the reference's example file (d phi_J / (p (phi_J -
  phi0)) ~ 1; the default start of bench_calippso.py);
- ``ls1024_p1e12``, ``ls1024_p1e12_s03``, ``ls2048_p1e12``: LS outputs at p = 1e12 (sigma = 0, 0.3, 0), the inputs
  on which the new LP path's certificates are compared with today's;
- ``ls10000_p1e12_s0``, ``ls10000_p1e12_s03``, ``ls16384_p1e12_s0``: LS outputs at p = 1e12 at the paper's N,
  sigma = 0 and 0.3 (sigma: relative standard deviation of the diameters); the last two at gamma = 1e-2, and
  ``ls10000_p1e12_s03_gamma1e-3`` the sigma = 0.3 one at gamma = 1e-3, as ``ls10000_p1e12_s0``;
- ``ls16384_p1e5``: the reference's own case (CALiPPSO.jl's documented N = 16384 run starts from an LS output at
  p = 1e5), LS at gamma = 1e-3, sigma = 0;
- ``ls4096_p1e5``, ``ls4096_p1e12``: the same two LS kinds (gamma = 1e-3, sigma = 0, p = 1e5 and 1e12) at N = 4096,
  where the LP path's default changes (docs/calippso.md §10.11); ``ls512_p1e12`` the p = 1e12 kind at N = 512, whose
  2 x 2 x 2 tiling (``bench_calippso.py --tile 2``) is an N = 4096 input made in minutes; ``lsmls4096_p1e5``
  ``lsmls1024_p1e5``'s recipe at N = 4096;
- ``mls10000_s0``: a true MLS output at N = 1e4, the kind of packing the workflow certifies: the paper's MLS
  (gamma 10 -> 1e-4, halved per stage, p_max = 1e12) from ``ls10000_rate0.5_s0``, a fast LS output (gamma = 0.5,
  p = 1e12), the kind of start whose closest jammed state MLS searches for. Hours of CPU; its MLS run checkpoints
  beside the file as well. (The earlier ``mls10000_p1e12_s0`` started from ``ls10000_p1e12_s0``: a slowly
  compressed output that MLS finds jammed in its first window and returns unchanged, so it was that LS output again,
  docs/calippso.md §10.12.) ``mls10000_s0_seed2`` is the same recipe with seed 2.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

#: name -> (N, sigma, LS rate gamma, stop pressure p, seed)
FIXTURES: dict[str, tuple[int, float, float, float, int]] = {
    "ls1024_p1e5": (1024, 0.0, 1e-2, 1e5, 1),
    "lsmls1024_p1e5": (1024, 0.0, 1e-2, 1e5, 1),
    "ls1024_p1e12": (1024, 0.0, 1e-3, 1e12, 1),
    "ls1024_p1e12_s03": (1024, 0.3, 1e-3, 1e12, 1),
    "ls2048_p1e12": (2048, 0.0, 1e-3, 1e12, 1),
    "ls10000_p1e12_s0": (10_000, 0.0, 1e-3, 1e12, 1),
    # gamma = 1e-2: on a 2-core machine shared four ways, gamma = 1e-3 took ~50 min at N = 1e4
    "ls10000_p1e12_s03": (10_000, 0.3, 1e-2, 1e12, 1),
    # the sigma = 0.3 input at the sigma = 0 input's rate: gamma = 1e-2 left it ~1e-5 from its LP-jammed state in
    # sqrt(Gamma) - 1, ~150 times farther than gamma = 1e-3 (docs/calippso.md §9)
    "ls10000_p1e12_s03_gamma1e-3": (10_000, 0.3, 1e-3, 1e12, 1),
    "ls16384_p1e12_s0": (16_384, 0.0, 1e-2, 1e12, 1),
    # the reference's own case (issue 46): LS at N = 16384, sigma = 0, to p = 1e5; gamma = 1e-3 so that the
    # packing's true pressure is near its stop pressure (at gamma = 1e-2 it is ~10 times lower and creeps, §9)
    "ls16384_p1e5": (16_384, 0.0, 1e-3, 1e5, 1),
    # the two LS kinds at N = 4096, the smallest N where every LP is a HiPO solve (issue 46: the default path against
    # interior steps on whole runs, docs/calippso.md §10.11)
    "ls4096_p1e5": (4096, 0.0, 1e-3, 1e5, 1),
    "ls4096_p1e12": (4096, 0.0, 1e-3, 1e12, 1),
    # lsmls1024_p1e5's recipe at N = 4096 (LS, then MLS at p_max = 1e5: p = 1e5 is the packing's own pressure),
    # the kind of start that certifies in 9-18 LPs at N = 1024 (docs/calippso.md §10.13)
    "lsmls4096_p1e5": (4096, 0.0, 1e-2, 1e5, 1),
    # tiled 2 x 2 x 2 (bench_calippso.py --tile 2): an N = 4096 input in minutes, where ls4096_p1e12 takes an hour
    "ls512_p1e12": (512, 0.0, 1e-3, 1e12, 1),
    # the MLS fixture's start: fast LS, far from its closest jammed state (the parity starts, docs/mls_parity.md §6)
    "ls10000_rate0.5_s0": (10_000, 0.0, 0.5, 1e12, 1),
    # the same start with another seed: the second N = 1e4 MLS output, on which the cost model's LP count is
    # validated (docs/calippso.md §10.17)
    "ls10000_rate0.5_s0_seed2": (10_000, 0.0, 0.5, 1e12, 2),
}
#: name -> the LS fixture its MLS search starts from (the paper's MLS parameters, the workflow's defaults)
MLS_FIXTURES: dict[str, str] = {"mls10000_s0": "ls10000_rate0.5_s0", "mls10000_s0_seed2": "ls10000_rate0.5_s0_seed2"}
DEFAULT_DIR = Path(__file__).resolve().parent / "fixtures"


def fixture_path(name: str, directory: Path = DEFAULT_DIR) -> Path:
    return Path(directory) / f"{name}.h5"


def build(name: str, directory: Path = DEFAULT_DIR) -> Path:
    """Make fixture ``name`` unless its file exists; return the file."""
    from spherejam.core.seeding import poisson_packing
    from spherejam.engines.lubachevsky_stillinger import run_ls

    path = fixture_path(name, directory)
    if path.exists():
        return path
    if name in MLS_FIXTURES:
        return _build_mls(name, directory)
    n, sigma, rate, pressure, seed = FIXTURES[name]
    path.parent.mkdir(parents=True, exist_ok=True)
    t = time.perf_counter()
    result = run_ls(poisson_packing(n, sigma, seed, dim=3), rate, p_max=pressure, seed=seed,
                    checkpoint=str(path) + ".ckpt", checkpoint_interval=120.0, progress_interval=60.0)
    if name.startswith("lsmls"):
        from spherejam.engines.closest_jamming import find_closest_jamming

        result = find_closest_jamming(result.packing, initial_rate=rate, final_rate=1e-4, p_max=pressure, seed=seed,
                                      progress_interval=60.0)
    return _write(name, path, result.packing, f"N={n} sigma={sigma} rate={rate:g}", t)


def _build_mls(name: str, directory: Path) -> Path:
    """The MLS fixture ``name``: the closest jammed state of its LS fixture (built first if missing)."""
    from spherejam.core.packing_io import read_packing
    from spherejam.engines.closest_jamming import find_closest_jamming

    source = MLS_FIXTURES[name]
    start = read_packing(build(source, directory))
    path = fixture_path(name, directory)
    t = time.perf_counter()
    result = find_closest_jamming(start, seed=FIXTURES[source][4], checkpoint=str(path) + ".ckpt",
                                  checkpoint_interval=120.0, progress_interval=60.0)
    return _write(name, path, result.packing, f"MLS of {source}", t)


def _write(name: str, path: Path, packing, recipe: str, t0: float) -> Path:
    """Write fixture ``name`` (labelled in its metadata) and say what it is and what it took."""
    from spherejam.core.packing_io import write_packing

    packing.metadata["fixture"] = name
    write_packing(path, packing)
    print(f"{name}: {recipe} p={packing.metadata.get('reduced_pressure'):.3g} phi={packing.phi:.8f} in "
          f"{time.perf_counter() - t0:.0f} s -> {path}", flush=True)
    return path


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--only", nargs="+", choices=sorted({**FIXTURES, **MLS_FIXTURES}), help="build only these")
    ap.add_argument("--dir", type=Path, default=DEFAULT_DIR, help=f"output folder ({DEFAULT_DIR})")
    ap.add_argument("--list", action="store_true", help="print the recipes and exit")
    args = ap.parse_args(argv)
    if args.list:
        for name, (n, sigma, rate, p, seed) in FIXTURES.items():
            state = "built" if fixture_path(name, args.dir).exists() else "missing"
            print(f"{name:20s} N={n:6d} sigma={sigma:.1f} LS rate {rate:g} to p = {p:g}, seed {seed}: {state}")
        for name, source in MLS_FIXTURES.items():
            state = "built" if fixture_path(name, args.dir).exists() else "missing"
            print(f"{name:20s} the paper's MLS from {source}: {state}")
        return 0
    import logging

    logging.basicConfig(level=logging.INFO, format="%(message)s")
    for name in args.only or [*FIXTURES, *MLS_FIXTURES]:
        build(name, args.dir)
    return 0


if __name__ == "__main__":
    sys.exit(main())
