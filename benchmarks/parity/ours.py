"""Our side of a pair: the start packing (made by our code for both codes) and our MLS search, with why it stopped."""

from __future__ import annotations

import functools
import time

import numpy as np

from spherejam import find_closest_jamming, poisson_packing, run_fb, run_ls

P_MAX = 1e12
MAX_EQUILIBRATION_WINDOWS = 50


def make_start(n: int, sigma: float, seed: int, kind: str, rate: float):
    """The pair's start packing, made by our code: Poisson (phi_nominal 0.6) -> FB or LS at ``rate``."""
    poisson = poisson_packing(n, sigma, seed=seed, phi_nominal=0.6)
    if kind == "fb":
        return run_fb(poisson, rate, progress_interval=1e9).packing
    return run_ls(poisson, rate, seed=seed, progress_interval=1e9).packing


def run_ours(start, seed: int, initial_rate: float, factor: float, final_rate: float, max_collisions: int,
             return_packing: bool = False, **options):
    """Our search; ``options`` go to :func:`find_closest_jamming` (e.g. ``stall_windows``). With ``return_packing``,
    ``(result, final packing)``."""
    cpu0, wall0 = time.process_time(), time.perf_counter()
    r = find_closest_jamming(start, initial_rate=initial_rate, decrease_factor=factor, final_rate=final_rate,
                             p_max=P_MAX, max_equilibration_windows=MAX_EQUILIBRATION_WINDOWS, seed=seed,
                             max_collisions=max_collisions, progress_interval=1e9, **options)
    cpu, wall = time.process_time() - cpu0, time.perf_counter() - wall0
    h = r.history
    cols = {k: np.asarray(h[k]).tolist() for k in ("phi", "pressure", "rate", "collisions", "duration") if k in h}
    collisions = int(np.sum(h["collisions"]))
    stop = stop_reason(cols["rate"], cols["pressure"], final_rate)
    res = {"code": "ours", "phi_J": float(r.packing.phi), "stop": stop, "cpu_s": cpu, "wall_s": wall,
           "collisions": collisions, "windows": len(cols["phi"]), "history": cols}
    res = classify(res, max_collisions)
    return (res, r.packing) if return_packing else res


def classify(res: dict, max_collisions: int) -> dict:
    """Mark our search as capped if it ended at the collision cap without meeting a stop rule (the cap is checked
    after the MLS rules, so a search that stops exactly at the cap window by a rule keeps that rule)."""
    capped = res["collisions"] >= max_collisions and res["stop"] not in ("final_rate", "jammed")
    res["capped"] = capped
    if capped:
        res["stop"], res["phi_J"] = "capped", None
    return res


def stop_reason(rate, pressure, final_rate: float) -> str:
    """Why a search ended, from its last windows (the MLS rules of docs/algorithms.md §3)."""
    if not rate:
        return "unfinished"
    if 0 < rate[-1] <= final_rate:
        return "final_rate" if pressure[-1] >= P_MAX else "final_rate_stalled"
    tail = MAX_EQUILIBRATION_WINDOWS
    if len(rate) >= tail and all(g == 0 for g in rate[-tail:]) and all(p >= P_MAX for p in pressure[-tail:]):
        return "jammed"
    return "unfinished"


@functools.cache
def warm_up() -> None:
    """Load/compile the kernels once, outside the timed searches."""
    find_closest_jamming(poisson_packing(64, 0.0, seed=0), initial_rate=1.0, max_collisions=2000, progress_interval=1e9)
