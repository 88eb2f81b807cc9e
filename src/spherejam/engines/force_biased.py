"""The force-biased (FB) packing algorithm (Mościński et al. 1989; Bezrukov, Bargieł & Stoyan 2002), as the paper
applies it (``docs/algorithms.md`` §4).

Every sphere i has a fixed nominal diameter D_i, scaled so that the spheres fill ``phi_nominal`` of the box, and two
global scale factors:

* inner ratio ``rho_in = min_ij r_ij / D_ij``: the largest overlap-free scale (the closest pair touches);
* outer ratio ``rho_out``, starting at ``1.2**(1/d)`` (outer spheres fill 1.2 phi_nominal) and shrinking.

One iteration (Jacobi: all forces come from the configuration at the start of the iteration):

1. move ``x_i += eps / (2 D_i) * rho_out**2 * F_i`` with eps = 0.5, and wrap into the box;
2. recompute ``F_i = sum_j D_i D_j (1 - r_ij**2 / (rho_out D_ij)**2) e_ji`` over the pairs whose *outer* spheres
   overlap (e_ji: unit vector from j to i), and ``rho_in``;
3. shrink ``rho_out -= 0.5**k * rho_out0 * gamma`` with ``k = ceil(-log10(1.2 phi_nominal - phi_in))``
   (no shrink once ``phi_in >= 1.2 phi_nominal``).

The run stops as soon as ``rho_out <= rho_in``; the result is the packing at the inner diameters
``rho_in * D_i``, with density ``phi = phi_nominal * rho_in**d``. As in the reference code, step 1 uses the current
(already shrunk) ``rho_out`` with forces computed before the shrink.

gamma (the contraction rate) is dimensionless and per iteration; the number of iterations is about
``(rho_out0 - rho_final) / (0.3 ... 0.5 * gamma)``, e.g. ~120 at gamma = 1e-3. It is *not* the LS compression rate.

Neighbours: a Verlet list of all pairs with ``r_ij < rho_out D_ij + skin`` (built from cell lists of
:mod:`spherejam.core.neighbours`), rebuilt whenever a sphere has moved more than skin/2 since the last build. Since
``rho_out`` never grows, the list then holds every pair whose outer spheres overlap. Each sphere's list is sorted
by index, so the force sums (and hence the result) do not depend on when the list was built: a resumed run is
bitwise identical to an uninterrupted one.
"""

from __future__ import annotations

import hashlib
import math
import os
import time
from pathlib import Path

import numpy as np

from ..core import neighbours
from ..core.checkpoint import load_checkpoint, save_checkpoint
from ..core.errors import PackingFileError, SimulationError, require
from ..core.packing import Packing, ball_volume
from ..core.progress import rate as per_second
from .driver import Progress, RunResult
from .kernels import force_biased as kernels

#: Outer spheres start at this multiple of the nominal density (Bezrukov et al. 2002).
OUTER_DENSITY_RATIO = 1.2
#: eps of the displacement rule x_i += eps / (2 D_i) rho_out^2 F_i.
FORCE_SCALING = 0.5
#: The paper's nominal-density rule: a line in the (ln gamma, phi_nominal) plane through these two points.
RULE_POINTS = ((1e-3, 0.6), (1e-7, 0.7))
#: Verlet skin, in units of the mean nominal diameter.
SKIN = 0.7
#: Cells fit the outer sphere of this diameter quantile; larger spheres scan more cells.
CELL_QUANTILE = 0.9
#: The history keeps at most 2 * this many rows; beyond, every other row is dropped and the stride doubles.
MAX_HISTORY_ROWS = 20000
CHECKPOINT_KIND = "fb"
HISTORY_COLUMNS = ("iteration", "phi_inner", "phi_outer", "max_overlap", "wall_time")


def nominal_density_for_rate(rate) -> float:
    """The paper's nominal density phi_nominal(gamma) for an FB run at contraction rate gamma.

    The straight line in the (ln gamma, phi) plane through (1e-3, 0.6) and (1e-7, 0.7), extrapolated linearly:
    ``0.6 + 0.1 * (ln gamma - ln 1e-3) / (ln 1e-7 - ln 1e-3)`` (0.55 at 1e-1, 0.65 at 1e-5). The formula printed in
    the reference README has the sign of the numerator flipped (it would give 0.5 at 1e-7); its own sentence, a line
    through those two points, is what is implemented here (``docs/algorithms.md`` §4.5).
    """
    rate = _check_rate(rate)
    (g1, p1), (g2, p2) = RULE_POINTS
    phi = p1 + (p2 - p1) * (math.log(rate) - math.log(g1)) / (math.log(g2) - math.log(g1))
    require(0 < phi < 1, "rate", rate, f"the nominal-density rule gives phi_nominal={phi:.4g}, outside (0, 1)")
    return phi


