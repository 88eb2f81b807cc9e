"""CALiPPSO with the reference's solver tolerances, mapped to our units (issue 46; docs/calippso.md §10.13).

    python benchmarks/calippso_reference_tolerances.py FIXTURE.h5 --out NAME [--max-iterations 80]

CALiPPSO.jl solves its LPs with Gurobi at FeasibilityTol = OptimalityTol = 1e-9, absolute, in the units of its input:
a box of side L = 1, where the diameter sigma_L = D / L is 0.042 at N = 16384. Our LP's rows are lengths squared and
its unit is the largest diameter D, so the reference's row tolerance is 1e-9 / sigma_L^2 in our units (2.2e-7 at
N = 4096, 5.6e-7 at N = 16384), and its reduced-cost tolerance (1 / length) 1e-9 sigma_L, below HiGHS's floor of
1e-10. This run uses those tolerances, the reference's bounds schedule and its solver path (an interior point with
crossover, a fresh model per LP, no active-set shortcut), so that it can be compared LP by LP with a strict run of
the same input (``spherejam calippso FIXTURE.h5 --schedule reference --lp-log ...``).

An experiment, not a mode of the package: with rows allowed to be violated by up to 10 times the row tolerance, a
step may overlap by more than the driver's round-off guard (``calippso.run.MAX_OVERLAP_CORRECTION``), which is
raised here so that the run records such corrections (the LP log's ``overlap_correction``) instead of stopping.
"""

from __future__ import annotations

import argparse
import json
import sys

import numpy as np


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("fixture", help="input packing (.h5), a periodic cube")
    ap.add_argument("--out", required=True, help="name of the outputs: NAME.ckpt.h5 (resumable), NAME.lps.csv")
    ap.add_argument("--max-iterations", type=int, default=80)
    args = ap.parse_args(argv)

    import spherejam.calippso.run as run
    from spherejam.core.packing_io import read_packing

    packing = read_packing(args.fixture)
    side = packing.require_cube("the reference's tolerances in box units")
    sigma_l = float(np.max(packing.diameters)) / float(side)
    primal = 1e-9 / sigma_l**2
    dual = max(1e-10, 1e-9 * sigma_l)
    run.MAX_OVERLAP_CORRECTION = 1e-5
    print(f"N = {packing.n}, sigma/L = {sigma_l:.4g}: row tolerance {primal:.3g}, reduced-cost tolerance {dual:.3g}",
          flush=True)
    result = run.run_calippso(
        packing, solver="ipx", crossover=True, active_set=False, warm_start=False, schedule="reference",
        interior_steps=False, solver_tolerance=min(primal, 1e-5),
        solver_options={"primal_feasibility_tolerance": primal, "dual_feasibility_tolerance": dual,
                        "ipm_optimality_tolerance": 1e-8},
        max_iterations=args.max_iterations, checkpoint=f"{args.out}.ckpt.h5", lp_log=f"{args.out}.lps.csv",
        progress_interval=60.0)
    print(json.dumps(result.summary(), default=float, indent=1), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
