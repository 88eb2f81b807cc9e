"""The force-biased (FB) packing algorithm (Mościński et al. 1989; Bezrukov, Bargieł & Stoyan 2002), as the paper
applies it (docs/algorithms.md §4).

Every sphere i has a fixed nominal diameter D_i, scaled so that the spheres fill ``phi_nominal`` of the container's
volume (the box's L^d in a periodic cube), and two global scale factors:

* inner ratio ``rho_in = min(min_ij r_ij / D_ij, min_i 2 h_i / D_i)``: the largest overlap-free scale (the closest
  pair touches, or a sphere touches a wall; h_i is the distance of centre i to its nearest wall);
* outer ratio ``rho_out``, starting at ``1.2**(1/d)`` (outer spheres fill 1.2 phi_nominal) and shrinking.

One iteration (Jacobi: all forces come from the configuration at the start of the iteration):

1. move ``x_i += eps / (2 D_i) * rho_out**2 * F_i`` with eps = 0.5, and wrap into the box along its periodic axes;
   in a container, a centre that would end closer to a wall than rho_in D_i / 2 is put back at that distance;
2. recompute ``F_i = sum_j D_i D_j (1 - r_ij**2 / (rho_out D_ij)**2) e_ji`` over the pairs whose *outer* spheres
   overlap (e_ji: unit vector from j to i), plus the walls' forces (each wall acts as the sphere's mirror image
   across it: ``D_i**2 (1 - (2 h_i / (rho_out D_i))**2)`` along its inward normal), and ``rho_in``;
3. shrink ``rho_out -= 0.5**k * rho_out0 * gamma`` with ``k = ceil(-log10(1.2 phi_nominal - phi_in))``
   (no shrink once ``phi_in >= 1.2 phi_nominal``).

The run stops as soon as ``rho_out <= rho_in``; the result is the packing at the inner diameters
``rho_in * D_i``, with density ``phi = phi_nominal * rho_in**d``. As in the paper's C++ code, step 1 uses the current
(already shrunk) ``rho_out`` with forces computed before the shrink.

gamma (the contraction rate) is dimensionless and per iteration; the number of iterations is about
``(rho_out0 - rho_final) / (0.3 ... 0.5 * gamma)``, e.g. ~120 at gamma = 1e-3. It is *not* the LS compression rate.

Neighbours: a Verlet list of all pairs with ``r_ij < rho_out D_ij + skin`` (built from cell lists of
:mod:`spherejam.core.neighbours`), rebuilt whenever a sphere has moved more than skin/2 since the last build. Since
``rho_out`` never grows, the list then holds every pair whose outer spheres overlap. Each sphere's list is sorted
by index, so the force sums (and hence the result) do not depend on when the list was built: a resumed run is
bitwise identical to an uninterrupted one.

Containers (core/container; docs/algorithms.md §4.6 "FB with walls"): the list and the forces run in the container's
frame, with minimum images along its periodic axes only; the walls' forces and distances are exact (no list).
"""

from __future__ import annotations

import math

import numpy as np

from ..core import neighbours
from ..core.checkpoint import fingerprint
from ..core.errors import SimulationError, require
from ..core.history import History
from ..core.packing import Packing, ball_volume
from ..core.progress import per_second
from .driver import RunOptions, Stepper, drive
from .kernels import force_biased as kernels
from .result import FBCounts, RunResult, RunStats

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


