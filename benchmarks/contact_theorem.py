"""The pressure at a flat wall three ways (docs/containers.md §3): a hard-sphere fluid between two walls, gamma = 0.

Prints the wall's momentum flux per area (the mechanical pressure on the wall), k_B T times the density of centres at
contact (the contact theorem), and the normal pressure of the collision virial with its wall term,
P_zz = p_zz N k_B T / V, each with its standard error over windows; the three must agree. Also the mean of the
virial's diagonal, which differs by the tangential stress of the wall layers.

    python benchmarks/contact_theorem.py [--n 2000] [--phi 0.3] [--height 14] [--windows 400]
"""

from __future__ import annotations

import argparse
import math

import numpy as np

from spherejam.core.seeding import poisson_packing
from spherejam.engines.event_driven import LSEngine
from spherejam.engines.lubachevsky_stillinger import maxwell_velocities, run_ls


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=2000)
    ap.add_argument("--phi", type=float, default=0.3)
    ap.add_argument("--height", type=float, default=14.0, help="slab height in mean diameters")
    ap.add_argument("--windows", type=int, default=400)
    ap.add_argument("--seed", type=int, default=7)
    a = ap.parse_args()
    temperature = 0.2
    start = poisson_packing(a.n, seed=a.seed, container=f"slab:height={a.height}")
    fluid = run_ls(start, 0.2, target_phi=a.phi, seed=3, progress_interval=1e9).packing
    c, n = fluid.container, fluid.n
    engine = LSEngine.start(fluid.positions, np.ones(n), c, fluid.mean_diameter,
                            maxwell_velocities(n, temperature, np.random.default_rng(a.seed)), 0.0, temperature)
    area, volume, radius = c.lengths[0] * c.lengths[1], float(np.prod(c.lengths)), 0.5 * fluid.mean_diameter
    for _ in range(50):
        engine.window(20 * n)
    edges = radius + np.linspace(0.0, 0.25, 11) * fluid.mean_diameter
    wall, virial, mean, profiles = [], [], [], []
    for _ in range(a.windows):
        stats = engine.window(20 * n)
        wall.append(stats.wall_impulse / (2.0 * area * stats.duration))
        virial.append(stats.pressure_axes[2] * n * temperature / volume)
        mean.append(stats.pressure * n * temperature / volume)
        z = engine.positions[:, 2]
        profiles.append(np.histogram(np.minimum(z, c.lengths[2] - z), edges)[0] / (2.0 * area * np.diff(edges)))
    wall, virial, profiles = np.array(wall), np.array(virial), np.array(profiles)
    centres = 0.5 * (edges[1:] + edges[:-1]) - radius
    # the contact value by a quadratic through the bins, and its error from the spread of per-block fits
    blocks = np.array_split(np.arange(a.windows), 10)
    fits = [np.polyval(np.polyfit(centres, profiles[b].mean(axis=0), 2), 0.0) * temperature for b in blocks]
    se = lambda x: float(np.std(x, ddof=1) / math.sqrt(len(x)))  # noqa: E731
    print(f"slab N = {n}, phi = {fluid.phi:.4f}, height = {c.lengths[2] / fluid.mean_diameter:.3f} d, "
          f"{a.windows} windows of 20 N events, k_B T = {temperature}")
    print(f"  wall momentum flux       P = {wall.mean():.5f} +- {se(wall):.5f}")
    print(f"  k_B T rho_contact        P = {np.mean(fits):.5f} +- {se(fits):.5f}")
    print(f"  virial with wall term    P_zz = {virial.mean():.5f} +- {se(virial):.5f}")
    print(f"  its mean diagonal        (P_xx + P_yy + P_zz)/3 = {np.mean(mean):.5f} +- {se(mean):.5f} "
          "(the pressure MLS uses; tangential stress differs near walls)")
    print(f"  ideal gas (N k_B T / V)  P = {n * temperature / volume:.5f}")


if __name__ == "__main__":
    main()
