"""Poisson seeding: N uniform random centres in a periodic cube (or any container: core/container), with diameters
from any size distribution.

By default the diameters follow the paper's log-normal law with mean 1 and relative standard deviation sigma (read as
the std of D itself: s^2 = ln(1 + sigma^2), mu = -s^2/2; the paper could also be read with sigma = std(ln D); the two
readings differ in relative std by at most 2.3 % for sigma <= 0.3). Any other distribution is given by its spec
(:mod:`spherejam.core.size_distribution`). The drawn sample is rescaled to mean exactly 1. The stream draws the
diameters first, then the centres, for every family, so the log-normal packings are those of spherejam 0.1.
"""

from __future__ import annotations

import math

import numpy as np

from . import container as containers
from .errors import require
from .packing import Packing, ball_volume
from .size_distribution import MAX_SIGMA, LogNormal, SizeDistribution, lognormal_spec, parse, sample_descriptors
from .validation import N_MAX

#: The packing fraction the nominal diameters fill in the periodic cube (it only sets the cube's side).
CUBE_PHI_NOMINAL = 0.6

__all__ = ["MAX_SIGMA", "box_for", "lognormal_diameters", "poisson_packing", "rng_for"]


def rng_for(seed: int) -> np.random.Generator:
    """The independent random stream of one packing: PCG64 seeded by ``seed`` (any int >= 0)."""
    require(isinstance(seed, (int, np.integer)) and seed >= 0, "seed", seed, "must be an integer >= 0")
    return np.random.default_rng(np.random.SeedSequence(int(seed)))


def lognormal_diameters(n: int, sigma: float, rng: np.random.Generator) -> np.ndarray:
    """``n`` log-normal diameters with sample mean exactly 1 and relative std ``sigma`` (0 = monodisperse)."""
    require(isinstance(n, (int, np.integer)) and n >= 1, "n", n, "must be an integer >= 1")
    require(math.isfinite(sigma) and 0 <= sigma <= MAX_SIGMA, "sigma", sigma, f"must be in [0, {MAX_SIGMA}]")
    return LogNormal(lognormal_spec(sigma), float(sigma)).draw(n, rng)


def box_for(diameters: np.ndarray, phi_nominal: float, dim: int = 3) -> float:
    """Side L of the cube in which ``diameters`` fill a fraction ``phi_nominal``."""
    require(0 < phi_nominal < 1, "phi_nominal", phi_nominal, "must be in (0, 1)")
    return float((np.sum(ball_volume(diameters, dim)) / phi_nominal) ** (1.0 / dim))