def nominal_density_for_rate(rate) -> float:
    """The paper's nominal density phi_nominal(gamma) for an FB run at contraction rate gamma.

    The straight line in the (ln gamma, phi) plane through (1e-3, 0.6) and (1e-7, 0.7), extrapolated linearly:
    ``0.6 + 0.1 * (ln gamma - ln 1e-3) / (ln 1e-7 - ln 1e-3)`` (0.55 at 1e-1, 0.65 at 1e-5): the line through those
    two points, as docs/algorithms.md §4.5 states it.
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

    def __init__(self, positions, diameters, frame, rho_out):
        n = positions.shape[0]
        self.skin = SKIN * float(np.mean(diameters))
        typical = float(np.quantile(diameters, CELL_QUANTILE))
        self.ms = neighbours.cells_per_axis(frame, rho_out * typical + self.skin, n)
        self.capacity = 32 * n
        self.max_diameter = float(diameters.max())
        self.rho_built = rho_out
        self.drift = np.zeros_like(positions)
        self.rebuilds = 0
        self.start = self.list = None
        self.max_drift = math.inf

    def refresh(self, positions, diameters, frame, rho_out):
        """Rebuild if two spheres may have approached by more than the skin since the last build."""
        if self.start is None or 2.0 * self.max_drift >= self.skin:
            while True:
                self.start, self.list = kernels.build_verlet(positions, diameters, frame.lengths, frame.half,
                                                             frame.periodic, rho_out, self.skin, self.ms,
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


def _shrink(rho_out, rho_in, rho_out0, rate, phi_nominal, dim):
    """The outer-ratio update of one iteration (Bezrukov et al. 2002 schedule)."""
    delta = OUTER_DENSITY_RATIO * phi_nominal - phi_nominal * rho_in**dim
    if delta <= 0.0:
        return rho_out
    k = math.ceil(-math.log10(delta))
    return rho_out - 0.5**k * rho_out0 * rate


class FBRun(Stepper):
    """The FB iteration, as :func:`~.driver.drive` steps it."""

    kind = CHECKPOINT_KIND
    step_name = "iteration"

    def __init__(self, packing: Packing, rate: float, phi_nominal: float, max_iterations: int | None,
                 parameters: dict):
        self.input, self.rate, self.phi_nominal, self.max_iterations = packing, rate, phi_nominal, max_iterations
        self.parameters = parameters
        self.dim, container = packing.dim, packing.container
        self.frame = neighbours.Frame.of(container)
        self.has_walls = container.has_walls
        # the walls for the kernels (core.container.Container.wall_array; unused without walls, any dimension)
        self.walls = container.wall_array() if self.has_walls else np.zeros(9)
        #: the shortest periodic length (inf if none): no sphere may overlap its own image across it
        self.period = min((L for L, p in zip(container.lengths, container.periodic) if p), default=math.inf)
        rel = packing.diameters / packing.mean_diameter
        self.nominal = rel * (phi_nominal * packing.volume / float(np.sum(ball_volume(rel, self.dim)))) ** (
            1.0 / self.dim)
        self.rho_out0 = OUTER_DENSITY_RATIO ** (1.0 / self.dim)
        self.label = f"fb N={packing.n} rate={rate:g}"
        self.forces = np.zeros_like(packing.positions)
        self.dx = np.empty(self.dim)
        # an outer sphere reaches an image other than the minimum one only if rho_out D_ij > L_k/2 along a periodic
        # axis (rho_out shrinks)
        self.multi = bool(self.rho_out0 * float(self.nominal.max()) > 0.5 * self.period)

    def _history(self, columns=None, stride=1) -> History:
        return History(columns, step="iteration", max_rows=MAX_HISTORY_ROWS, stride=stride)

    def _add_row(self, wall_time: float, force: bool = False) -> None:
        self.history.append(force=force, iteration=self.iteration, phi_inner=self.phi,
                            phi_outer=self.phi_nominal * self.rho_out**self.dim,
                            max_overlap=1.0 - self.rho_in / self.rho_out, wall_time=wall_time)

    def _compute_forces(self) -> float:
        """Forces at the current rho_out and the exact rho_in (the list is exact below rho_out; the walls are
        exact)."""
        nb, positions, nominal, frame = self.nb, self.positions, self.nominal, self.frame
        nb.refresh(positions, nominal, frame, self.rho_out)
        h = kernels.forces(positions, nominal, frame.lengths, frame.half, frame.periodic, self.rho_out, nb.start,
                           nb.list, self.forces, self.dx, self.multi)
        h_wall = math.inf
        if self.has_walls:
            h_wall = kernels.wall_forces(positions, nominal, frame.lengths, self.walls, self.rho_out, self.forces)
        if not min(h, h_wall) < nb.exact_below():  # the closest pair may lie outside the list: find it exactly
            i, j, _ = neighbours.closest_pair(positions, nominal, self.input.frame)
            h = kernels.pair_ratio(positions, nominal, frame.lengths, frame.half, i, j)  # as in kernels.forces
        if self.multi:  # nor may a sphere overlap its own image (the forces of its own images cancel)
            h = min(h, self.period / float(nominal.max()))
        h = min(h, h_wall)
        if not math.isfinite(h) or not np.all(np.isfinite(self.forces)):
            raise SimulationError(f"FB iteration {self.iteration}: non-finite forces or inner ratio ({h!r})")
        return h

    # --- Stepper ---------------------------------------------------------------------------------------------
    def start(self, wall_time) -> None:
        self.positions = self.input.positions.copy()
        self.rho_out, self.iteration = self.rho_out0, 0
        self.history = self._history()
        self.nb = _Neighbours(self.positions, self.nominal, self.frame, self.rho_out)
        self.rho_in = self._compute_forces()
        self._phi_initial = self.phi
        self._add_row(wall_time(), force=True)

    def load(self, arrays, attrs, history) -> None:
        self.positions, self.forces = arrays["positions"].copy(), arrays["forces"].copy()
        self.rho_out, self.rho_in = float(attrs["rho_out"]), float(attrs["rho_in"])
        self.iteration, self._phi_initial = int(attrs["iteration"]), float(attrs["phi_initial"])
        self.history = self._history(history, attrs["history_stride"])
        self.nb = _Neighbours(self.positions, self.nominal, self.frame, self.rho_out)
        self.nb.rebuilds = int(attrs["neighbour_rebuilds"])

    def state(self):
        return {"positions": self.positions, "forces": self.forces}, {
            "rho_out": self.rho_out, "rho_in": self.rho_in, "iteration": self.iteration,
            "phi_initial": self._phi_initial, "history_stride": self.history.stride,
            "neighbour_rebuilds": self.nb.rebuilds}

    def stop_before(self) -> str | None:
        if not self.rho_out > self.rho_in:
            return "converged"
        if self.max_iterations is not None and self.iteration >= self.max_iterations:
            return "max_iterations"
        return None

    def step(self, wall_time) -> str | None:
        prefactor = FORCE_SCALING / 2.0 * self.rho_out * self.rho_out
        self.nb.max_drift = kernels.move(self.positions, self.nominal, self.frame.lengths, self.frame.periodic,
                                         self.walls, self.has_walls, self.rho_in, self.forces, prefactor,
                                         self.nb.drift)
        self.rho_in = self._compute_forces()
        self.rho_out = _shrink(self.rho_out, self.rho_in, self.rho_out0, self.rate, self.phi_nominal, self.dim)
        self.iteration += 1
        self._add_row(wall_time())
        return self.stop_before()

    def report(self, progress, stop, wall_time) -> None:
        phi_in, phi_out = self.phi, self.phi_nominal * self.rho_out**self.dim
        progress.update(f"iteration {self.iteration}: phi_inner {phi_in:.6f}, phi_outer {phi_out:.6f}",
                        fields={"iteration": self.iteration, "φ_in": phi_in, "φ_out": phi_out,
                                "iterations/s": per_second(self.iteration, wall_time)},
                        bar=(phi_in / phi_out, "φ_in/φ_out"))

    def finish(self, wall_time) -> None:
        self._add_row(wall_time, force=True)  # the last iteration, also off the history's stride

    @property
    def steps(self) -> int:
        return self.iteration

    @property
    def collisions(self) -> None:
        return None

    @property
    def phi_initial(self) -> float:
        return self._phi_initial

    @property
    def phi(self) -> float:
        return self.phi_nominal * self.rho_in**self.dim

    def extras(self) -> FBCounts:
        return FBCounts(phi_outer=self.phi_nominal * self.rho_out**self.dim, rho_inner=self.rho_in,
                        rho_outer=self.rho_out, neighbour_rebuilds=self.nb.rebuilds,
                        history_stride=self.history.stride)

    def result(self, stats: RunStats) -> Packing:
        metadata = {"algorithm": "fb", "parameters": self.parameters, "counters": stats.as_dict()}
        if "seed" in self.input.metadata:
            metadata["seed"] = self.input.metadata["seed"]
        if "size_distribution" in self.input.metadata:  # the seed's distribution and sample descriptors
            metadata["size_distribution"] = self.input.metadata["size_distribution"]
        result = Packing(self.positions, self.nominal * self.rho_in, self.input.box, metadata, self.input.container)
        result.validate(what="FB result")
        return result


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
        Start configuration. Its relative diameters are the nominal sizes; its box or container is kept (in a
        container every centre must lie inside the walls, as a Poisson packing's do). Overlaps are allowed.
    rate : float
        Contraction rate gamma (dimensionless, per iteration), 0 < gamma < 1.
    phi_nominal : float, optional
        Nominal density: the nominal diameters are scaled to fill this fraction of the box (of the container's
        volume, inside its walls). ``None`` (default) uses
        the paper's rule :func:`nominal_density_for_rate` (d = 3 only).
    max_iterations : int, optional
        Stop after this many iterations in all (counting those before a resume); the result is then unfinished and
        the checkpoint, if any, is kept.
    max_wall_time, checkpoint, checkpoint_interval, progress_interval :
        The run options (:class:`spherejam.engines.driver.RunOptions`): seconds of this call (unfinished result,
        checkpoint kept); the HDF5 checkpoint (resumed from if it matches, written every ``checkpoint_interval``
        s and when the run stops early, deleted when the run converges); seconds between progress lines.

    Returns
    -------
    RunResult
        ``packing`` at the inner (actual) diameters, overlap-free with the closest pair touching; ``history``
        columns ``iteration, phi_inner, phi_outer, max_overlap, wall_time`` (max_overlap = 1 - rho_in/rho_out, the
        worst relative overlap of the outer spheres; wall_time in s since the run began, resumes included);
        ``stats`` (:class:`~spherejam.engines.result.RunStats`: stop_reason "converged", "max_iterations" or
        "max_wall_time"; steps = iterations; collisions None; phi_final = phi_inner; extras
        :class:`~spherejam.engines.result.FBCounts`). The history has one row per iteration (plus iteration 0,
        the start) up to 2 * MAX_HISTORY_ROWS rows; longer runs keep every 2^k-th iteration and always the last.
    """
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
    options = RunOptions(max_wall_time=max_wall_time, checkpoint=checkpoint,
                         checkpoint_interval=checkpoint_interval, progress_interval=progress_interval)
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
        "box": packing.box,
        "sigma": packing.polydispersity,
    }
    if not packing.container.is_periodic_cube:  # (the periodic cube keeps its parameters and fingerprint as before)
        parameters.update(box=None, container=packing.container.spec)
    budget_free = {k: v for k, v in parameters.items() if k not in ("max_iterations", "max_wall_time")}
    if not packing.container.is_periodic_cube:
        budget_free["frame"] = packing.container.to_dict()
    run = FBRun(packing, rate, phi_nominal, max_iterations, parameters)
    return drive(run, options, fingerprint(packing, CHECKPOINT_KIND, budget_free))