def _check_rate(rate) -> float:
    ok = isinstance(rate, (int, float, np.integer, np.floating)) and not isinstance(rate, bool)
    require(
        ok and math.isfinite(rate) and 0 < rate < 1, "rate", rate, "the FB contraction rate gamma must be in (0, 1)"
    )
    return float(rate)


# --- the run ----------------------------------------------------------------------------------------------------


class _Neighbours:
    """The Verlet list and its rebuild rule.

    Cells are sized for the outer diameter (plus skin) of the CELL_QUANTILE-quantile sphere at the run's start;
    larger spheres scan a wider stencil (rho_out never grows, so this stays valid).
    """

    def __init__(self, positions, diameters, box, rho_out):
        n, dim = positions.shape
        self.skin = SKIN * float(np.mean(diameters))
        typical = float(np.quantile(diameters, CELL_QUANTILE))
        self.m = neighbours.cells_per_side(box, rho_out * typical + self.skin, dim, n)
        self.capacity = 32 * n
        self.max_diameter = float(diameters.max())
        self.rho_built = rho_out
        self.drift = np.zeros_like(positions)
        self.rebuilds = 0
        self.start = self.list = None
        self.max_drift = math.inf

    def refresh(self, positions, diameters, box, rho_out):
        """Rebuild if two spheres may have approached by more than the skin since the last build."""
        if self.start is None or 2.0 * self.max_drift >= self.skin:
            while True:
                self.start, self.list = kernels.build_verlet(positions, diameters, box, rho_out, self.skin, self.m,
                                                      self.capacity)
                if len(self.start):
                    break
                self.capacity *= 2  # more pairs than room: retry (rare; the list itself is the same)
            self.drift[:] = 0.0
            self.max_drift = 0.0
            self.rebuilds += 1
            self.rho_built = rho_out

    def exact_below(self):
        """A pair missing from the list has r_ij / D_ij above this bound, so a list minimum below it is exact."""
        return self.rho_built + (self.skin - 2.0 * self.max_drift) / self.max_diameter


def _input_fingerprint(packing: Packing) -> str:
    h = hashlib.sha256()
    h.update(np.ascontiguousarray(packing.positions).tobytes())
    h.update(np.ascontiguousarray(packing.diameters).tobytes())
    h.update(np.float64(packing.box).tobytes())
    return h.hexdigest()


def _shrink(rho_out, rho_in, rho_out0, rate, phi_nominal, dim):
    """The outer-ratio update of one iteration (Bezrukov et al. 2002 schedule)."""
    delta = OUTER_DENSITY_RATIO * phi_nominal - phi_nominal * rho_in**dim
    if delta <= 0.0:
        return rho_out
    k = math.ceil(-math.log10(delta))
    return rho_out - 0.5**k * rho_out0 * rate


class _History:
    """Per-iteration rows, thinned for long runs: rows at iterations that are multiples of ``stride``."""

    def __init__(self, phi_nominal, dim, columns=None, stride=1):
        self.phi_nominal, self.dim, self.stride = phi_nominal, dim, int(stride)
        self.rows = {k: list(np.asarray(columns[k]).tolist()) if columns else [] for k in HISTORY_COLUMNS}

    def add(self, iteration, rho_in, rho_out, wall_time, force=False):
        if not force and iteration % self.stride:
            return
        if self.rows["iteration"] and self.rows["iteration"][-1] == iteration:
            return
        row = (iteration, self.phi_nominal * rho_in**self.dim, self.phi_nominal * rho_out**self.dim,
               1.0 - rho_in / rho_out, wall_time)
        for key, value in zip(HISTORY_COLUMNS, row):
            self.rows[key].append(value)
        if len(self.rows["iteration"]) >= 2 * MAX_HISTORY_ROWS:
            self.stride *= 2
            keep = [i for i, it in enumerate(self.rows["iteration"]) if it % self.stride == 0]
            for key in HISTORY_COLUMNS:
                self.rows[key] = [self.rows[key][i] for i in keep]

    def arrays(self):
        out = {k: np.asarray(v, dtype=np.float64) for k, v in self.rows.items()}
        out["iteration"] = out["iteration"].astype(np.int64)
        return out