def poisson_packing(
    n: int | None, sigma: float = 0.0, seed: int = 0, phi_nominal: float | None = None, dim: int = 3,
    psd: str | SizeDistribution | None = None, container: str | containers.ContainerSpec | None = None,
) -> Packing:
    """A Poisson packing: uniform centres, relative sizes from a size distribution, closest pair just touching.

    Parameters
    ----------
    n : int or None
        Number of spheres N >= 2; None takes it from a ``list:`` distribution.
    sigma : float
        Relative standard deviation of log-normal diameters (dimensionless, 0 ... 1); ignored if ``psd`` is given.
    psd : str or SizeDistribution, optional
        The size distribution (a spec such as ``gaussian:delta=0.2``); default ``lognormal:sigma=<sigma>``.
    seed : int
        Seed of this packing's independent random stream; the same seed gives bitwise the same packing.
    phi_nominal : float, optional
        Packing fraction the mean-1 nominal diameters would have (default 0.6 in the cube); it only fixes the box
        side L (length unit = mean nominal diameter). The actual diameters are the nominal ones scaled so that
        the closest pair touches, so the actual phi is tiny (~1e-5 for N = 1e4).
    dim : int
        Dimension d (2 ... 5).
    container : str, optional
        A container spec (``cylinder:diameter=10``; docs/containers.md); default the periodic cube. Its lengths are
        in mean diameters of the final packing: the frame is sized for ``phi_nominal`` (here the expected final
        packing fraction, default :data:`~spherejam.core.container.PHI_ESTIMATE`), centres are uniform inside the
        walls, and the diameters are scaled until the closest pair touches or a sphere touches a wall. A spec that
        gives every length fixes N (``n`` None, or that number).
    """
    if psd is None:
        require(isinstance(sigma, (int, float, np.floating)) and math.isfinite(sigma) and 0 <= sigma <= MAX_SIGMA,
                "sigma", sigma, f"must be in [0, {MAX_SIGMA}]")
        psd = lognormal_spec(sigma)
    distribution = parse(psd)
    spec = containers.parse(container)
    if not (spec.is_periodic and not spec.lengths):
        return _poisson_in_container(n, distribution, spec, seed,
                                     containers.PHI_ESTIMATE if phi_nominal is None else phi_nominal, dim)
    phi_nominal = CUBE_PHI_NOMINAL if phi_nominal is None else phi_nominal
    if n is None:
        require(distribution.fixed_n is not None, "n", n, "must be given (only a list: distribution fixes N)")
        n = distribution.fixed_n
    require(isinstance(n, (int, np.integer)) and 2 <= n <= N_MAX, "n", n, f"must be an integer in [2, {N_MAX}]")
    require(isinstance(dim, (int, np.integer)) and 2 <= dim <= 5, "dim", dim, "must be 2, 3, 4 or 5")
    rng = rng_for(seed)
    nominal = distribution.draw(n, rng)
    box = box_for(nominal, phi_nominal, dim)
    positions = rng.random((n, dim)) * box
    metadata = _metadata(distribution, nominal, seed, phi_nominal, dim)
    return Packing(positions, nominal, box, metadata).scaled_to_contact()


def _metadata(distribution: SizeDistribution, nominal: np.ndarray, seed: int, phi_nominal: float, dim: int,
              **extra) -> dict:
    """A Poisson packing's metadata: its parameters (``extra`` last) and the distribution with the drawn sample's
    own descriptors (delta, skewness, d_max/d_min, M1..M3, z)."""
    parameters = {"n": len(nominal)}
    if isinstance(distribution, LogNormal):
        parameters["sigma"] = float(distribution.sigma)
    parameters.update({"phi_nominal": float(phi_nominal), "dim": int(dim), "psd": distribution.spec, **extra})
    return {
        "algorithm": "poisson",
        "seed": int(seed),
        "parameters": parameters,
        "size_distribution": {**distribution.provenance(), "sample": sample_descriptors(nominal).as_dict()},
    }


def _uniform_inside(container: containers.Container, n: int, rng: np.random.Generator) -> np.ndarray:
    """``n`` centres uniform inside the container's walls (strictly: each then fits a sphere of some radius > 0).
    Curved containers draw in the frame and keep the points inside, batch by batch."""
    lengths = np.asarray(container.lengths)
    out = np.empty((0, container.dim))
    while len(out) < n:
        need = n - len(out)
        batch = rng.random((need if container.curved is None else 2 * need + 16, container.dim)) * lengths
        out = np.concatenate([out, batch[container.contains(batch)]])
    return out[:n]


def _poisson_in_container(n, distribution: SizeDistribution, spec: containers.ContainerSpec, seed: int,
                          phi_estimate: float, dim: int) -> Packing:
    require(isinstance(dim, (int, np.integer)) and dim == 3, "dim", dim, "containers are implemented in d = 3")
    if n is None:
        n = distribution.fixed_n
    if n is None:
        mean_volume = math.pi / 6.0 * distribution.descriptors().m3
        n = containers.number_for(spec, mean_volume, phi_estimate)
        require(n is not None, "n", n, f"must be given (the container {spec.text} leaves a length to N)")
    require(isinstance(n, (int, np.integer)) and 2 <= n <= N_MAX, "n", n, f"must be an integer in [2, {N_MAX}]")
    rng = rng_for(seed)
    nominal = distribution.draw(n, rng)
    container = containers.build(spec, n, nominal, phi_estimate, dim)
    positions = _uniform_inside(container, n, rng)
    metadata = _metadata(distribution, nominal, seed, phi_estimate, dim, container=container.spec)
    return Packing(positions, nominal, math.nan, metadata, container).scaled_to_contact()
