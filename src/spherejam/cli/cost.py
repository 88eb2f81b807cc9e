"""``spherejam cost``: expected jobs, CPU-hours and SLURM time limits of a workflow config, before you submit it."""

from __future__ import annotations

from pathlib import Path


def register(sub) -> None:
    p = sub.add_parser(
        "cost", help="expected jobs, CPU-hours and time limits of a workflow config (docs/cluster.md)",
        description="Print the cost model's jobs, expected CPU-hours and requested hours (sum of the SLURM time "
        "limits, first attempts) per stage. Several configs are merged as Snakemake merges --configfile: "
        "later files override earlier ones key by key.",
    )
    p.add_argument("configs", type=Path, nargs="+", metavar="CONFIG",
                   help="config files, e.g. config/config.yaml config/paper.yaml")
    p.set_defaults(func=_cost)


def _cost(args) -> int:
    from ..core.errors import InputError
    from ..workflow.config import check_config
    from ..workflow.cost_model import load_configs, print_plan

    config = load_configs(*args.configs)  # each file through the one config loader (load_config_file)
    if "n" not in config:
        raise InputError(f"config: no 'n' (spheres per packing) in {', '.join(map(str, args.configs))}")
    check_config(config)  # the workflow's limits (finite numbers, ranges), so the plan is of a config that runs
    print_plan(config)
    return 0
