"""The experiment design: from a validated config to the list of packings, their seeds and file paths.

Both the Snakefile (to define its targets) and the dataset builder (to know which files belong to the experiment)
use this module, so the two can never disagree. It has no Snakemake dependency.

A config (see ``config/schema.yaml``) names the spheres per packing, the polydispersities sigma, the LS and FB
compression-rate grids gamma, the number of replicas, the MLS parameters, and the parameter-validation grid.
"""

from __future__ import annotations

import hashlib
import itertools
import json
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from ..core.errors import InputError

PROTOCOLS = ("ls", "fb")


def fmt(x: float) -> str:
    """Canonical text of a number in paths and wildcards (``0.3``, ``0.01``, ``1e-05``)."""
    return format(float(x), "g")


def derive_seed(master: int, *labels: object) -> int:
    """A deterministic 63-bit seed from the master seed and labels (protocol, sigma, rate, replica, purpose)."""
    text = "/".join([str(int(master))] + [fmt(x) if isinstance(x, float) else str(x) for x in labels])
    return int.from_bytes(hashlib.sha256(text.encode()).digest()[:8], "little") >> 1


def rate_grid(spec) -> list[float]:
    """Compression rates gamma from a list, or from ``{min, max, count}`` (log-spaced, inclusive)."""
    if isinstance(spec, dict):
        import numpy as np

        lo, hi, count = float(spec["min"]), float(spec["max"]), int(spec["count"])
        if not (0 < lo <= hi) or count < 1:
            raise InputError(f"rates={spec!r}: need 0 < min <= max and count >= 1")
        return [float(f"{r:.6g}") for r in np.geomspace(lo, hi, count)]
    return [float(r) for r in spec]


def check_grid_rates(grid_rates: list[float], ls_rates: list[float]) -> None:
    """The validation grid re-jams LS packings of the experiment (Fig. 3 is compared with Fig. 2b on the same
    packings), so every rate of ``validation_grid.ls_rates`` must be one of ``ls.rates``, to the digits of the file
    paths (:func:`fmt`). A rate that is not is an error naming it and the nearest rate of ``ls.rates``; it is not
    replaced silently, and no packing outside the experiment is generated."""
    import math

    known = {fmt(r) for r in ls_rates}
    for rate in grid_rates:
        if fmt(rate) not in known:
            nearest = min(ls_rates, key=lambda r: abs(math.log(r / rate)))
            raise InputError(
                f"validation_grid.ls_rates={fmt(rate)}: not one of ls.rates (nearest: {fmt(nearest)}); the grid "
                "re-jams packings of the experiment, so its rates must be taken from ls.rates"
            )


def config_hash(config: dict[str, Any]) -> str:
    return hashlib.sha256(json.dumps(config, sort_keys=True, default=str).encode()).hexdigest()[:16]


@dataclass(frozen=True)
class Run:
    """One generated packing: protocol (``ls``/``fb``), sigma, compression rate gamma and replica index."""

    protocol: str
    sigma: float
    rate: float
    replica: int

    @property
    def key(self) -> str:
        return f"{self.protocol}/sigma{fmt(self.sigma)}/rate{fmt(self.rate)}/r{self.replica}"

    def seed(self, master: int, purpose: str = "poisson") -> int:
        return derive_seed(master, self.protocol, float(self.sigma), float(self.rate), self.replica, purpose)


@dataclass(frozen=True)
class GridRun:
    """One MLS run of the parameter-validation grid on the LS packing ``source``."""

    source: Run
    decrease_factor: float
    initial_rate: float
    final_rate: float

    @property
    def key(self) -> str:
        return (
            f"{self.source.key}/f{fmt(self.decrease_factor)}_g{fmt(self.initial_rate)}_gf{fmt(self.final_rate)}"
        )


