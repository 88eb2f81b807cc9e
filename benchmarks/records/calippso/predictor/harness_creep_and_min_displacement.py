# ruff: noqa
# One-off experiment harness of docs/calippso.md §10.14, kept as the provenance of the figures it measured (not
# maintained; it monkeypatches spherejam.calippso.run of commit 4daeff5). Run from this folder with PYTHONPATH=src.
"""Experiment: a second LP per step that minimises sum |s| over the optimal face (Gamma >= 1 + (1-theta)(Gamma*-1))."""
import sys, time, json, math
import numpy as np
sys.path.insert(0, str(__import__("pathlib").Path(__file__).resolve().parents[3]))  # benchmarks/
from bench_calippso import ls_start
import spherejam.calippso.run as R
from spherejam.calippso.constraints import constraint_rows
from spherejam.calippso.highs import highs_model
from spherejam.calippso.constraints import as_pins
import highspy

SOLVER2 = __import__("os").environ.get("SOLVER2", "ipx")
THETA = float(sys.argv[4]) if len(sys.argv) > 4 else -1
orig = R._solve
stats = []

def min_disp(lp, sol, loop, cfg):
    n, dim = cfg.nodes, lp.rij.shape[1]
    start, index, value, rhs = constraint_rows(lp.rij, lp.sigma2, lp.pi, lp.pj, n)
    m = len(rhs)
    # columns: u (n dim), v (n dim), Gamma ; s = u - v
    nd = n * dim
    nnz_row = 2 * dim + 1
    idx = index.reshape(m, nnz_row); val = value.reshape(m, nnz_row)
    new_idx = np.concatenate([idx[:, :2*dim], idx[:, :2*dim] + nd, np.full((m, 1), 2*nd)], axis=1).astype(np.int32)
    new_val = np.concatenate([val[:, :2*dim], -val[:, :2*dim], val[:, 2*dim:]], axis=1)
    new_start = (np.arange(m + 1) * (4*dim + 1)).astype(np.int32)
    cost = np.concatenate([np.ones(2*nd), [0.0]])
    lower = np.zeros(2*nd + 1); upper = np.full(2*nd + 1, lp.s_bound)
    fixed = as_pins(R._pins(loop, cfg), n, dim).columns
    upper[fixed] = 0; upper[nd + fixed] = 0
    g = sol.inflation
    lower[-1] = max(lp.inflation_min, 1.0 + (1.0 - THETA) * (g - 1.0)) if g > 1 else g
    upper[-1] = lp.inflation_max
    model = highs_model(cost, lower, upper, np.full(m, -np.inf), rhs, new_start, new_idx.ravel(), new_val.ravel())
    h = highspy.Highs(); h.setOptionValue("output_flag", False)
    for k, v in {"primal_feasibility_tolerance": 1e-10, "dual_feasibility_tolerance": 1e-10}.items():
        h.setOptionValue(k, v)
    h.setOptionValue("solver", SOLVER2); h.passModel(model)
    t = time.process_time()
    h.run()
    st = h.getModelStatus()
    x = np.asarray(h.getSolution().col_value)
    s2 = (x[:nd] - x[nd:2*nd]).reshape(n, dim)
    # check rows
    r = rhs - (np.einsum('ka,ka->k', -2*lp.rij, s2[lp.pi] - s2[lp.pj]) + lp.sigma2 * x[-1])
    ok = st == highspy.HighsModelStatus.kOptimal and r.min() > -1e-12
    stats.append(dict(it=len(stats)+1, g1=g-1, g2=x[-1]-1, s1=float(np.abs(sol.s).max()), s2=float(np.abs(s2).max()),
                      cpu2=time.process_time()-t, ok=bool(ok), minrow=float(r.min())))
    print(stats[-1], flush=True)
    if ok:
        sol.s = s2.copy(); sol.inflation = float(x[-1])
    return sol

PREV = None
def analyse(lp, sol, cfg):
    n, dim = cfg.nodes, lp.rij.shape[1]
    c = sol.duals > 1e-10
    z = np.bincount(lp.pi[c], minlength=n) + np.bincount(lp.pj[c], minlength=n)
    a = np.abs(sol.s).max(axis=1)
    stable = z > dim
    q = np.quantile(a[stable], [0.5, 0.9, 0.99, 0.999])
    top = np.argsort(a * stable)[::-1][:8]
    global PREV
    sm = sol.s[stable].mean(axis=0)
    cur = sol.s - sm
    if PREV is not None:
        both = stable & PREV[1]
        a1, a2 = PREV[0][both].ravel(), cur[both].ravel()
        print("  COS %.3f  |s|2 ratio %.3f" % (a1 @ a2 / np.linalg.norm(a1) / np.linalg.norm(a2), np.linalg.norm(a2) / np.linalg.norm(a1)))
    PREV = (cur.copy(), stable.copy())
    b = np.abs(sol.s - sm).max(axis=1)
    print("  MEAN s %s  |s-mean| q50 %.1e q99 %.1e max %.1e" % (np.array2string(sm, precision=2), *np.quantile(b[stable], [0.5, 0.99]), b[stable].max()))
    print("ANALYSE g-1 %.2e q50 %.1e q90 %.1e q99 %.1e q999 %.1e max %.1e | top z %s | n>1e-4 %d n>1e-5 %d zhist %s" % (
        sol.inflation - 1, *q, a[stable].max(), z[top].tolist(), (a[stable] > 1e-4).sum(), (a[stable] > 1e-5).sum(),
        np.bincount(z[stable])[3:8].tolist()), flush=True)

def patched(lp, loop, cfg, tally, iteration):
    sol = orig(lp, loop, cfg, tally, iteration)
    if THETA >= 0:
        sol = min_disp(lp, sol, loop, cfg)
    if os.environ.get("ANALYSE"):
        analyse(lp, sol, cfg)
    return sol

R._solve = patched
n, rate, seed = int(sys.argv[1]), float(sys.argv[2]), int(sys.argv[3])
kind = sys.argv[5] if len(sys.argv) > 5 else "ls"
import os
from spherejam.core.packing_io import write_packing, read_packing
cache = f"in_{kind}{rate:g}_n{n}_s{seed}.h5"
if os.path.exists(cache):
    p = read_packing(cache)
else:
    p, _ = ls_start(n, 1e5, rate, seed, kind=kind)
    write_packing(cache, p)
t = time.process_time()
res = R.run_calippso(p, max_iterations=400, active_set=False)
print("RESULT", n, rate, seed, THETA, "LPs", res.iterations, "completed", res.completed, "phi", res.packing.phi if hasattr(res,'packing') else None,
      "cpu", time.process_time()-t, "contacts", res.n_contacts, "rattlers", res.n_rattlers)
