"""Force-biased (FB) packings in every container shape: density, the wall layer, the audit and the cost per sphere
and iteration against the periodic cube of the same run (docs/algorithms.md §4.6).

For each shape and seed: a Poisson start inside the container, FB at the paper's nominal density for the rate, the
final phi (in the container's volume), the achieved lengths in mean diameters, the worst sphere-sphere overlap and
wall penetration (Packing.check, relative), the first wall layer (the mode of the centres' distance to the nearest
wall, in mean diameters, among those within one diameter of it) and the CPU time per sphere and iteration, as a
ratio against the periodic cube's.

``--profile SPEC`` instead prints, for seed 0 of one container, the histogram of the centres' distance to the nearest
wall (bins of 0.1 mean diameters): the layering at the wall.

Usage: python benchmarks/fb_containers.py [--n 1000] [--seeds 3] [--rate 1e-3] [--sigma 0] [--profile SPEC]
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from spherejam.core.container import number_for
from spherejam.core.seeding import poisson_packing
from spherejam.engines.force_biased import run_fb

SHAPES = ["periodic", "slab:height=8", "box:x=8,y=8,z=8", "cylinder:diameter=8",
          "cylinder:diameter=8,length=8,capped=yes", "sphere:diameter=10"]


def _first_layer(packing) -> float:
    """Mode of the distance of the centres to the nearest wall (in mean diameters), among those within one."""
    h = packing.container.wall_distance(packing.positions) / packing.mean_diameter
    hist, edges = np.histogram(h[h < 1.0], bins=np.arange(0.0, 1.0001, 0.05))
    k = int(np.argmax(hist))
    return 0.5 * (edges[k] + edges[k + 1])


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=1000, help="N where the shape leaves it free (default 1000)")
    ap.add_argument("--seeds", type=int, default=3)
    ap.add_argument("--rate", type=float, default=1e-3)
    ap.add_argument("--sigma", type=float, default=0.0)
    ap.add_argument("--profile", metavar="SPEC", help="print the wall-distance histogram of this container instead")
    args = ap.parse_args()
    if args.profile:
        n = args.n if number_for(args.profile, 1.0) is None else None
        p = run_fb(poisson_packing(n, args.sigma, seed=0, container=args.profile), args.rate,
                   progress_interval=1e9).packing
        size = ", ".join(f"{k}={v:.2f}" for k, v in p.container.in_diameters(p.mean_diameter).items())
        print(f"{args.profile}: N = {p.n}, {size}, phi = {p.phi:.4f}; centres by distance h to the nearest wall")
        h = p.container.wall_distance(p.positions) / p.mean_diameter
        counts, edges = np.histogram(h, bins=np.arange(0.0, min(float(h.max()), 4.0) + 0.1, 0.1))
        for lo, count in zip(edges[:-1], counts):
            print(f"  h/<d> {lo:4.1f}-{lo + 0.1:4.1f}: {count:5d} {'#' * int(60 * count / counts.max())}")
        return
    run_fb(poisson_packing(60, 0.1, seed=0, container="cylinder:diameter=4"), 1e-2, progress_interval=1e9)
    run_fb(poisson_packing(60, 0.1, seed=0), 1e-2, progress_interval=1e9)  # compile / load the kernels first
    print(f"FB, gamma = {args.rate:g}, sigma = {args.sigma:g}, {args.seeds} seeds; phi as mean +- sd over seeds")
    print(f"{'container':42} {'N':>5} {'achieved lengths / <d>':30} {'phi':>16} {'iters':>5} {'overlap':>9} "
          f"{'wall pen.':>9} {'layer':>5} {'CPU us/(N it)':>13} {'ratio':>5}")
    cube_cost = None
    for spec in SHAPES:
        n = args.n if number_for(spec, 1.0) is None else None  # a spec that gives every length fixes N
        phis, iters, costs, overlap, penetration, layers = [], [], [], -np.inf, -np.inf, []
        for seed in range(args.seeds):
            start = poisson_packing(n, args.sigma, seed=seed, container=None if spec == "periodic" else spec)
            t = time.process_time()
            res = run_fb(start, args.rate, progress_interval=1e9)
            cpu = time.process_time() - t
            p = res.packing
            phis.append(p.phi)
            iters.append(res.stats.steps)
            costs.append(cpu / (p.n * max(res.stats.steps, 1)) * 1e6)
            overlap = max(overlap, float(-p.min_gap()))  # 1 - min r_ij / D_ij
            penetration = max(penetration, p.container.wall_penetration(p.positions, p.diameters)[0])
            if p.container.has_walls:
                layers.append(_first_layer(p))
        size = ", ".join(f"{k}={v:.2f}" for k, v in p.container.in_diameters(p.mean_diameter).items()
                         if k != "height")
        cost = float(np.median(costs))
        cube_cost = cost if spec == "periodic" else cube_cost
        sd = f"{np.std(phis, ddof=1):.4f}" if len(phis) > 1 else "n/a"
        layer = f"{np.mean(layers):.2f}" if layers else "-"
        print(f"{spec:42} {p.n:>5} {size:30} {np.mean(phis):.4f} +- {sd:>6} {np.mean(iters):>5.0f} "
              f"{overlap:>9.1e} {penetration:>9.1e} {layer:>5} {cost:>13.2f} {cost / cube_cost:>5.2f}", flush=True)


if __name__ == "__main__":
    main()
