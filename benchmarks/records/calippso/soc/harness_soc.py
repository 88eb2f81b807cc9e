# ruff: noqa
# One-off experiment harness of docs/calippso.md §10.15, kept as the provenance of the figures it measured (not
# maintained; it monkeypatches spherejam.calippso.run of commit f06ba70 and builds its input with
# benchmarks/calippso_lp_count.py). Run with PYTHONPATH=src from the repository's root.
"""Prototype: a second-order correction after each CALiPPSO step (close the LP's contacts exactly, Newton on the
isostatic network), to test whether it ends the creep. Usage: harness_soc.py N KIND RATE SEED [SOC 0/1] [MAXIT]"""
import math
import sys
import time
from pathlib import Path

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

sys.path.insert(0, "benchmarks")
import calippso_lp_count as lc  # noqa: E402

import spherejam.calippso.run as R  # noqa: E402

n, kind, rate, seed = int(sys.argv[1]), sys.argv[2], float(sys.argv[3]), int(sys.argv[4])
soc = int(sys.argv[5]) if len(sys.argv) > 5 else 1
maxit = int(sys.argv[6]) if len(sys.argv) > 6 else 400
name = f"{kind}{rate:g}-n{n}-s{seed}"
packing, _ = lc.built(name, kind, rate, n, seed, "soc_inputs")

stash = {}
orig_check, orig_step = R._check, R._step
stats = []


def check(lp, sol, loop, cfg):
    out = orig_check(lp, sol, loop, cfg)
    stash.update(out=out, loop=loop)
    return out


def step(x, dia, sol, lp, cfg, iteration):
    x1, dia1, sq, corr = orig_step(x, dia, sol, lp, cfg, iteration)
    if not soc:
        return x1, dia1, sq, corr
    contact, rattler, n_contacts, isostatic, _, _ = stash["out"]
    held = getattr(sol, "held", None)
    if not isostatic or (held is not None and np.any(held)):
        stats.append((iteration, "skip"))
        return x1, dia1, sq, corr
    dim = cfg.dim
    pi, pj = lp.pi, lp.pj
    c = np.flatnonzero(contact & ~rattler[pi] & ~rattler[pj])
    s = sol.s
    r = lp.rij[c] + s[pi[c]] - s[pj[c]]
    sig = 0.5 * (dia1[pi[c]] + dia1[pj[c]])
    g = np.einsum("ij,ij->i", r, r) - sig**2
    free = np.repeat(~rattler[:cfg.n], dim)
    from spherejam.calippso.constraints import as_pins
    free[as_pins(R._pins(stash["loop"], cfg), cfg.n, dim).columns] = False
    col = np.full(cfg.n * dim, -1)
    col[free] = np.arange(free.sum())
    nu = int(free.sum()) + 1
    if c.size != nu:
        stats.append((iteration, f"not square {c.size} {nu}"))
        return x1, dia1, sq, corr
    rows, cols, vals = [], [], []
    for k in range(dim):
        ci = col[pi[c] * dim + k]
        cj = col[pj[c] * dim + k]
        m = ci >= 0
        rows.append(np.arange(c.size)[m]); cols.append(ci[m]); vals.append(2 * r[m, k])
        m = cj >= 0
        rows.append(np.arange(c.size)[m]); cols.append(cj[m]); vals.append(-2 * r[m, k])
    rows.append(np.arange(c.size)); cols.append(np.full(c.size, nu - 1)); vals.append(-(sig**2))
    A = sp.csc_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))), shape=(c.size, nu))
    t = time.process_time()
    try:
        u = spla.spsolve(A, -g)
    except Exception as e:
        stats.append((iteration, f"solve failed {e}"))
        return x1, dia1, sq, corr
    lam = float(u[-1])
    delta = np.zeros(cfg.n * dim)
    delta[free] = u[:-1]
    delta = delta.reshape(cfg.n, dim)
    dmax = float(np.max(np.abs(delta))) / float(dia1.max())
    if not np.all(np.isfinite(u)) or lam <= 0 or dmax > 1e-5:
        stats.append((iteration, f"reject lam {lam:.2e} dmax {dmax:.2e}"))
        return x1, dia1, sq, corr
    x2 = R._moved(x1, delta, cfg)
    dia2 = dia1 * math.sqrt(1 + lam)
    h = R._closest(x2, dia2, cfg)
    if h < 1:
        dia2 = dia2 * h
    gain = math.sqrt(1 + lam) * min(h, 1.0)
    stats.append((iteration, f"soc lam {lam:.2e} h-1 {h - 1:.2e} gain {gain - 1:.2e} dmax {dmax:.2e} g {g.max():.2e} cpu {time.process_time() - t:.2f}"))
    if gain <= 1:
        return x1, dia1, sq, corr
    return x2, dia2, sq, corr


R._check, R._step = check, step
t0 = time.process_time()
res = R.run_calippso(packing, max_iterations=maxit, lp_log=f"{name}.soc{soc}.lps.csv",
                     progress_interval=1e9)
cpu = time.process_time() - t0
for s_ in stats:
    print("SOC", *s_)
h = res.history
print(f"{name} soc={soc}: stop {res.stop_reason} LPs {res.iterations} phi {res.packing.phi:.10f} cpu {cpu:.1f}")
for k in range(len(h["phi"])):
    print(f"  LP {k+1}: sqrtG-1 {h['sqrt_inflation_minus_1'][k]:.3e} max|s| {h['max_displacement'][k]:.3e} phi {h['phi'][k]:.10f} iso {h['isostatic'][k]}")
