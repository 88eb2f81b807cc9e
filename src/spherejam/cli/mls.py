"""``spherejam mls``: the closest-jamming search, the paper's modified LS (MLS) (docs/algorithms.md)."""

from __future__ import annotations

from ..core.validation import FIELDS, check_mls
from .ls import add_event_driven_options, check_paths, engine_options, finish
from .stale_checkpoint import run_discarding_stale


def register(sub) -> None:
    p = sub.add_parser("mls", help="closest jammed configuration: the paper's modified LS (MLS) search")
    add_event_driven_options(p)
    p.add_argument("--initial-rate", type=FIELDS["mls.initial_rate"].arg, default=10.0,
                   help="first compression rate, 1e-8 ... 1e3 (default 10)")
    p.add_argument("--decrease-factor", type=FIELDS["mls.decrease_factor"].arg, default=2.0,
                   help="rate divisor per stage, 1 < f <= 100 (default 2)")
    p.add_argument("--final-rate", type=FIELDS["mls.final_rate"].arg, default=1e-4,
                   help="termination rate, <= the initial rate (default 1e-4)")
    p.add_argument("--max-equilibration-windows", type=FIELDS["mls.max_equilibration_windows"].arg, default=50,
                   help="zero-rate windows with p >= p_max that mean 'jammed' (default 50)")
    stall = p.add_mutually_exclusive_group()
    stall.add_argument("--stall-windows", type=FIELDS["mls.stall_windows"].arg, default=None,
                       help="compression windows with p >= p_max/10 flat within 10%% that end a stage as if p_max "
                            "were reached (double-precision floor; default 1000)")
    stall.add_argument("--no-stall-rule", action="store_true",
                       help="the paper's rule exactly: a stage ends only at p >= p_max")
    p.add_argument("--max-collisions-per-particle", type=FIELDS["mls.max_collisions_per_particle"].arg, default=None,
                   help="cut the search after this many collisions per particle (deterministic; default: no cut)")
    p.set_defaults(func=_mls)


def _mls(args) -> int:
    from ..core.packing_io import read_packing
    from ..engines.closest_jamming import DEFAULT_STALL_WINDOWS, find_closest_jamming

    check_mls(args.initial_rate, args.decrease_factor, args.final_rate,
              ("--initial-rate", "--decrease-factor", "--final-rate"))
    check_paths(args)
    packing = read_packing(args.input)
    max_collisions = None
    if args.max_collisions_per_particle is not None:
        max_collisions = max(1, int(round(args.max_collisions_per_particle * packing.n)))
    result = run_discarding_stale(args, lambda: find_closest_jamming(
        packing, initial_rate=args.initial_rate, decrease_factor=args.decrease_factor, final_rate=args.final_rate,
        max_equilibration_windows=args.max_equilibration_windows, max_collisions=max_collisions,
        stall_windows=None if args.no_stall_rule else (args.stall_windows or DEFAULT_STALL_WINDOWS),
        **engine_options(args),
    ))
    return finish(args, result, f"MLS stages={result.stats.extras.stages}")
