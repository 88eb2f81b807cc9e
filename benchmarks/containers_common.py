"""Shared pieces of the container acceptance benchmarks (issue 45; docs/containers_acceptance.md): the protocols as a
table, container specs sized from N, the brute-force overlap and wall check, resumable per-run JSON records and the
confidence interval of a mean.

Not a module of the package: the benchmarks import it from their own folder.
"""

from __future__ import annotations

import json
import math
import os
import time
from pathlib import Path

import numpy as np

from spherejam.core.atomic import atomic_output
from spherejam.core.seeding import poisson_packing
from spherejam.engines.closest_jamming import find_closest_jamming
from spherejam.engines.force_biased import run_fb
from spherejam.engines.lubachevsky_stillinger import run_ls

LIMIT = 1e-10

#: The committed raw records of the acceptance benchmarks (one small JSON per run): every table of
#: docs/containers_acceptance.md is rebuilt from them by the scripts' ``--table-only``.
RECORDS = Path(__file__).resolve().parent / "records" / "containers"

#: Size distributions of the stress matrix: label -> psd spec (docs/psd.md). "Bidisperse 1:4" is taken with equal
#: numbers of each size, so that every N down to 20 holds both sizes and a periodic edge of a few diameters still
#: exceeds the largest sphere (with 30 % of the volume in the small ones, N = 20 would hold about one large sphere of
#: 3.6 mean diameters, wider than the periodic edges of a 20-sphere container, and be refused up front).
DISTRIBUTIONS = {
    "mono": "lognormal:sigma=0",
    "sigma0.3": "lognormal:sigma=0.3",
    "bi1:4": "bidisperse:ratio=4,small=0.5,by=number",
}

#: <d^3> / <d>^3 of each distribution (for sizing a container of N spheres in mean diameters).
_THIRD_MOMENT = {
    "mono": 1.0,
    "sigma0.3": 1.09**3,  # log-normal of relative sd sigma: <d^3>/<d>^3 = (1 + sigma^2)^3
    "bi1:4": (0.5 * 1 + 0.5 * 64) / (0.5 * 1 + 0.5 * 4) ** 3,
}


def cube_side(n: int, dist: str, phi: float = 0.62) -> float:
    """The side (in mean diameters) of the cube that N spheres of ``dist`` fill at ``phi``."""
    return (n * math.pi / 6.0 * _THIRD_MOMENT[dist] / phi) ** (1.0 / 3.0)


#: Every shape of the issue, as a spec built from the cube side s of N spheres (so each holds about N spheres and
#: has an aspect ratio near 1). The sphere's spec fixes N from its diameter; N is passed too and must agree within
#: the container's fill tolerance (core/container.build).
SHAPES = {
    "slab": lambda s: f"slab:height={s:.4g}",
    "box": lambda s: f"box:x={0.8 * s:.4g},y={1.25 * s:.4g}",
    "cylinder": lambda s: f"cylinder:diameter={1.084 * s:.4g}",
    "cylinder-capped": lambda s: f"cylinder:diameter={1.084 * s:.4g},capped=yes",
    "sphere": lambda s: f"sphere:diameter={(6.0 / math.pi) ** (1 / 3) * s:.4g}",
    "periodic-box": lambda s: f"periodic:x={0.7 * s:.4g},y={1.2 * s:.4g}",
}


# --- protocols: one entry each -------------------------------------------------------------------------------------
def _ls(start, seed: int, rate: float = 1.0, max_wall_time: float | None = None):
    return run_ls(start, rate, seed=seed, progress_interval=1e9, max_wall_time=max_wall_time)


def _mls(start, seed: int, max_wall_time: float | None = None):
    return find_closest_jamming(start, initial_rate=10.0, decrease_factor=2.0, final_rate=1e-2, seed=seed,
                                progress_interval=1e9, max_wall_time=max_wall_time)


#: FB's contraction rate: the fast end of the paper's range, nominal density 0.60 by its rule (docs/algorithms.md §4.5)
FB_RATE = 1e-3


def _fb(start, seed: int, max_wall_time: float | None = None):
    # FB draws no random numbers after the seeding: the seed acts through the Poisson start only
    return run_fb(start, FB_RATE, progress_interval=1e9, max_wall_time=max_wall_time)


#: name -> (description, callable(start packing, seed, max_wall_time) -> RunResult)
PROTOCOLS = {
    "ls": ("LS gamma = 1 from the Poisson start to p = 1e12",
           lambda start, seed, budget=None: _ls(start, seed, 1.0, budget)),
    "mls": ("MLS gamma_0 = 10, f = 2, gamma_f = 1e-2 from the Poisson start",
            lambda start, seed, budget=None: _mls(start, seed, budget)),
    "fb": (f"FB gamma = {FB_RATE:g} (nominal phi 0.60) from the Poisson start to outer = inner",
           lambda start, seed, budget=None: _fb(start, seed, budget)),
}


def start_packing(n: int | None, dist: str, container: str, seed: int):
    return poisson_packing(n, psd=DISTRIBUTIONS.get(dist, dist), container=container, seed=seed)


