"""``spherejam fb``: run the force-biased algorithm on a packing file (usually a Poisson packing)."""

from __future__ import annotations

import sys
from pathlib import Path

from ..core.output_paths import check_outputs, output_file
from ..core.validation import FB_ITERATIONS, FIELDS, INTERVAL, SECONDS
from . import EXIT_FAILED
from .stale_checkpoint import add_option as add_stale_checkpoint_option
from .stale_checkpoint import run_discarding_stale


def register(sub) -> None:
    p = sub.add_parser(
        "fb",
        help="force-biased packing generation (Bezrukov et al.) at contraction rate gamma",
        description="Run the force-biased algorithm from INPUT until the outer diameter meets the inner one; "
        "write the packing at its inner (actual) diameters, with the per-iteration history.",
    )
    p.add_argument("input", type=Path, help="start packing (.h5), e.g. from `spherejam seed`")
    p.add_argument("--rate", type=FIELDS["fb.rates[]"].arg, required=True,
                   help="contraction rate gamma, 1e-9 <= gamma < 1")
    p.add_argument(
        "--phi-nominal", type=FIELDS["fb.phi_nominal"].arg, default=None,
        help="nominal density (default: the paper's rule, 0.6 at gamma=1e-3, 0.7 at 1e-7, linear in ln gamma)",
    )
    p.add_argument("-o", "--output", type=output_file, required=True, help="output packing file (.h5)")
    p.add_argument("--checkpoint", type=output_file, help="checkpoint file: resumed from if present")
    p.add_argument("--checkpoint-interval", type=INTERVAL.arg, default=300.0,
                   help="seconds, 0 = every iteration (default 300)")
    add_stale_checkpoint_option(p)
    p.add_argument("--max-iterations", type=FB_ITERATIONS.arg,
                   help="stop after this many iterations; the unfinished packing is written (completed false, exit 1)")
    p.add_argument("--max-wall-time", type=SECONDS.arg,
                   help="stop after this many seconds of this call (> 0); the checkpoint is kept, so a rerun continues")
    p.add_argument("--progress-interval", type=INTERVAL.arg, default=10.0,
                   help="seconds, 0 = every iteration (default 10)")
    p.set_defaults(func=_fb)


def _fb(args) -> int:
    from ..core.packing_io import read_packing, write_packing
    from ..engines.force_biased import run_fb

    check_outputs({"-o/--output": args.output}, inputs={"input": args.input}, also={"--checkpoint": args.checkpoint})
    start = read_packing(args.input, tolerance=None)  # FB accepts overlapping starts
    result = run_discarding_stale(args, lambda: run_fb(
        start, args.rate, phi_nominal=args.phi_nominal, max_iterations=args.max_iterations,
        max_wall_time=args.max_wall_time, checkpoint=args.checkpoint,
        checkpoint_interval=args.checkpoint_interval, progress_interval=args.progress_interval,
    ))
    c = result.stats
    if c.stop_reason == "max_wall_time":
        # no output: Snakemake would take it for the result; the kept checkpoint lets a rerun continue
        where = f"; rerun to resume from the checkpoint {args.checkpoint}" if args.checkpoint else ""
        sys.stderr.write(f"spherejam fb: stopped by --max-wall-time after {c.steps} iterations (phi_inner "
                         f"{c.phi_final:.6f}), no output written{where}\n")
        return EXIT_FAILED
    write_packing(args.output, result.packing, result.history)
    if not c.completed:  # as calippso --max-iterations: the unfinished packing, marked completed false, exit 1
        sys.stderr.write(f"spherejam fb: stopped by --max-iterations after {c.steps} iterations (phi_inner "
                         f"{c.phi_final:.6f}) before the outer diameter met the inner one; wrote the unfinished "
                         f"packing to {args.output} (counters: completed false)\n")
        return EXIT_FAILED
    print(f"{args.output}: N={result.packing.n} phi={result.packing.phi:.6f} "
          f"iterations={c.steps} wall={c.wall_time:.2f}s")
    return 0
