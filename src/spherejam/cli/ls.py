"""``spherejam ls``: Lubachevsky–Stillinger compression; its options and output are shared by ``spherejam mls``."""

from __future__ import annotations

from pathlib import Path

from ..core.errors import InputError
from ..core.output_paths import check_outputs, output_file
from ..core.validation import (
    EVENTS_PER_PARTICLE,
    FIELDS,
    INTERVAL,
    LS_RATE,
    MAX_COLLISIONS,
    SECONDS,
    UNIT_OPEN,
)
from . import seed_int
from .stale_checkpoint import add_option as add_stale_checkpoint_option
from .stale_checkpoint import run_discarding_stale


def _ls_rate(text: str) -> float:
    """An LS rate: 0 (equilibrate only) or inside the limits of :data:`spherejam.core.validation.LS_RATE`."""
    try:
        if float(text) == 0.0:
            return 0.0
    except ValueError:
        pass
    return LS_RATE.arg(text)


def add_event_driven_options(p) -> None:
    """The options of both event-driven commands, ``ls`` and ``mls`` (the paper's modified LS)."""
    p.add_argument("input", type=Path, help="start packing (.h5): Poisson, LS, FB, ...")
    p.add_argument("-o", "--output", type=output_file, required=True, help="output packing file (.h5)")
    p.add_argument("--p-max", type=FIELDS["ls.p_max"].arg, default=1e12,
                   help="reduced-pressure threshold, 1 < p_max <= 1e15 (default 1e12)")
    p.add_argument("--seed", type=seed_int, default=0, help="seed of the initial velocities (default 0)")
    p.add_argument("--events-per-particle", type=EVENTS_PER_PARTICLE.arg, default=20,
                   help="window length in events per particle, 1 ... 10^6 (default 20)")
    p.add_argument("--count-collisions", action="store_true",
                   help="count only collisions towards the window length (default: all events, as the reference)")
    p.add_argument("--max-wall-time", type=SECONDS.arg, default=None,
                   help="stop after this many seconds of this call (> 0); the checkpoint is kept, so a rerun continues")
    p.add_argument("--checkpoint", type=output_file, default=None,
                   help="checkpoint file: saved periodically, resumed from if present, removed when done")
    p.add_argument("--checkpoint-interval", type=INTERVAL.arg, default=300.0,
                   help="seconds between checkpoints, 0 = every window (default 300)")
    add_stale_checkpoint_option(p)
    p.add_argument("--progress-interval", type=INTERVAL.arg, default=10.0,
                   help="seconds between progress lines, 0 = every window (default 10)")


def register(sub) -> None:
    p = sub.add_parser("ls", help="compress with the Lubachevsky-Stillinger algorithm until p >= p_max")
    add_event_driven_options(p)
    p.add_argument("--rate", type=_ls_rate, required=True,
                   help="compression rate gamma = d rho/dt: 1e-8 ... 1e3, or 0 with a stop option")
    p.add_argument("--target-phi", type=UNIT_OPEN.arg, default=None, help="stop at this packing fraction")
    p.add_argument("--max-collisions", type=MAX_COLLISIONS.arg, default=None,
                   help="stop after this many collisions")
    p.set_defaults(func=_ls)


def engine_options(args) -> dict:
    """The engine keywords of the shared options (for ``run_ls`` and ``find_closest_jamming`` alike)."""
    return {
        "p_max": args.p_max, "seed": args.seed, "events_per_particle": args.events_per_particle,
        "count_collisions_only": args.count_collisions, "max_wall_time": args.max_wall_time,
        "checkpoint": args.checkpoint, "checkpoint_interval": args.checkpoint_interval,
        "progress_interval": args.progress_interval,
    }


def check_paths(args) -> None:
    check_outputs({"-o/--output": args.output}, inputs={"input": args.input}, also={"--checkpoint": args.checkpoint})


def finish(args, result, label: str) -> int:
    """Write the result packing (with its history) and print its one-line summary."""
    from ..core.packing_io import write_packing

    write_packing(args.output, result.packing, history=result.history)
    c = result.stats
    print(f"{args.output}: {label} phi={result.packing.phi:.6f} p={result.packing.metadata['reduced_pressure']:.4g} "
          f"windows={c.steps} collisions={c.collisions} wall={c.wall_time:.1f}s stop={c.stop_reason}")
    return 0


def _ls(args) -> int:
    from ..core.packing_io import read_packing
    from ..engines.lubachevsky_stillinger import run_ls

    if args.rate == 0 and args.target_phi is None and args.max_collisions is None and args.max_wall_time is None:
        raise InputError("--rate=0: never reaches p_max; give --max-collisions, --target-phi or --max-wall-time")
    check_paths(args)
    packing = read_packing(args.input)
    result = run_discarding_stale(args, lambda: run_ls(
        packing, args.rate, target_phi=args.target_phi, max_collisions=args.max_collisions, **engine_options(args)))
    return finish(args, result, "LS")