# --- the brute-force check -----------------------------------------------------------------------------------------
def brute_force(positions: np.ndarray, diameters: np.ndarray, container, chunk: int = 128) -> dict:
    """Worst relative sphere-sphere overlap 1 - r_ij / D_ij over every pair and every periodic image (shifts -1, 0,
    +1 of the edge along periodic axes only; a sphere against its own images too), and worst relative wall
    penetration (r_i - distance to the nearest wall) / r_i, from the container's geometry written out here (no
    cell list, no call to the package's own checks). Memory O(chunk x N).

    Shifts of -1, 0, +1 edges suffice: after wrapping, a difference along a periodic axis lies in (-L, L), so every
    image closer than L is among them, and no periodic edge is shorter than the largest sphere (the container refuses
    it). Also checks that each centre lies inside the frame along every walled axis."""
    x = np.asarray(positions, dtype=np.float64).copy()
    d = np.asarray(diameters, dtype=np.float64)
    n = len(x)
    lengths = np.asarray(container.lengths, dtype=np.float64)
    per = np.asarray(container.periodic)
    for k in range(3):
        if per[k]:
            x[:, k] = np.mod(x[:, k], lengths[k])
    shifts = np.array(np.meshgrid(*[(-1, 0, 1) if p else (0,) for p in per], indexing="ij")).reshape(3, -1).T
    shifts = shifts * lengths
    worst, worst_pair = -math.inf, (-1, -1)
    idx = np.arange(n)
    for a in range(0, n, chunk):
        xa, da = x[a:a + chunk], d[a:a + chunk]
        contact = 0.5 * (da[:, None] + d[None, :])
        i = idx[a:a + chunk, None]
        for s in shifts:
            own = not np.any(s)
            diff = x[None, :, :] + s - xa[:, None, :]
            r = np.sqrt(np.einsum("ijk,ijk->ij", diff, diff))
            ov = 1.0 - r / contact
            # without a shift each pair once and no sphere with itself; with a shift every ordered pair and self
            ov = np.where(idx[None, :] > i, ov, -np.inf) if own else ov
            m = int(np.argmax(ov))
            if ov.flat[m] > worst:
                worst, worst_pair = float(ov.flat[m]), (a + m // n, m % n)
    r = 0.5 * d
    dist = np.full(n, np.inf)
    for k in range(3):
        if container.planes[k]:
            dist = np.minimum(dist, np.minimum(x[:, k], lengths[k] - x[:, k]))
        if not per[k]:  # a walled axis: the centre must lie in the frame
            dist = np.minimum(dist, np.where((x[:, k] >= 0) & (x[:, k] <= lengths[k]), np.inf, -np.inf))
    if container.curved is not None:
        q = x - 0.5 * lengths
        if container.curved == "cylinder":
            q[:, container.axis] = 0.0
        dist = np.minimum(dist, container.radius - np.sqrt(np.einsum("ij,ij->i", q, q)))
    pen = (r - dist) / r if container.has_walls else np.full(n, -np.inf)
    j = int(np.argmax(pen))
    return {"worst_overlap": worst, "overlap_pair": [int(v) for v in worst_pair],
            "worst_penetration": float(pen[j]), "penetration_sphere": j}


# --- porosity profiles ---------------------------------------------------------------------------------------------
#: Bin width of the recorded profiles, in mean diameters (fine enough to place the first minimum within 0.0125 d).
PROFILE_BIN = 0.025
#: The core: the region at least this many mean diameters from every wall (the issue's "beyond 5 d").
CORE_DISTANCE = 5.0


def profile_record(packing, bin_width: float = PROFILE_BIN) -> dict:
    """The packing's exact porosity profile (analysis.profiles.profile: radial in a cylinder or a sphere, folded axial
    in a slab or a box) as plain lists, with each bin's share of the container's volume (to rebin it), and the core
    phi (None when the container has no point CORE_DISTANCE from every wall)."""
    from spherejam.analysis import profiles

    pr = profiles.profile(packing, bin_width)
    co = profiles.core(packing, CORE_DISTANCE)
    share = pr.volume / pr.volume.sum()
    return {"profile": {"kind": pr.kind, "bin_width": bin_width, "extent": float(pr.edges[-1]),
                        "porosity": [round(float(e), 6) for e in pr.porosity],
                        "volume_share": [float(f"{v:.6g}") for v in share]},
            "core_phi": co.phi if co.volume > 0 else None, "core_fraction": co.fraction_of_container}


def mean_profile(records: list[dict]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Bin centres (mean diameters from the wall), the porosity averaged over the records' profiles, and the bins'
    volume shares, over the bins all of them have (their extents differ by the achieved size)."""
    m = min(len(r["profile"]["porosity"]) for r in records)
    w = records[0]["profile"]["bin_width"]
    eps = np.mean([r["profile"]["porosity"][:m] for r in records], axis=0)
    share = np.mean([r["profile"]["volume_share"][:m] for r in records], axis=0)
    return (np.arange(m) + 0.5) * w, eps, share


def profile_features(centres: np.ndarray, eps: np.ndarray, share: np.ndarray, eps_core: float | None,
                     shell: float = 0.5) -> dict:
    """The issue's criteria of a porosity profile measured from the wall:

    * ``wall_bin``: the porosity of the first bin; ``wall_extrapolated``: 1.5 eps_1 - 0.5 eps_2, the linear
      extrapolation to the wall (a sphere touching a wall cuts a plane at distance z in a disc of area ~ pi d z, so the
      solid fraction rises linearly from 0 at the wall);
    * ``minima``: the first minimum, the lowest bin between 0.2 and 1.0 d, then each next one the lowest bin between
      0.6 and 1.4 d beyond the previous (while that window lies in the profile); ``period``: their mean spacing;
    * ``core_deviation``: beyond CORE_DISTANCE, the largest |eps - eps_core| over shells of ``shell`` d (bins merged
      by volume: single 0.025 d bins near a cylinder's axis hold a fraction of a sphere and are noise, not structure);
      None without a core."""
    w = centres[1] - centres[0]
    out = {"wall_bin": float(eps[0]), "wall_extrapolated": float(1.5 * eps[0] - 0.5 * eps[1])}
    minima, lo, hi = [], 0.2, 1.0
    while hi <= centres[-1] + 0.5 * w and len(minima) < 5:
        sel = (centres >= lo) & (centres <= hi)
        if not sel.any():
            break
        k = int(np.flatnonzero(sel)[np.argmin(eps[sel])])
        minima.append((float(centres[k]), float(eps[k])))
        lo, hi = centres[k] + 0.6, centres[k] + 1.4
    out["minima"] = minima
    out["period"] = float(np.mean(np.diff([x for x, _ in minima]))) if len(minima) >= 2 else None
    out["core_deviation"] = None
    if eps_core is not None and centres[-1] > CORE_DISTANCE + shell:
        far = centres > CORE_DISTANCE
        groups = np.floor((centres[far] - CORE_DISTANCE) / shell).astype(int)
        solid = (1.0 - eps[far]) * share[far]
        dev = [abs(1.0 - solid[groups == g].sum() / share[far][groups == g].sum() - eps_core)
               for g in np.unique(groups) if (groups == g).sum() * w >= 0.99 * shell]
        out["core_deviation"] = float(max(dev)) if dev else None
    return out


# --- resumable records ---------------------------------------------------------------------------------------------
class Records:
    """One JSON file per run in ``folder``; a run whose file exists is skipped (resumption)."""

    def __init__(self, folder: str | os.PathLike):
        self.folder = Path(folder)
        self.folder.mkdir(parents=True, exist_ok=True)

    def path(self, key: str) -> Path:
        return self.folder / f"{key.replace('/', '_').replace(':', '_').replace('=', '')}.json"

    def get(self, key: str) -> dict | None:
        p = self.path(key)
        return json.loads(p.read_text()) if p.exists() else None

    def put(self, key: str, record: dict) -> None:
        with atomic_output(self.path(key), ".json") as tmp:
            Path(tmp).write_text(json.dumps(record, separators=(",", ":"), default=float) + "\n")


def provenance() -> dict:
    import subprocess

    here = Path(__file__).resolve().parent
    try:
        commit = subprocess.run(["git", "-C", str(here), "rev-parse", "HEAD"], capture_output=True, text=True,
                                check=True).stdout.strip()
    except (OSError, subprocess.CalledProcessError):
        commit = "unknown"
    return {"commit": commit, "time": time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime()),
            "load": os.getloadavg()[0]}


# --- statistics ------------------------------------------------------------------------------------------------------
def mean_ci(values, level: float = 0.95) -> tuple[float, float | None]:
    """Mean and the half-width of its Student-t interval; None when n < 2 (not estimable)."""
    v = np.asarray([x for x in values if x is not None and math.isfinite(x)], dtype=np.float64)
    if len(v) == 0:
        return math.nan, None
    if len(v) < 2:
        return float(v.mean()), None
    from scipy.stats import t

    return float(v.mean()), float(t.ppf(0.5 + level / 2, len(v) - 1) * v.std(ddof=1) / math.sqrt(len(v)))


def welch(x, y, level: float = 0.95) -> tuple[float, float | None]:
    """mean(x) - mean(y) and the half-width of its Welch interval; None when either has n < 2."""
    from scipy.stats import t

    x, y = np.asarray(x, float), np.asarray(y, float)
    if len(x) < 2 or len(y) < 2:
        return float(x.mean() - y.mean()), None
    vx, vy = x.var(ddof=1) / len(x), y.var(ddof=1) / len(y)
    se = math.sqrt(vx + vy)
    dof = (vx + vy) ** 2 / (vx**2 / (len(x) - 1) + vy**2 / (len(y) - 1)) if se > 0 else len(x) + len(y) - 2
    return float(x.mean() - y.mean()), float(t.ppf(0.5 + level / 2, dof) * se)


def fmt_ci(values, digits: int = 4) -> str:
    m, h = mean_ci(values)
    n = len([x for x in values if x is not None])
    if h is None:
        return f"{m:.{digits}f} (CI not estimable, n = {n})" if n else "n = 0"
    return f"{m:.{digits}f} ± {h:.{digits}f} (n = {n})"
