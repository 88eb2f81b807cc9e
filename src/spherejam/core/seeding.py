"""Poisson seeding: N uniform random centres in a periodic cube, with log-normal diameters.

Diameters follow a log-normal law with mean 1 and relative standard deviation sigma (the paper's sigma, read as the
std of D itself: s^2 = ln(1 + sigma^2), mu = -s^2/2). The paper could also be read with sigma = std(ln D); the two
readings differ in relative std by at most 2.3 % for sigma <= 0.3. The drawn sample is rescaled to mean exactly 1.
"""

from __future__ import annotations

import math

import numpy as np

from .errors import require
from .packing import Packing, ball_volume
from .validation import N_MAX

#: Upper bound of sigma we accept: beyond it log-normal size ratios grow so large that the
#: cell-list cost bound (size ratio up to ~1:10 for N ~ 1e4) no longer holds.
MAX_SIGMA = 1.0


def rng_for(seed: int) -> np.random.Generator:
    """The independent random stream of one packing: PCG64 seeded by ``seed`` (any int >= 0)."""
    require(isinstance(seed, (int, np.integer)) and seed >= 0, "seed", seed, "must be an integer >= 0")
    return np.random.default_rng(np.random.SeedSequence(int(seed)))


def lognormal_diameters(n: int, sigma: float, rng: np.random.Generator) -> np.ndarray:
    """``n`` log-normal diameters with sample mean exactly 1 and relative std ``sigma`` (0 = monodisperse)."""
    require(isinstance(n, (int, np.integer)) and n >= 1, "n", n, "must be an integer >= 1")
    require(math.isfinite(sigma) and 0 <= sigma <= MAX_SIGMA, "sigma", sigma, f"must be in [0, {MAX_SIGMA}]")
    if sigma == 0:
        return np.ones(n)
    s2 = math.log1p(sigma * sigma)
    d = rng.lognormal(mean=-s2 / 2, sigma=math.sqrt(s2), size=n)
    return d / d.mean()


def box_for(diameters: np.ndarray, phi_nominal: float, dim: int = 3) -> float:
    """Side L of the cube in which ``diameters`` fill a fraction ``phi_nominal``."""
    require(0 < phi_nominal < 1, "phi_nominal", phi_nominal, "must be in (0, 1)")
    return float((np.sum(ball_volume(diameters, dim)) / phi_nominal) ** (1.0 / dim))


def poisson_packing(
    n: int, sigma: float = 0.0, seed: int = 0, phi_nominal: float = 0.6, dim: int = 3
) -> Packing:
    """A Poisson packing: uniform centres, log-normal relative sizes, closest pair just touching.

    Parameters
    ----------
    n : int
        Number of spheres N >= 2.
    sigma : float
        Relative standard deviation of the diameters (dimensionless, 0 ... 1).
    seed : int
        Seed of this packing's independent random stream; the same seed gives bitwise the same packing.
    phi_nominal : float
        Packing fraction the mean-1 nominal diameters would have; it only fixes the box side L (length unit = mean
        nominal diameter). The actual diameters are the nominal ones scaled so that the closest pair touches, so the
        actual phi is tiny (~1e-5 for N = 1e4).
    dim : int
        Dimension d (2 ... 5).
    """
    require(isinstance(n, (int, np.integer)) and 2 <= n <= N_MAX, "n", n, f"must be an integer in [2, {N_MAX}]")
    require(isinstance(dim, (int, np.integer)) and 2 <= dim <= 5, "dim", dim, "must be 2, 3, 4 or 5")
    rng = rng_for(seed)
    nominal = lognormal_diameters(n, sigma, rng)
    box = box_for(nominal, phi_nominal, dim)
    positions = rng.random((n, dim)) * box
    metadata = {
        "algorithm": "poisson",
        "seed": int(seed),
        "parameters": {"n": int(n), "sigma": float(sigma), "phi_nominal": float(phi_nominal), "dim": int(dim)},
    }
    return Packing(positions, nominal, box, metadata).scaled_to_contact()
