"""``spherejam calippso``: jam a packing by iterative linear programming and certify it (contacts, forces)."""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from ..core.calippso_path import INTERIOR_STEPS_MIN_N
from ..core.output_paths import check_outputs, output_file
from ..core.validation import CALIPPSO_ITERATIONS, LP_SOLVERS, THREADS
from . import EXIT_FAILED, finite_float
from .stale_checkpoint import add_option as add_stale_checkpoint_option
from .stale_checkpoint import run_discarding_stale


def register(sub) -> None:
    p = sub.add_parser("calippso", help="jam a packing with CALiPPSO (iterative LP, HiGHS) and report its forces",
                       description="Exit status: 0 converged, 1 not converged within --max-iterations (the output "
                       "is written all the same, marked converged False), 2 bad input.")
    p.add_argument("path", type=Path, help="input packing file (.h5), overlap-free")
    p.add_argument("-o", "--output", type=output_file, required=True, help="output packing file (.h5)")
    p.add_argument("--max-iterations", type=CALIPPSO_ITERATIONS.arg, default=1000, help="iteration cap (1000)")
    p.add_argument("--inflation-tolerance", type=finite_float, default=1e-12,
                   help="tolerance on sqrt(Gamma)-1, Gamma the LP's inflation factor (1e-12)")
    p.add_argument("--displacement-tolerance", type=finite_float, default=1e-9,
                   help="max |s| of non-rattlers, units of the largest diameter (1e-9)")
    p.add_argument("--cutoff", type=finite_float, default=None,
                   help="regime-1 cutoff l0, units of the initial largest diameter (default 2 = 4 radii)")
    p.add_argument("--solver", choices=("auto", *LP_SOLVERS), default="auto",
                   help="HiGHS solver of a cold LP: auto (default: hipo from N = 4096 on, else ipx), hipo "
                        "(sparse-direct interior point), ipx, simplex")
    p.add_argument("--threads", type=THREADS.arg, default=1,
                   help="threads of HiGHS and HiPO's BLAS, 1 ... 256 (1: workflow jobs get one core each)")
    p.add_argument("--crossover", action=argparse.BooleanOptionalAction, default=None,
                   help="cross over after every interior point, or certify its active set and cross over only "
                        "when that fails (default: certify with hipo, cross over with ipx)")
    p.add_argument("--constraint-generation", action="store_true",
                   help="solve each HiGHS LP over the rows that can close first, then add the violated others "
                        "(docs/calippso.md 5.7); the certificate is the same")
    p.add_argument("--schedule", choices=("adaptive", "reference", "trust"), default="adaptive",
                   help="bounds schedule: adaptive (default: first regime from the input's gaps, a bound that stops "
                        "a stable particle widened) or reference (CALiPPSO.jl's: a loose first LP, the regimes of "
                        "the previous sqrt(Gamma) alone, no widening) or trust (adaptive, with s_bound capped at "
                        "30 sqrt(sqrt(Gamma)-1) R and the cutoff shrunk with it); docs/calippso.md 10")
    p.add_argument("--interior-steps", action=argparse.BooleanOptionalAction, default=None,
                   help="step from the interior point (no vertex, no crossover) while sqrt(Gamma)-1 > 1e-9; the "
                        "final LPs and the force LP take vertices (default: "
                        + (f"from N = {INTERIOR_STEPS_MIN_N} on" if INTERIOR_STEPS_MIN_N else "off")
                        + "; --no-interior-steps: every LP a vertex; docs/calippso.md 10.11)")
    p.add_argument("--lp-log", type=output_file, default=None,
                   help="write one CSV row per LP here (sqrt(Gamma)-1, max |s|, bounds, contacts gained and lost, "
                        "solver path, CPU and wall s), flushed after each LP; a resumed run rewrites it from its "
                        "checkpoint and continues it")
    p.add_argument("--checkpoint", type=output_file, default=None, help="checkpoint file (resume if it exists)")
    add_stale_checkpoint_option(p)
    p.add_argument("--require-convergence", action="store_true",
                   help="stop with an error and write nothing if not converged (without it an unconverged run "
                        "still writes its output, reports converged False and exits 1)")
    p.add_argument("--json", action="store_true", help="print the summary as JSON")
    p.add_argument("--summary", type=output_file, default=None,
                   help="also write the summary (scalars and power-law fits) to this JSON file")
    p.set_defaults(func=_calippso)


def _calippso(args) -> int:
    from ..analysis.distributions import contact_arrays, distributions
    from ..calippso.run import run_calippso
    from ..core.atomic import atomic_output
    from ..core.packing_io import read_packing, write_packing

    check_outputs({"-o/--output": args.output, "--summary": args.summary, "--lp-log": args.lp_log},
                  inputs={"path": args.path},
                  also={"--checkpoint": args.checkpoint})
    packing = read_packing(args.path)
    result = run_discarding_stale(args, lambda: run_calippso(
        packing, max_iterations=args.max_iterations, inflation_tolerance=args.inflation_tolerance,
        displacement_tolerance=args.displacement_tolerance, cutoff=args.cutoff, checkpoint=args.checkpoint,
        require_convergence=args.require_convergence, solver=args.solver, threads=args.threads,
        crossover=args.crossover, constraint_generation=args.constraint_generation, schedule=args.schedule,
        interior_steps=args.interior_steps, lp_log=args.lp_log,
    ))
    summary = {"input": str(args.path), "output": str(args.output), **result.summary()}
    if result.completed:
        summary.update(distributions(result))
    if args.summary:
        with atomic_output(args.summary, ".json") as tmp:
            tmp.write_text(json.dumps(summary, indent=2, allow_nan=True))
    write_packing(args.output, result.packing, history=result.history, groups={"contacts": contact_arrays(result)})
    if result.stop_reason == "no_force_network":
        from ..calippso.run import no_force_network_message

        sys.stderr.write(f"spherejam calippso: {no_force_network_message(result)}\n")
    if args.json:
        print(json.dumps(summary, indent=2))
    else:
        print(f"{args.output}: phi {result.phi:.10f} (input {result.phi_initial:.10f}), {result.iterations} "
              f"iterations, converged {result.completed}, contacts {result.n_contacts}, rattlers "
              f"{result.n_rattlers}, isostatic {result.isostatic}, force balance {result.force_balance_residual:.2e}")
    return 0 if result.completed else EXIT_FAILED
