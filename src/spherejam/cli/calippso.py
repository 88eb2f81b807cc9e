"""``spherejam calippso``: jam a packing by iterative linear programming and certify it (contacts, forces)."""

from __future__ import annotations

import json
from pathlib import Path

from . import EXIT_FAILED, finite_float, int_at_least


def register(sub) -> None:
    p = sub.add_parser("calippso", help="jam a packing with CALiPPSO (iterative LP, HiGHS) and report its forces")
    p.add_argument("path", type=Path, help="input packing file (.h5), overlap-free")
    p.add_argument("-o", "--output", type=Path, required=True, help="output packing file (.h5)")
    p.add_argument("--max-iterations", type=int_at_least(1), default=1000, help="iteration cap (1000)")
    p.add_argument("--gamma-tolerance", type=finite_float, default=1e-12, help="sqrt(Gamma)-1 tolerance (1e-12)")
    p.add_argument("--displacement-tolerance", type=finite_float, default=1e-9,
                   help="max |s| of non-rattlers, units of the largest diameter (1e-9)")
    p.add_argument("--cutoff", type=finite_float, default=None,
                   help="regime-1 cutoff l0, units of the initial largest diameter (default 2 = 4 radii)")
    # the choices of calippso.SOLVERS, not imported here: it loads numba, and `spherejam --help` should stay fast
    p.add_argument("--solver", choices=("hipo", "ipx", "simplex"), default="hipo",
                   help="HiGHS solver of a cold LP: hipo (sparse-direct interior point, default), ipx, simplex")
    p.add_argument("--threads", type=int_at_least(1), default=1,
                   help="threads of HiGHS and HiPO's BLAS (1: workflow jobs get one core each)")
    p.add_argument("--crossover", action="store_true",
                   help="always cross over after an interior point (default: certify its active set instead)")
    p.add_argument("--checkpoint", type=Path, default=None, help="checkpoint file (resume if it exists)")
    p.add_argument("--require-convergence", action="store_true", help="exit 1 if not converged")
    p.add_argument("--json", action="store_true", help="print the summary as JSON")
    p.add_argument("--summary", type=Path, default=None,
                   help="also write the summary (scalars and power-law fits) to this JSON file")
    p.set_defaults(func=_calippso)


def _calippso(args) -> int:
    from ..atomic import atomic_output
    from ..calippso import contact_arrays, distributions, run_calippso
    from ..packing_io import read_packing, write_packing

    packing = read_packing(args.path)
    result = run_calippso(
        packing, max_iterations=args.max_iterations, gamma_tolerance=args.gamma_tolerance,
        displacement_tolerance=args.displacement_tolerance, cutoff=args.cutoff, checkpoint=args.checkpoint,
        require_convergence=args.require_convergence, solver=args.solver, threads=args.threads,
        crossover=args.crossover,
    )
    summary = {"input": str(args.path), "output": str(args.output), **result.summary()}
    if result.converged:
        summary.update(distributions(result))
    if args.summary:
        with atomic_output(args.summary, ".json") as tmp:
            tmp.write_text(json.dumps(summary, indent=2, allow_nan=True))
    write_packing(args.output, result.packing, history=result.history, groups={"contacts": contact_arrays(result)})
    if args.json:
        print(json.dumps(summary, indent=2))
    else:
        print(f"{args.output}: phi {result.phi:.10f} (input {result.phi_initial:.10f}), {result.iterations} "
              f"iterations, converged {result.converged}, contacts {result.n_contacts}, rattlers "
              f"{result.n_rattlers}, isostatic {result.isostatic}, force balance {result.force_balance_residual:.2e}")
    return 0 if result.converged else EXIT_FAILED