def run_fb(
    packing: Packing,
    rate,
    *,
    phi_nominal=None,
    max_iterations=None,
    max_wall_time=None,
    checkpoint=None,
    checkpoint_interval: float = 300.0,
    progress_interval: float = 10.0,
) -> RunResult:
    """Run the force-biased algorithm from ``packing`` (typically a Poisson packing) until outer meets inner.

    Parameters
    ----------
    packing : Packing
        Start configuration. Its relative diameters are the nominal sizes; its box is kept. Overlaps are allowed.
    rate : float
        Contraction rate gamma (dimensionless, per iteration), 0 < gamma < 1.
    phi_nominal : float, optional
        Nominal density: the nominal diameters are scaled to fill this fraction of the box. ``None`` (default) uses
        the paper's rule :func:`nominal_density_for_rate` (d = 3 only).
    max_iterations : int, optional
        Stop after this many iterations in all (counting those before a resume); the result is then unfinished.
    max_wall_time : float, optional
        Stop after this many seconds of this call (unfinished result; a checkpoint is written if requested).
    checkpoint : path, optional
        HDF5 checkpoint: resumed from if it exists, written every ``checkpoint_interval`` s and when the run
        stops early, deleted when the run finishes.
    progress_interval : float
        Seconds between progress lines (logger ``spherejam``).

    Returns
    -------
    RunResult
        ``packing`` at the inner (actual) diameters, overlap-free with the closest pair touching; ``history``
        columns ``iteration, phi_inner, phi_outer, max_overlap, wall_time`` (max_overlap = 1 - rho_in/rho_out, the
        worst relative overlap of the outer spheres; wall_time in s since the run began, resumes included);
        ``counters`` ``iterations, wall_time, phi_inner, phi_outer, finished, neighbour_rebuilds,
        history_stride``. The history has one row per iteration (plus iteration 0, the start) up to
        2 * MAX_HISTORY_ROWS rows; longer runs keep every 2^k-th iteration and always the last one.
    """
    started = time.perf_counter()
    require(isinstance(packing, Packing), "packing", type(packing).__name__, "must be a spherejam Packing")
    n, dim = packing.n, packing.dim
    require(n >= 2, "N", n, "FB needs at least 2 spheres")
    rate = _check_rate(rate)
    if phi_nominal is None:
        require(dim == 3, "phi_nominal", None, f"the paper's rule holds for d=3; give phi_nominal for d={dim}")
        phi_nominal = nominal_density_for_rate(rate)
        rule = "paper line (ln gamma, phi) through (1e-3, 0.6), (1e-7, 0.7)"
    else:
        ok = isinstance(phi_nominal, (int, float, np.integer, np.floating)) and math.isfinite(phi_nominal)
        require(ok and 0 < phi_nominal < 1, "phi_nominal", phi_nominal, "must be in (0, 1)")
        phi_nominal, rule = float(phi_nominal), "given"
    if max_iterations is not None:
        require(isinstance(max_iterations, (int, np.integer)) and max_iterations >= 0, "max_iterations",
                max_iterations, "must be an integer >= 0 or None")
    if max_wall_time is not None:
        require(math.isfinite(max_wall_time) and max_wall_time > 0, "max_wall_time", max_wall_time,
                "must be None or a number > 0 (seconds)")
    # as in LS: 0 = at every iteration
    require(math.isfinite(checkpoint_interval) and checkpoint_interval >= 0, "checkpoint_interval",
            checkpoint_interval, "must be a number >= 0 (seconds)")
    require(math.isfinite(progress_interval) and progress_interval >= 0, "progress_interval", progress_interval,
            "must be a number >= 0 (seconds)")

    box = packing.box
    rel = packing.diameters / packing.mean_diameter
    nominal = rel * (phi_nominal * box**dim / float(np.sum(ball_volume(rel, dim)))) ** (1.0 / dim)
    rho_out0 = OUTER_DENSITY_RATIO ** (1.0 / dim)
    fingerprint = _input_fingerprint(packing)
    parameters = {
        "rate": rate,
        "phi_nominal": phi_nominal,
        "phi_nominal_rule": rule,
        "outer_density_ratio": OUTER_DENSITY_RATIO,
        "force_scaling": FORCE_SCALING,
        "verlet_skin": SKIN,
        "max_iterations": max_iterations,
        "max_wall_time": max_wall_time,
        "n": n,
        "dim": dim,
        "box": box,
        "sigma": packing.polydispersity,
    }

    positions = packing.positions.copy()
    forces = np.zeros_like(positions)
    dx = np.empty(dim)
    checkpoint = Path(checkpoint) if checkpoint is not None else None
    resumed = checkpoint is not None and checkpoint.exists()
    if resumed:
        arrays, attrs = load_checkpoint(checkpoint, CHECKPOINT_KIND)
        for key, value in (("input_sha256", fingerprint), ("rate", rate), ("phi_nominal", phi_nominal)):
            if attrs.get(key) != value:
                raise PackingFileError(f"{checkpoint}: checkpoint was made with a different {key} "
                                       f"({attrs.get(key)!r}, this run {value!r}); delete it or change the path")
        positions, forces = arrays["positions"].copy(), arrays["forces"].copy()
        rho_out, rho_in, iteration = float(attrs["rho_out"]), float(attrs["rho_in"]), int(attrs["iteration"])
        wall_before = float(attrs["wall_time"])
        history = _History(phi_nominal, dim, {k: arrays[f"history_{k}"] for k in HISTORY_COLUMNS},
                           attrs["history_stride"])
        nb = _Neighbours(positions, nominal, box, rho_out)
        nb.rebuilds = int(attrs["neighbour_rebuilds"])
    else:
        rho_out, iteration, wall_before = rho_out0, 0, 0.0
        history = _History(phi_nominal, dim)
        nb = _Neighbours(positions, nominal, box, rho_out)

    def elapsed():
        return wall_before + time.perf_counter() - started

    def compute_forces():
        """Forces at the current rho_out and the exact rho_in (the list is exact below rho_out)."""
        nb.refresh(positions, nominal, box, rho_out)
        h = kernels.forces(positions, nominal, box, rho_out, nb.start, nb.list, forces, dx)
        if not h < nb.exact_below():  # the closest pair may lie outside the list: find it exactly
            i, j, _ = neighbours.closest_pair(positions, nominal, box)
            h = kernels.pair_ratio(positions, nominal, box, i, j)  # rounded exactly as in kernels.forces
        if not math.isfinite(h) or not np.all(np.isfinite(forces)):
            raise SimulationError(f"FB iteration {iteration}: non-finite forces or inner ratio ({h!r})")
        return h

    if not resumed:
        rho_in = compute_forces()
        history.add(0, rho_in, rho_out, elapsed(), force=True)

    def save_state():
        arrays = {"positions": positions, "forces": forces}
        arrays.update({f"history_{k}": v for k, v in history.arrays().items()})
        attrs = {"input_sha256": fingerprint, "rate": rate, "phi_nominal": phi_nominal, "rho_out": rho_out,
                 "rho_in": rho_in, "iteration": iteration, "wall_time": elapsed(),
                 "history_stride": history.stride, "neighbour_rebuilds": nb.rebuilds}
        save_checkpoint(checkpoint, CHECKPOINT_KIND, arrays, attrs)

    progress = Progress(f"fb N={n} gamma={rate:g}", progress_interval)
    last_checkpoint = time.perf_counter()
    prefactor = FORCE_SCALING / 2.0
    stopped_early = False
    while rho_out > rho_in:
        if (max_iterations is not None and iteration >= max_iterations) or (
            max_wall_time is not None and time.perf_counter() - started >= max_wall_time
        ):
            stopped_early = True
            break
        nb.max_drift = kernels.move(positions, nominal, box, forces, prefactor * rho_out * rho_out, nb.drift)
        rho_in = compute_forces()
        rho_out = _shrink(rho_out, rho_in, rho_out0, rate, phi_nominal, dim)
        iteration += 1
        t = elapsed()
        history.add(iteration, rho_in, rho_out, t)
        phi_in, phi_out = phi_nominal * rho_in**dim, phi_nominal * rho_out**dim
        progress.update(f"iteration {iteration}: phi_inner {phi_in:.6f}, phi_outer {phi_out:.6f}",
                        fields={"iteration": iteration, "φ_in": phi_in, "φ_out": phi_out,
                                "iterations/s": per_second(iteration, t)},
                        bar=(phi_in / phi_out, "φ_in/φ_out"))
        if checkpoint is not None and time.perf_counter() - last_checkpoint >= checkpoint_interval:
            save_state()
            last_checkpoint = time.perf_counter()

    wall = elapsed()
    history.add(iteration, rho_in, rho_out, wall, force=True)
    if checkpoint is not None:
        if stopped_early:
            save_state()
        elif checkpoint.exists():
            os.unlink(checkpoint)
    phi_inner, phi_outer = phi_nominal * rho_in**dim, phi_nominal * rho_out**dim
    counters = {
        "iterations": iteration,
        "wall_time": wall,
        "phi_inner": phi_inner,
        "phi_outer": phi_outer,
        "rho_inner": rho_in,
        "rho_outer": rho_out,
        "finished": not stopped_early,
        "resumed": resumed,
        "neighbour_rebuilds": nb.rebuilds,
        "history_stride": history.stride,
    }
    metadata = {"algorithm": "fb", "parameters": parameters, "counters": counters}
    if "seed" in packing.metadata:
        metadata["seed"] = packing.metadata["seed"]
    result = Packing(positions, nominal * rho_in, box, metadata)
    result.validate(what="FB result")
    progress.update(f"{'done' if not stopped_early else 'stopped'} after {iteration} iterations: "
                    f"phi = {phi_inner:.6f}", force=True)
    return RunResult(packing=result, history=history.arrays(), counters=counters, wall_time=wall)
