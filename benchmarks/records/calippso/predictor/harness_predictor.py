# ruff: noqa
# One-off experiment harness of docs/calippso.md §10.14, kept as the provenance of the figures it measured (not
# maintained; it monkeypatches spherejam.calippso.run of commit 4daeff5). Run from this folder with PYTHONPATH=src.
"""Experiment: linearise each row at r_ij + alpha * s_prev_ij (a valid inner approximation by convexity)."""
import sys, os, time
import numpy as np
import spherejam.calippso.run as R
from spherejam.core.packing_io import read_packing

ALPHA = float(os.environ.get("ALPHA", "1"))
state = {"s": None}
orig_solve = R._solve

def solve(lp, loop, cfg, tally, iteration):
    sp = state["s"]
    sh = None
    if ALPHA > 0 and sp is not None:
        sh = ALPHA * sp
        d = sh[lp.pi] - sh[lp.pj]
        gmin = float(np.min((np.einsum("ka,ka->k", lp.rij, lp.rij) - np.einsum("ka,ka->k", d, d)) / lp.sigma2))
        lp.rij = lp.rij + d   # the standard rows at the predicted configuration x + s_hat, for s' = s - s_hat
        lp.inflation_min = min(1.0, gmin * (1 - 1e-12))
    sol = orig_solve(lp, loop, cfg, tally, iteration)
    c = sol.duals > cfg.zero_force
    z = np.bincount(lp.pi[c], minlength=cfg.nodes) + np.bincount(lp.pj[c], minlength=cfg.nodes)
    if sh is not None:
        sol.s = sol.s + sh
    s = sol.s.copy(); s[z <= lp.rij.shape[1]] = 0.0
    state["s"] = s if np.abs(s).max() > 1e-7 and sol.inflation >= 1.0 else None
    return sol
R._solve = solve
p = read_packing(sys.argv[1])
t = time.process_time()
res = R.run_calippso(p, max_iterations=int(os.environ.get("MAXIT", "300")), active_set=False,
                     lp_log=sys.argv[2] if len(sys.argv) > 2 else None)
print("RESULT", sys.argv[1], "ALPHA", ALPHA, "LPs", res.iterations, "completed", res.completed,
      "cpu", time.process_time() - t, "contacts", res.n_contacts, "rattlers", res.n_rattlers, "phi", res.summary().get("phi_J", None))