class Experiment:
    """Runs and paths of one validated config. ``results`` is the output folder (default ``results``)."""

    def __init__(self, config: dict[str, Any]):
        self.config = config
        try:
            self.results = Path(config.get("results", "results"))
            self.n = int(config["n"])
            self.master_seed = int(config["seed"])
            self.sigmas = [float(s) for s in config["sigmas"]]
            self.replicas = int(config.get("replicas", 1))
            self.rates = {p: rate_grid(config[p]["rates"]) for p in PROTOCOLS}
            # extra rates for some sigmas only (e.g. the slow series of Table 2, which sigma = 0 does not use)
            self.extra_rates = {
                p: [([float(s) for s in e["sigmas"]], rate_grid(e["rates"])) for e in config[p].get("extra_rates", [])]
                for p in PROTOCOLS
            }
            grid = config.get("validation_grid", {})
        except (KeyError, TypeError, ValueError) as exc:
            raise InputError(f"config: missing or malformed key {exc}") from None
        known = {fmt(s) for s in self.sigmas}
        for p in PROTOCOLS:
            for sigmas, _ in self.extra_rates[p]:
                for s in sigmas:
                    if fmt(s) not in known:
                        raise InputError(f"{p}.extra_rates.sigmas={fmt(s)}: not one of sigmas")
        self.grid_enabled = bool(grid.get("enabled", False))
        self.grid = grid
        if self.grid_enabled:
            for sigma in grid.get("sigmas", []):
                if fmt(sigma) not in known:  # its LS packings would not be in the experiment either
                    raise InputError(f"validation_grid.sigmas={fmt(sigma)}: not one of sigmas")
                check_grid_rates(rate_grid(grid.get("ls_rates", [])), self.rates_for("ls", float(sigma)))

    def rates_for(self, protocol: str, sigma: float) -> list[float]:
        """Compression rates gamma of one protocol at one sigma: ``rates`` plus the ``extra_rates`` of that sigma,
        in the order given, without repeats (same digits as the file paths)."""
        rates = list(self.rates[protocol])
        for sigmas, extra in self.extra_rates[protocol]:
            if any(fmt(sigma) == fmt(s) for s in sigmas):
                rates += extra
        unique: dict[str, float] = {}
        for r in rates:
            unique.setdefault(fmt(r), r)
        return list(unique.values())

    # --- runs ----------------------------------------------------------------------------------------------------
    def runs(self, protocol: str | None = None) -> list[Run]:
        protocols = PROTOCOLS if protocol is None else (protocol,)
        return [
            Run(p, s, r, k)
            for p in protocols
            for s in self.sigmas
            for r in self.rates_for(p, s)
            for k in range(self.replicas)
        ]

    def figure1_run(self) -> Run:
        """The run whose closest jammed configuration Fig. 1 shows: the largest sigma, generated (as in the paper)
        by the force-biased algorithm (LS if there are no FB runs) at its fastest rate, replica 0."""
        runs = [r for r in self.runs("fb") if r.replica == 0] or [r for r in self.runs("ls") if r.replica == 0]
        return max(runs, key=lambda r: (r.sigma, r.rate))

    def grid_runs(self) -> list[GridRun]:
        if not self.grid_enabled:
            return []
        g = self.grid
        # the experiment's own rate values (equal to the grid's under fmt), so grid runs match their packing exactly
        canonical = {float(s): {fmt(x): x for x in self.rates_for("ls", float(s))} for s in g["sigmas"]}
        sources = [
            Run("ls", float(s), canonical[float(s)].get(fmt(float(r)), float(r)), k)
            for s in g["sigmas"]
            for r in rate_grid(g["ls_rates"])
            for k in range(int(g.get("replicas", 1)))
        ]
        return [
            GridRun(src, float(f), float(g0), float(gf))
            for src, f, g0, gf in itertools.product(
                sources, g["decrease_factors"], g["initial_rates"], g["final_rates"]
            )
        ]

    # --- paths -----------------------------------------------------------------------------------------------------
    def packing_dir(self, run: Run) -> Path:
        return self.results / "packings" / run.key

    def path(self, run: Run, stage: str) -> Path:
        """File of a run: stage is ``poisson``, ``initial`` (LS/FB output), ``jammed`` (MLS), ``structure``
        (analysis JSON of the jammed packing) or ``calippso`` (certification JSON)."""
        suffix = ".json" if stage in ("structure", "calippso") else ".h5"
        return self.packing_dir(run) / f"{stage}{suffix}"

    def grid_path(self, grid_run: GridRun) -> Path:
        return self.results / "validation" / f"{grid_run.key}.h5"

    def iter_all_outputs(self) -> Iterator[Path]:
        for run in self.runs():
            for stage in ("initial", "jammed"):
                yield self.path(run, stage)
        for grid_run in self.grid_runs():
            yield self.grid_path(grid_run)


def parse_run(protocol: str, sigma: str, rate: str, replica: str) -> Run:
    """A :class:`Run` from path wildcards."""
    return Run(protocol, float(sigma), float(rate), int(replica))
