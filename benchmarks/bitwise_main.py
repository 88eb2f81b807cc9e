"""Bitwise comparison of LS, MLS and FB results between two checkouts (issue 35: where the single-image engine
worked, multi-image support must not change a bit).

Run once per checkout, then compare:

    PYTHONPATH=/path/to/main/src python benchmarks/bitwise_main.py run /tmp/main.npz
    PYTHONPATH=/path/to/branch/src python benchmarks/bitwise_main.py run /tmp/branch.npz
    python benchmarks/bitwise_main.py compare /tmp/main.npz /tmp/branch.npz

``run PATH --only fb`` (or ``ls,mls``) runs only those algorithms; compare then reports the others' arrays as in one
file only.

Cases: N = 100, 200, 500, 1000, sigma = 0 and 0.3, seeds 0-1 (LS at gamma = 0.1, MLS from 10 to 1e-2, FB at
gamma = 1e-2); a case the older checkout refuses is recorded as such and skipped in the comparison.
"""

from __future__ import annotations

import sys

import numpy as np

CASES = [(n, sigma, seed) for n in (100, 200, 500, 1000) for sigma in (0.0, 0.3) for seed in (0, 1)]


def run(path: str, only: set[str] | None = None) -> None:
    from spherejam import find_closest_jamming, poisson_packing, run_fb, run_ls

    out = {}
    for n, sigma, seed in CASES:
        start = poisson_packing(n, sigma, seed=seed)
        runs = {
            "ls": lambda p, seed=seed: run_ls(p, 0.1, seed=seed, progress_interval=1e9),
            "mls": lambda p, seed=seed: find_closest_jamming(p, final_rate=1e-2, seed=seed, progress_interval=1e9),
            "fb": lambda p: run_fb(p, 1e-2, progress_interval=1e9),
        }
        for alg, fn in runs.items():
            if only is not None and alg not in only:
                continue
            key = f"{alg}_{n}_{sigma}_{seed}"
            try:
                q = fn(start).packing
            except Exception as exc:  # noqa: BLE001 (the old engine's refusals are data here)
                print(key, "refused:", str(exc).splitlines()[0][:100], flush=True)
                continue
            out[key + "_x"], out[key + "_d"], out[key + "_phi"] = q.positions, q.diameters, np.array(q.phi)
            print(key, f"phi={q.phi:.12f}", flush=True)
    np.savez(path, **out)


def compare(a: str, b: str) -> None:
    x, y = np.load(a), np.load(b)
    same = differ = 0
    for key in sorted(set(x.files) & set(y.files)):
        if np.array_equal(x[key], y[key]):
            same += 1
        else:
            differ += 1
            print("DIFFERENT:", key)
    only = sorted(set(x.files) ^ set(y.files))
    print(f"{same} arrays bitwise equal, {differ} different; in one file only: {len(only)} {only[:6]}")
    sys.exit(1 if differ else 0)


if __name__ == "__main__":
    if sys.argv[1] == "run":
        run(sys.argv[2], set(sys.argv[4].split(",")) if sys.argv[3:4] == ["--only"] else None)
    else:
        compare(sys.argv[2], sys.argv[3])
