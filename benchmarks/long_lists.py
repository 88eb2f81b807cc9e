"""CPU time per listed pair of one re-prediction of a long neighbour list (issue 47; docs/algorithms.md §7.7): the
two-pass path (``_predict_long``) against the scalar loop (``_predict_pairs`` on the same list in pieces of at most
``LONG_LIST`` entries, carrying the running best), in one process, on a synthetic first shell: a sphere of D = 10
with ``--m`` small neighbours (D = 1) at 1.0-1.2 contact distances, moving at random, their rows scattered among
``--rows`` rows of ``st`` (``--rows`` = m + 1: contiguous). A third path, ``copy``, is the two-pass reading the
neighbours' rows from a contiguous copy in list order, laid out by field (docs/algorithms.md §7.8), instead of
gathering them from ``st``.
Every path must return the same event (checked).

    python benchmarks/long_lists.py [--m 340] [--rows 10000] [--repeats 5]
"""

from __future__ import annotations

import argparse
import time

import numpy as np
from numba import njit

from spherejam.engines.kernels import event_driven as ed


@njit(cache=True)
def _two_pass(reps, st, ev_time, nbr, nnb, x, v, di, rho, gamma, t, box, rows, base):
    s = 0.0
    for _ in range(reps):
        if base < 0:
            for kk in range(nnb[0]):  # as _predict does for a list without a copy
                ed._prefetch_row(st, nbr[0, kk])
        b = ed._predict_long(0, -1, t, x[0], x[1], x[2], v[0], v[1], v[2], di, rho, gamma, t + 1.0, ed.SKIN, -1, st,
                             ev_time, nbr, nnb, box, box, box, box / 2, box / 2, box / 2, rows, base)
        s += b[0] + b[2]
    return s


@njit(cache=True)
def _scalar(reps, st, ev_time, pieces, lens, x, v, di, rho, gamma, t, box):
    s = 0.0
    for _ in range(reps):
        for p in range(pieces.shape[0]):
            for kk in range(lens[p]):
                ed._prefetch_row(st, pieces[p, kk])
        best, kind, j = t + 1.0, ed.SKIN, -1
        for p in range(pieces.shape[0]):
            best, kind, j = ed._predict_pairs(p, -1, t, x[0], x[1], x[2], v[0], v[1], v[2], di, rho, gamma, best, kind,
                                              j, st, ev_time, pieces, lens, box, box, box, box / 2, box / 2, box / 2)
        s += best + j
    return s


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--m", type=int, default=340, help="list length (1:10, N = 1e4: ~340)")
    ap.add_argument("--rows", type=int, default=10000)
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--reps", type=int, default=20000, help="re-predictions per timing")
    a = ap.parse_args()
    rng = np.random.default_rng(0)
    m, box, t = a.m, 40.0, 1.0
    st = rng.random((a.rows, 8)) * box
    st[:, 6], st[:, 7] = 0.5, 1.0
    at = np.concatenate([[0], np.sort(rng.choice(np.arange(1, a.rows), m, replace=False))])
    n = rng.normal(size=(m, 3))
    n /= np.linalg.norm(n, axis=1)[:, None]
    st[at[0]] = (20.0, 20.0, 20.0, *rng.normal(size=3), 1.0, 10.0)
    st[at[1:], :3] = 20.0 + n * (5.5 * rng.uniform(1.0 + 1e-9, 1.2, m))[:, None]
    st[at[1:], 3:6] = rng.normal(size=(m, 3))
    st[at[1:], 6] = 1.0
    nbr = at[1:][rng.permutation(m)].astype(np.int32)[None, :].copy()
    nnb = np.array([m], dtype=np.int32)
    k = ed.LONG_LIST
    pieces = np.zeros((-(-m // k), k), dtype=np.int32)
    lens = np.zeros(len(pieces), dtype=np.int32)
    for p in range(len(pieces)):
        part = nbr[0, p * k:(p + 1) * k]
        pieces[p, :len(part)], lens[p] = part, len(part)
    ev_time = t + rng.exponential(0.01, a.rows)
    x, v = st[0, :3].copy(), st[0, 3:6].copy()
    copy = st[nbr[0]].T.copy()  # the neighbours' rows in list order, by field (as LongCopies holds them)
    no_copy = np.empty((8, 0))  # the gather path reads st
    for rho, gamma in ((1.0, 1e-2), (1.0, 1e-4)):
        two = _two_pass(1, st, ev_time, nbr, nnb, x, v, 10.0, rho, gamma, t, box, no_copy, -1)
        cop = _two_pass(1, st, ev_time, nbr, nnb, x, v, 10.0, rho, gamma, t, box, copy, 0)
        one = _scalar(1, st, ev_time, pieces, lens, x, v, 10.0, rho, gamma, t, box)
        assert two == one and cop == one, (two, cop, one)
        ns = {}
        for name, f, args in (("two-pass", _two_pass, (nbr, nnb)), ("scalar", _scalar, (pieces, lens)),
                              ("copy", _two_pass, (nbr, nnb))):
            extra = {"two-pass": (no_copy, -1), "copy": (copy, 0), "scalar": ()}[name]
            best = np.inf
            for _ in range(a.repeats):
                c0 = time.process_time()
                f(a.reps, st, ev_time, *args, x, v, 10.0, rho, gamma, t, box, *extra)
                best = min(best, time.process_time() - c0)
            ns[name] = best / a.reps / m * 1e9
        print(f"m={m} rows={a.rows} gamma={gamma:g}: scalar {ns['scalar']:.2f} ns/pair, two-pass {ns['two-pass']:.2f} "
              f"({ns['two-pass'] / ns['scalar']:.3f}), copy {ns['copy']:.2f} ({ns['copy'] / ns['scalar']:.3f}) "
              f"(best of {a.repeats}, CPU time)", flush=True)


if __name__ == "__main__":
    main()
