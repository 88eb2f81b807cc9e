"""The experiment design: from a validated config to the list of packings, their seeds and file paths.

Both the Snakefile (to define its targets, inputs, seeds and command-line arguments) and the dataset builder (to know
which files belong to the experiment) use this module, so the two can never disagree: the rules in ``rules/`` spell
no path, seed or config-derived argument themselves. It has no Snakemake dependency; the rules hand their
``wildcards`` (any object with the wildcard names as attributes) to :meth:`Run.from_wildcards` and friends.

A config (see ``config/schema.yaml``) names the spheres per packing, the size distributions (``sigmas``, the
paper's log-normals, and ``distributions``, any named spec of :mod:`spherejam.core.size_distribution`), the LS and FB
compression-rate grids gamma, the number of replicas, the MLS parameters, and the parameter-validation grid.

The experiment has three axes:

* the **distribution** (:class:`Distribution`), keyed in paths, seeds and the dataset by its key: ``sigma0.1`` for
  an entry of ``sigmas`` (the paths and seeds of spherejam 0.1, unchanged) or the name given in ``distributions``
  (``powder``);
* the **number of spheres N** (``n``). A single number keeps the paths and seeds of spherejam 0.1; a list (a
  ladder of N, for finite-size scaling, docs/finite_size.md) puts each N first in the run key (``n1000/...``) and
  in the seeds, so packings at different N are independent;
* the **container** (:class:`ContainerEntry`, ``containers``: name -> spec of :mod:`spherejam.core.container`).
  Without it, or with only ``periodic``, every packing fills the periodic cube, with the paths and seeds of before
  containers. With any other container, each run key starts with the container's name (after ``n<N>/`` of a ladder:
  ``column/ls/sigma0/rate0.5/r0``) and every seed has the label ``container:<name>``. A container that leaves a
  length free (``cylinder:diameter=10``) takes the experiment's N and solves that length; one that gives every
  length (``sphere:diameter=12``) fixes N itself (:meth:`Experiment.size`). CALiPPSO certifies the packings of
  every container (its wall rows: docs/containers.md §5).

Files below the results folder ``<results>``:

* ``packings/<run key>/{poisson,initial,jammed}.h5``, ``structure.json``, ``calippso.json``, ``calippso.h5``: one
  packing's stages (:data:`PACKING_FILES`), run key ``ls/sigma0.1/rate0.5/r0`` or ``fb/powder/rate0.01/r2``
  (:data:`RUN_KEY`), with a ladder of N ``n1000/ls/sigma0.1/rate0.5/r0`` (:data:`N_LADDER_KEY`);
* ``validation/<grid key>.h5``: the MLS output of one validation-grid run (:data:`GRID_KEY`);
* ``logs/``, ``benchmarks/``, ``checkpoints/``: per job, in the folder of its kind (:data:`JOB_FOLDERS`);
* ``experiment.json``, ``dataset.nc``, ``tables/``, ``figures/``: the experiment as a whole.
"""

from __future__ import annotations

import hashlib
import itertools
import json
import math
import re
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from ..core.errors import InputError

PROTOCOLS = ("ls", "fb")

#: Key of one generated packing, the folder of its files below ``packings/``; braces are the wildcards of the rules.
#: ``dist`` is the distribution's key (``sigma0.1``, or a name of ``distributions``).
RUN_KEY = "{protocol}/{dist}/rate{rate}/r{replica}"
#: Run key of an experiment with a ladder of N (``n`` a list): N first, so each N's packings share one folder.
N_LADDER_KEY = "n{n}/" + RUN_KEY
#: The container's part of a run key in an experiment with containers (after ``n<N>/`` of a ladder).
CONTAINER_PREFIX = "{container}/"
#: Container names that would read as another part of a run key.
_RESERVED_CONTAINER = re.compile(r"(ls|fb|n\d+|sigma[0-9].*)")
#: The part of a validation-grid run's key after its packing's: its MLS ladder (decrease factor f, initial and final
#: rate).
GRID_SUFFIX = "/f{factor}_g{g0}_gf{gf}"
#: Key of one validation-grid run: the LS packing it re-jams, then its MLS ladder.
GRID_KEY = RUN_KEY + GRID_SUFFIX
_NUMBER = r"[0-9][0-9.e+-]*"
#: A name in ``distributions``: a letter, then letters, digits, ``_`` or ``-`` (it is a folder name and a wildcard).
NAME_PATTERN = r"[A-Za-z][A-Za-z0-9_-]*"
_SHORTHAND = re.compile(r"sigma([0-9][0-9.e+-]*)")
#: What each wildcard of the keys may match (the workflow's global ``wildcard_constraints``).
#: ``dist`` is a name or ``sigma`` followed by a number (``sigma0.1``, ``sigma1e-05``).
WILDCARD_CONSTRAINTS = {"n": r"\d+", "protocol": "|".join(PROTOCOLS), "dist": r"[A-Za-z][A-Za-z0-9_.+-]*",
                        "rate": _NUMBER, "replica": r"\d+", "factor": _NUMBER, "g0": _NUMBER, "gf": _NUMBER,
                        "container": NAME_PATTERN}

#: The files of one packing below ``packings/<run key>/``, by stage: the Poisson start, the LS or FB output, the MLS
#: output, its structure analysis, CALiPPSO's summary and CALiPPSO's packing (with its contacts and forces).
PACKING_FILES = {"poisson": "poisson.h5", "initial": "initial.h5", "jammed": "jammed.h5",
                 "structure": "structure.json", "calippso": "calippso.json", "calippso_packing": "calippso.h5"}

#: Folder of each per-packing job's log, benchmark and checkpoint below ``logs/``, ``benchmarks/`` and
#: ``checkpoints/``, and whether its key is a run's or a validation-grid run's. The job names are the rules' and the
#: cost model's stages; LS and FB jobs are filed by protocol (``logs/ls/sigma0.1/rate0.5/r0.log``).
JOB_FOLDERS = {"seed": ("seed", "run"), "ls": ("", "run"), "fb": ("", "run"), "mls": ("mls", "run"),
               "analyze": ("structure", "run"), "calippso": ("calippso", "run"), "mls_grid": ("validation", "grid"),
               "view": ("views", "run")}

#: The paper's tables and the figures drawn from the dataset (Fig. 1, a rendered packing, is apart).
TABLE_NAMES = ("table2", "table3", "table4")
TABLE_FORMATS = ("csv", "md", "tex")
FIGURE_NAMES = ("fig2", "fig3", "fig4", "fig5", "fig6", "fig7", "structure", "forces", "scaling", "containers",
                "profiles")
#: Figures that need packings at several N.
N_LADDER_FIGURES = ("scaling",)
#: Figures that need containers with walls (spherejam.workflow.container_figures).
CONTAINER_FIGURES = ("containers", "profiles")
FIGURE_FORMATS = ("png", "pdf")


def fmt(x: float) -> str:
    """Canonical text of a number in paths and wildcards (``0.3``, ``0.01``, ``1e-05``)."""
    return format(float(x), "g")


def check_distinct_paths(values, where: str) -> None:
    """Refuse two different numbers that :func:`fmt` prints alike: their runs would share one path, and one would
    silently replace the other. (Equal numbers given twice are one run.) ``where`` names the config list."""
    seen: dict[str, float] = {}
    for i, value in enumerate(values):
        first = seen.setdefault(fmt(value), float(value))
        if first != float(value):
            raise InputError(f"{where}[{i}]={value!r}: differs from {first!r} only beyond the 6 significant digits "
                             f"of the file paths (both would be {fmt(value)!r}); make them differ within 6 digits "
                             "or drop one")


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


def shorthand_key(sigma: float) -> str:
    """The key of the ``sigmas`` entry sigma (``sigma0.1``): the folder of its packings since spherejam 0.1."""
    return f"sigma{fmt(sigma)}"


@dataclass(frozen=True)
class Distribution:
    """One value of the experiment's axis: a size distribution with its key and spec.

    ``sigma`` is set for the ``sigmas`` shorthand (a log-normal with the paper's sigma), None for a named entry of
    ``distributions``. ``files`` are the PSD files its spec reads (inputs of the seeding jobs)."""

    key: str
    spec: str
    sigma: float | None = None

    @property
    def files(self) -> list[str]:
        family, _, rest = self.spec.partition(":")
        return [rest.strip()] if family.strip().lower() in ("table", "list") else []

    def model(self):
        """The :class:`~spherejam.core.size_distribution.SizeDistribution` (reads a table or list file)."""
        from ..core.size_distribution import parse

        return parse(self.spec, f"distributions.{self.key}" if self.sigma is None else f"sigmas[{fmt(self.sigma)}]")

    @property
    def paper_sigma(self) -> float:
        """The paper's sigma if this is one of its log-normals (shorthand, or a named ``lognormal:`` spec), else NaN:
        where the paper's values apply."""
        if self.sigma is not None:
            return float(self.sigma)
        family, _, rest = self.spec.partition(":")
        if family.strip().lower() == "lognormal":
            return float(self.model().sigma)
        return math.nan


def distributions_of(config: dict[str, Any]) -> list[Distribution]:
    """The experiment's distributions in order: ``sigmas`` (ascending, as given), then ``distributions`` (as
    given). Raises :class:`InputError` for a bad name or a name that shadows a ``sigma<number>`` key."""
    from ..core.size_distribution import lognormal_spec

    out = [Distribution(shorthand_key(s), lognormal_spec(s), float(s)) for s in config.get("sigmas") or []]
    for name, spec in _named_specs(config, "distributions", _SHORTHAND, "sigma<number>, the key of the sigmas "
                                   "shorthand", "'gaussian:delta=0.2'"):
        out.append(Distribution(name, spec.strip()))
    return out


def _named_specs(config: dict, field: str, reserved: re.Pattern, why_reserved: str, example: str):
    """The (name, spec) pairs of the mapping ``config[field]``, each checked: a name is a letter then letters,
    digits, _ or -, and not one that ``reserved`` matches; a spec is a string. A bad one: one line naming it."""
    named = config.get(field) or {}
    if not isinstance(named, dict):
        raise InputError(f"{field}={named!r}: must be a mapping of names to specs, e.g. {{name: {example}}}")
    for name, spec in named.items():
        if not isinstance(name, str) or not re.fullmatch(NAME_PATTERN, name) or reserved.fullmatch(name):
            raise InputError(f"{field}.{name}: a name is a letter then letters, digits, _ or - (and not "
                             f"{why_reserved})")
        if not isinstance(spec, str):
            raise InputError(f"{field}.{name}={spec!r}: must be a spec string such as {example}")
        yield name, spec


@dataclass(frozen=True)
class ContainerEntry:
    """One value of the container axis: its name (``key``, in run keys and seeds) and its spec in canonical form
    (:attr:`spherejam.core.container.ContainerSpec.text`)."""

    key: str
    spec: str

    @property
    def is_periodic_cube(self) -> bool:
        """The periodic cube, which every stage handles (CALiPPSO, g(r), Voronoi, pores)."""
        return self.spec == "periodic"

    def model(self):
        """The parsed :class:`~spherejam.core.container.ContainerSpec`."""
        from ..core.container import parse

        return parse(self.spec, f"containers.{self.key}")

    @property
    def shape(self) -> str:
        return self.spec.partition(":")[0]


def containers_of(config: dict[str, Any]) -> list[ContainerEntry]:
    """The experiment's containers in the order given (``containers``; none: the periodic cube alone). Raises
    :class:`InputError` naming a bad name or spec."""
    from ..core.container import parse

    out = []
    for name, spec in _named_specs(config, "containers", _RESERVED_CONTAINER, "ls, fb, n<number> or sigma<number>, "
                                   "which would read as another part of a run key", "'cylinder:diameter=10'"):
        out.append(ContainerEntry(name, parse(spec, f"containers.{name}").text))
    specs = [c.spec for c in out]
    for i, c in enumerate(out):
        if specs.index(c.spec) != i:
            raise InputError(f"containers.{c.key}={c.spec!r}: the same container as containers."
                             f"{out[specs.index(c.spec)].key}")
    return out or [ContainerEntry("periodic", "periodic")]


def config_hash(config: dict[str, Any]) -> str:
    return hashlib.sha256(json.dumps(config, sort_keys=True, default=str).encode()).hexdigest()[:16]


@dataclass(frozen=True)
class Run:
    """One generated packing: protocol (``ls``/``fb``), distribution key ``dist`` (``sigma0.1`` or a name; a number
    is read as the sigma of the ``sigmas`` shorthand), compression rate gamma, replica index and, in an experiment
    with a ladder of N, its number of spheres ``n`` (None: the experiment's single N, not part of key or seed)."""

    protocol: str
    dist: str
    rate: float
    replica: int
    n: int | None = None
    container: str | None = None  #: the container's name in an experiment with containers (else None)

    def __post_init__(self):
        if not isinstance(self.dist, str):
            object.__setattr__(self, "dist", shorthand_key(float(self.dist)))

    @classmethod
    def from_wildcards(cls, wildcards) -> Run:
        """The run of a job from its wildcards ``protocol``, ``dist``, ``rate``, ``replica`` and, with a ladder of
        N, ``n`` (path text)."""
        n = getattr(wildcards, "n", None)
        container = getattr(wildcards, "container", None)
        return cls(wildcards.protocol, str(wildcards.dist), float(wildcards.rate), int(wildcards.replica),
                   None if n is None else int(n), None if container is None else str(container))

    @property
    def sigma(self) -> float:
        """The sigma of a ``sigmas`` shorthand run, NaN for a named distribution."""
        m = _SHORTHAND.fullmatch(self.dist)
        return float(m.group(1)) if m else math.nan

    @property
    def key(self) -> str:
        return run_pattern(self.n is not None, self.container is not None).format(
            n=self.n, container=self.container, protocol=self.protocol, dist=self.dist, rate=fmt(self.rate),
            replica=self.replica)

    def seed(self, master: int, purpose: str = "poisson") -> int:
        """The seed for ``purpose``; a ``sigmas`` run's label is its sigma (the seeds of spherejam 0.1), a named
        distribution's is ``psd:<name>``; a run of a ladder of N has ``n<N>`` first, a run of an experiment with
        containers ``container:<name>`` next."""
        m = _SHORTHAND.fullmatch(self.dist)
        label = float(m.group(1)) if m else f"psd:{self.dist}"
        size = () if self.n is None else (f"n{self.n}",)
        where = () if self.container is None else (f"container:{self.container}",)
        return derive_seed(master, *size, *where, self.protocol, label, float(self.rate), self.replica, purpose)


def run_pattern(n_ladder: bool, containers: bool) -> str:
    """The run-key pattern of an experiment: :data:`RUN_KEY`, with the container's name first if it has
    containers, and ``n<N>/`` before that for a ladder of N."""
    return ("n{n}/" if n_ladder else "") + (CONTAINER_PREFIX if containers else "") + RUN_KEY


@dataclass(frozen=True)
class GridRun:
    """One MLS run of the parameter-validation grid on the LS packing ``source``."""

    source: Run
    decrease_factor: float
    initial_rate: float
    final_rate: float

    @classmethod
    def from_wildcards(cls, wildcards) -> GridRun:
        """The grid run of a job from its wildcards (those of :meth:`Run.from_wildcards` and ``factor``, ``g0``,
        ``gf``)."""
        return cls(Run.from_wildcards(wildcards), float(wildcards.factor), float(wildcards.g0), float(wildcards.gf))

    @property
    def key(self) -> str:
        return self.source.key + GRID_SUFFIX.format(factor=fmt(self.decrease_factor), g0=fmt(self.initial_rate),
                                                    gf=fmt(self.final_rate))

    @property
    def ladder(self) -> dict[str, float]:
        """The MLS rate ladder (keywords of :func:`spherejam.workflow.cost_model.runtime_minutes`)."""
        return {"initial_rate": self.initial_rate, "decrease_factor": self.decrease_factor,
                "final_rate": self.final_rate}

    def seed(self, master: int) -> int:
        """Seed of the MLS velocities: the source packing's, for a purpose naming the ladder."""
        ladder = "-".join(fmt(x) for x in (self.decrease_factor, self.initial_rate, self.final_rate))
        return self.source.seed(master, f"grid-{ladder}")


@dataclass(frozen=True)
class Part:
    """A part of an experiment, run and assembled apart (docs/cluster.md, "A run in parts"): its cells, each a
    number of spheres N and a size-distribution key. A part's dataset holds the packings of its cells; the datasets
    of parts that cover the experiment merge into the dataset of the whole run (:func:`spherejam.workflow.dataset.
    merge_datasets`)."""

    cells: frozenset[tuple[int, str]]

    def holds(self, exp: Experiment, run: Run) -> bool:
        return (exp.cell_n(run), run.dist) in self.cells

    @property
    def label(self) -> str:
        return ", ".join(f"n{n}/{d}" for n, d in sorted(self.cells))


class Paths:
    """Every file of the workflow below one results folder, as text (what Snakemake takes). A ``key`` is a
    :attr:`Run.key` or :attr:`GridRun.key`; by default it is the wildcard pattern the rules use, with an ``{n}``
    wildcard for a ladder of N (``n_ladder``)."""

    def __init__(self, results: Path, n_ladder: bool = False, containers: bool = False):
        self.results = results
        self.run_pattern = run_pattern(n_ladder, containers)
        self.grid_pattern = self.run_pattern + GRID_SUFFIX
        #: the run pattern with the container's name, also in an experiment without containers (the rule of seeding
        #: in a container has it always; with no container it matches no file)
        self.container_run_pattern = run_pattern(n_ladder, True)

    def _file(self, *parts: str) -> str:
        return str(self.results.joinpath(*parts))

    def _run(self, key: str | None, container: bool) -> str:
        return key if key is not None else self.container_run_pattern if container else self.run_pattern

    def packing(self, stage: str, key: str | None = None, container: bool = False) -> str:
        """A file of one packing: stage is a key of :data:`PACKING_FILES`; ``container``: the pattern with the
        container's name (:attr:`container_run_pattern`)."""
        return self._file("packings", self._run(key, container), PACKING_FILES[stage])

    def grid(self, key: str | None = None) -> str:
        """The MLS output of one validation-grid run."""
        return self._file("validation", f"{self.grid_pattern if key is None else key}.h5")

    def _job(self, kind: str, job: str, key: str | None, suffix: str, container: bool = False) -> str:
        folder, which = JOB_FOLDERS[job]
        pattern = self._run(None, container) if which == "run" else self.grid_pattern
        return self._file(kind, folder, f"{pattern if key is None else key}{suffix}")

    def log(self, job: str, key: str | None = None, container: bool = False) -> str:
        """Log of a per-packing job (a key of :data:`JOB_FOLDERS`)."""
        return self._job("logs", job, key, ".log", container)

    def benchmark(self, job: str, key: str | None = None) -> str:
        return self._job("benchmarks", job, key, ".tsv")

    def checkpoint(self, job: str, key: str | None = None) -> str:
        """Checkpoint of a long job: a job cut at its time limit resumes from it."""
        return self._job("checkpoints", job, key, ".h5")

    def experiment_log(self, name: str) -> str:
        """Log of a job of the whole experiment (``experiment_manifest``, ``dataset``, ``tables``)."""
        return self._file("logs", f"{name}.log")

    def figure_log(self, name: str = "{name}") -> str:
        return self._file("logs", "figures", f"{name}.log")

    @property
    def manifest(self) -> str:
        return self._file("experiment.json")

    @property
    def dataset(self) -> str:
        return self._file("dataset.nc")

    def dataset_part(self, n: int | str = "{n}", dist: str = "{dist}") -> str:
        """The dataset of one cell of the experiment (its packings at one N of one distribution): a
        :class:`Part` run on its own."""
        return self._file("parts", f"n{n}", str(dist), "dataset.nc")

    def table(self, name: str, ext: str) -> str:
        return self._file("tables", f"{name}.{ext}")

    def tables(self, formats=TABLE_FORMATS) -> list[str]:
        """Tables 2-4 in each of ``formats``."""
        return [self.table(name, ext) for name in TABLE_NAMES for ext in formats]

    def figure(self, ext: str, name: str = "{name}") -> str:
        return self._file("figures", f"{name}.{ext}")

    def view(self, key: str | None = None) -> str:
        """The interactive page (``spherejam view``) of one jammed packing."""
        return self._file("views", f"{self.run_pattern if key is None else key}.html")

    def figures(self, names=FIGURE_NAMES) -> list[str]:
        """The figures ``names`` in every format."""
        return [self.figure(ext, name) for name in names for ext in FIGURE_FORMATS]


def sizes_of(config: dict[str, Any]) -> tuple[list[int], bool]:
    """The experiment's numbers of spheres N in ascending order, and whether they form a ladder (``n`` given as a
    list, even of one N: each N is then in the paths and seeds). Raises :class:`InputError` naming a bad value."""
    value = config["n"]
    n_ladder = isinstance(value, (list, tuple))
    values = list(value) if n_ladder else [value]
    if n_ladder and not values:
        raise InputError("n=[]: give at least one N")
    for i, v in enumerate(values):
        if isinstance(v, bool) or not isinstance(v, int) or v < 2:
            where = f"n[{i}]" if n_ladder else "n"
            raise InputError(f"{where}={v!r}: must be an integer >= 2")
    if len(set(values)) != len(values):
        raise InputError(f"n={values!r}: an N appears twice")
    return sorted(int(v) for v in values), n_ladder


class Experiment:
    """Runs, seeds and paths of one validated config. ``results`` is the output folder (default ``results``);
    ``paths`` its :class:`Paths`; ``sizes`` the numbers of spheres N (one, or a ladder)."""

    def __init__(self, config: dict[str, Any]):
        self.config = config
        self._pair_loads: dict[tuple[str, int], float] = {}  # pair_load's cache
        self._certified: frozenset[Run] | None = None  # certified_sample's cache
        try:
            results = config.get("results", "results")
            if not isinstance(results, str) or not results.strip():
                raise InputError(f"results={results!r}: must name the output folder (default 'results'); an empty "
                                 "path would write into the current folder")
            self.results = Path(results)
            self.sizes, self.n_ladder = sizes_of(config)
            self.master_seed = int(config["seed"])
            self.sigmas = [float(s) for s in config.get("sigmas") or []]
            self.distributions = distributions_of(config)
            self.replicas = int(config.get("replicas", 1))
            self.rates = {p: rate_grid(config[p]["rates"]) for p in PROTOCOLS}
            # extra rates for some sigmas (and N of a ladder) only (e.g. the slow series of Table 2, which sigma = 0
            # does not use): (sigmas, rates, N or None for every N)
            self.extra_rates = {
                p: [([float(s) for s in e["sigmas"]], rate_grid(e["rates"]), e.get("n"))
                    for e in config[p].get("extra_rates", [])]
                for p in PROTOCOLS
            }
            grid = config.get("validation_grid", {})
        except (KeyError, TypeError, ValueError) as exc:
            raise InputError(f"config: missing or malformed key {exc}") from None
        if not self.distributions:
            raise InputError("sigmas: give sigmas or distributions (at least one size distribution)")
        self.containers = containers_of(config)
        check_distinct_paths(self.sigmas, "sigmas")
        keys = [d.key for d in self.distributions]
        if len(set(keys)) != len(keys):
            raise InputError(f"distributions: a key appears twice ({', '.join(keys)})")
        for d in self.distributions:
            if d.sigma is None:  # a named spec: parsed (and its file read) now, so a bad one fails before any job
                fixed = d.model().fixed_n
                if fixed is not None and self.sizes != [fixed]:
                    raise InputError(f"distributions.{d.key}={d.spec!r}: holds {fixed} diameters, n = "
                                     f"{config['n']}: set n to the list's length")
                for n in self.sizes:  # every N it is drawn at, so that no job fails for it later
                    try:
                        d.model().check_n(n)
                    except InputError as exc:
                        raise InputError(f"distributions.{d.key}: {exc}") from None
        #: whether the run keys and seeds carry the container (any container but the periodic cube)
        self.has_containers = any(not c.is_periodic_cube for c in self.containers)
        self._fixed_n = self._container_sizes()
        self.paths = Paths(self.results, self.n_ladder, self.has_containers)
        for p in PROTOCOLS:
            check_distinct_paths(self.rates[p], f"{p}.rates")
            for k, (_, extra, sizes) in enumerate(self.extra_rates[p]):
                check_distinct_paths(self.rates[p] + extra, f"{p}.rates + {p}.extra_rates[{k}].rates")
                for i, n in enumerate(sizes or []):
                    if n not in self.sizes:
                        raise InputError(f"{p}.extra_rates[{k}].n[{i}]={n!r}: not one of n {config['n']}")
        known = {fmt(s) for s in self.sigmas}
        for p in PROTOCOLS:
            for sigmas, _, _ in self.extra_rates[p]:
                for s in sigmas:
                    if fmt(s) not in known:
                        raise InputError(f"{p}.extra_rates.sigmas={fmt(s)}: not one of sigmas")
        self.grid_enabled = bool(grid.get("enabled", False))
        self.grid = grid
        if self.grid_enabled:
            for key in ("sigmas", "ls_rates", "initial_rates", "decrease_factors", "final_rates"):
                check_distinct_paths(grid.get(key, []), f"validation_grid.{key}")
            for sigma in grid.get("sigmas", []):
                if fmt(sigma) not in known:  # its LS packings would not be in the experiment either
                    raise InputError(f"validation_grid.sigmas={fmt(sigma)}: not one of sigmas")
                check_grid_rates(rate_grid(grid.get("ls_rates", [])), self.rates_for("ls", float(sigma)))

    def _container_sizes(self) -> dict[tuple[str, str], int]:
        """N of every (container, distribution) whose container gives every length (it fixes N), and a check that
        each container holds its spheres at every N it is filled with: a container too small is refused here, in
        one line, before any job."""
        import numpy as np

        from ..core import container as core_container

        fixed: dict[tuple[str, str], int] = {}
        if not self.has_containers:
            return fixed
        for c in self.containers:
            spec = c.model()
            for d in self.distributions:
                model = d.model()
                mean_volume = math.pi / 6.0 * model.descriptors().m3
                n_fixed = model.fixed_n or core_container.number_for(spec, mean_volume)
                where = f"containers.{c.key}={c.spec!r} with distributions.{d.key}"
                if core_container.number_for(spec, mean_volume) is not None:
                    if self.n_ladder:
                        raise InputError(f"containers.{c.key}={c.spec!r}: gives every length, which fixes N; a "
                                         "ladder of N needs a length left free (e.g. the cylinder's length)")
                    if not 2 <= n_fixed <= 10_000_000:
                        raise InputError(f"{where}: holds about {n_fixed} spheres (N must be 2 ... 10^7)")
                    fixed[c.key, d.key] = int(n_fixed)
                for n in ([fixed[c.key, d.key]] if (c.key, d.key) in fixed else self.sizes):
                    nominal = model.draw(model.fixed_n or n, np.random.default_rng(0))
                    try:
                        core_container.build(spec, None if (c.key, d.key) in fixed else n, nominal)
                    except InputError as exc:
                        raise InputError(f"containers.{c.key}: {exc} (N = {n}, distributions.{d.key})") from None
        return fixed

    def container(self, key: str | None) -> ContainerEntry:
        """The container of a run's container name (None: the periodic cube of an experiment without containers)."""
        if key is None:
            return self.containers[0] if not self.has_containers else ContainerEntry("periodic", "periodic")
        for c in self.containers:
            if c.key == key:
                return c
        raise InputError(f"container={key!r}: not one of {', '.join(c.key for c in self.containers)}")

    @property
    def container_keys(self) -> list[str | None]:
        """The runs' container names: the config's, or [None] without containers (no container in keys or seeds)."""
        return [c.key for c in self.containers] if self.has_containers else [None]

    @property
    def reference_container(self) -> str | None:
        """The container of the paper's figures and of the validation grid: the first periodic cube, else the first
        container (None without containers)."""
        if not self.has_containers:
            return None
        cubes = [c.key for c in self.containers if c.is_periodic_cube]
        return (cubes or [self.containers[0].key])[0]

    def certifies(self, run: Run) -> bool:
        """Whether CALiPPSO certifies ``run``: ``calippso.enabled`` (every container is certified) and, with
        ``calippso.per_cell: k``, ``run`` is one of the k packings of its cell that :meth:`certified_sample` draws."""
        if not self.config.get("calippso", {}).get("enabled", True):
            return False
        return self.calippso_per_cell is None or run in self.certified_sample()

    @property
    def calippso_per_cell(self) -> int | None:
        """``calippso.per_cell``: the packings certified per cell (None: every packing)."""
        k = self.config.get("calippso", {}).get("per_cell")
        return None if k is None else int(k)

    def certified_sample(self) -> frozenset[Run]:
        """With ``calippso.per_cell: k``, the packings CALiPPSO certifies: in each cell (N, container, size
        distribution; every protocol, rate and replica of it) the k whose SHA-256 of the master seed and run key
        ranks first (all of a cell with at most k). The choice depends only on the seed and the run keys, so the
        same config certifies the same packings, and a rate or replica added later leaves the others' ranks as
        they were."""
        if self._certified is None:
            k = self.calippso_per_cell
            cells: dict[tuple, list[Run]] = {}
            for run in self.runs():
                cells.setdefault((run.n, run.container, run.dist), []).append(run)

            def rank(run: Run) -> str:
                return hashlib.sha256(f"{self.master_seed}:calippso:{run.key}".encode()).hexdigest()
            self._certified = frozenset(r for runs in cells.values()
                                        for r in (runs if k is None else sorted(runs, key=rank)[:k]))
        return self._certified

    def distribution(self, key: str) -> Distribution:
        """The distribution of a key (``sigma0.1`` or a name)."""
        for d in self.distributions:
            if d.key == key:
                return d
        raise InputError(f"distribution={key!r}: not one of {', '.join(d.key for d in self.distributions)}")

    def rates_for(self, protocol: str, sigma: float | str, n: int | None = None) -> list[float]:
        """Compression rates gamma of one protocol at one distribution (a sigma of ``sigmas`` or a key) and N
        (None: the largest): ``rates`` plus the ``extra_rates`` of that sigma and N, in the order given, without
        repeats (same digits as the file paths). Extra rates are given for sigmas of the shorthand only."""
        rates = list(self.rates[protocol])
        key = sigma if isinstance(sigma, str) else shorthand_key(sigma)
        n = self.largest_n if n is None else n
        for sigmas, extra, sizes in self.extra_rates[protocol]:
            if any(key == shorthand_key(s) for s in sigmas) and (sizes is None or n in sizes):
                rates += extra
        unique: dict[str, float] = {}
        for r in rates:
            unique.setdefault(fmt(r), r)
        return list(unique.values())

    # --- runs ----------------------------------------------------------------------------------------------------
    @property
    def largest_n(self) -> int:
        """The largest N: the one closest to the paper's N = 10^4, drawn in the figures of a single N."""
        return self.sizes[-1]

    def cell_n(self, run: Run) -> int:
        """The experiment's N the run belongs to (its cell of a :class:`Part`): ``n``, or the run's N of a ladder."""
        return self.sizes[0] if run.n is None else run.n

    def size(self, run: Run) -> int:
        """The number of spheres N of a run: the experiment's (:meth:`cell_n`), or the one its container fixes."""
        return self._fixed_n.get((run.container, run.dist), self.cell_n(run))

    def size_of(self, wildcards) -> int:
        """N of a job, from its wildcards (a Snakemake ``params`` or resources function)."""
        return self.size(Run.from_wildcards(wildcards))

    def runs(self, protocol: str | None = None, n: int | None = None, part: Part | None = None) -> list[Run]:
        """The packings of the experiment (of one protocol, of one N of a ladder and of one part, if given), N
        outermost."""
        protocols = PROTOCOLS if protocol is None else (protocol,)
        sizes = [None] if not self.n_ladder else self.sizes if n is None else [n]
        runs = [
            Run(p, d.key, r, k, size, c)
            for size in sizes
            for c in self.container_keys
            for p in protocols
            for d in self.distributions
            for r in self.rates_for(p, d.key, size)
            for k in range(self.replicas)
        ]
        return runs if part is None else [r for r in runs if part.holds(self, r)]

    @property
    def cells(self) -> list[tuple[int, str]]:
        """Every (N, distribution key) of the experiment, in the order of its packings."""
        return [(n, d.key) for n in self.sizes for d in self.distributions]

    def part(self, sizes=None, dists=None) -> Part:
        """The part of the experiment with the N in ``sizes`` and the distribution keys in ``dists`` (None: all);
        an N or key the experiment does not have is an :class:`InputError` naming it."""
        for name, given, known in (("n", sizes, self.sizes), ("distribution", dists,
                                                              [d.key for d in self.distributions])):
            unknown = [x for x in (given or ()) if x not in known]
            if unknown:
                raise InputError(f"{name}={unknown[0]}: not in the experiment (one of "
                                 f"{', '.join(map(str, known))})")
        return Part(frozenset((n, d) for n, d in self.cells
                              if (sizes is None or n in sizes) and (dists is None or d in dists)))

    @property
    def several_n(self) -> bool:
        """Whether the experiment has packings at 2 or more N (what finite-size scaling needs; a ladder of one N has
        the paths and seeds of a ladder, but nothing to scale)."""
        return len(self.sizes) > 1

    @property
    def figure_names(self) -> tuple[str, ...]:
        """The figures of the experiment: every one of :data:`FIGURE_NAMES`, those of finite-size scaling only with
        packings at several N, those of containers only with containers."""
        return tuple(f for f in FIGURE_NAMES if (self.several_n or f not in N_LADDER_FIGURES)
                     and (self.has_containers or f not in CONTAINER_FIGURES))

    def largest_runs(self, protocol: str | None = None) -> list[Run]:
        """The packings at the largest N (all of them for a single N) in the :attr:`reference_container`."""
        return [r for r in self.runs(protocol, self.largest_n if self.n_ladder else None)
                if r.container == self.reference_container]

    def figure1_run(self) -> Run:
        """The run whose closest jammed configuration Fig. 1 shows: at the largest N, the largest sigma (of the
        ``sigmas``; else the first distribution), generated (as in the paper) by the force-biased algorithm (LS if
        there are no FB runs) at its fastest rate, replica 0."""
        runs = ([r for r in self.largest_runs("fb") if r.replica == 0]
                or [r for r in self.largest_runs("ls") if r.replica == 0])
        order = {d.key: i for i, d in enumerate(self.distributions)}
        return max(runs, key=lambda r: (r.sigma if r.sigma == r.sigma else -1.0, -order[r.dist], r.rate))

    def column_run(self) -> Run | None:
        """The packing the render of a packed column shows: in the first cylinder, at the largest N, chosen as
        :meth:`figure1_run` chooses among the bulk packings (None without a cylinder)."""
        cylinders = [c.key for c in self.containers if c.shape == "cylinder"] if self.has_containers else []
        if not cylinders:
            return None
        size = self.largest_n if self.n_ladder else None
        runs = ([r for r in self.runs("fb", size) if r.replica == 0 and r.container == cylinders[0]]
                or [r for r in self.runs("ls", size) if r.replica == 0 and r.container == cylinders[0]])
        order = {d.key: i for i, d in enumerate(self.distributions)}
        return max(runs, key=lambda r: (r.sigma if r.sigma == r.sigma else -1.0, -order[r.dist], r.rate))

    def view_runs(self) -> list[Run]:
        """The packings the report shows as interactive pages: per cell (container and size distribution) at the
        largest N, the one :meth:`figure1_run` would choose there (replica 0, FB at its fastest rate, else LS)."""
        size = self.largest_n if self.n_ladder else None
        out = []
        for c in self.container_keys:
            for d in self.distributions:
                runs = [r for r in self.runs("fb", size) if r.replica == 0 and r.container == c and r.dist == d.key]
                runs = runs or [r for r in self.runs("ls", size)
                                if r.replica == 0 and r.container == c and r.dist == d.key]
                if runs:
                    out.append(max(runs, key=lambda r: r.rate))
        return out

    def extra_figures(self) -> list[str]:
        """The outputs of ``all`` beyond the dataset, tables and figures that the config's ``figures`` switches on:
        Fig. 1, the packed column, the interactive pages."""
        switches = self.config.get("figures", {})
        out = self.paths.figures(["fig1"]) if switches.get("render_fig1", False) else []
        if switches.get("render_column", False) and self.column_run() is not None:
            out += self.paths.figures(["column"])
        if switches.get("view_pages", False):
            out += [self.paths.view(r.key) for r in self.view_runs()]
        return out

    def psd_inputs(self) -> list[str]:
        """Every PSD file of the experiment's distributions (inputs of the dataset, table and figure jobs too)."""
        return sorted({f for d in self.distributions for f in d.files})

    def figure1_options(self) -> str:
        """The ``spherejam render`` label flag of Fig. 1: ``--sigma S`` for a ``sigmas`` run (else the sample's)."""
        sigma = self.figure1_run().sigma
        return f"--sigma {fmt(sigma)}" if math.isfinite(sigma) else ""

    def pair_load(self, key: str, n: int) -> float:
        """The cost model's pair load W of distribution ``key`` at N spheres
        (:func:`spherejam.workflow.pair_load.pair_load`), from one draw of N diameters (seed 0: the expected sample
        at that N; a packing's own draw differs by its seed). Computed once per (key, N)."""
        cache = self._pair_loads
        if (key, n) not in cache:
            import numpy as np

            from .pair_load import pair_load

            model = self.distribution(key).model()
            draw = model.draw(model.fixed_n or n, np.random.default_rng(0))
            cache[key, n] = pair_load(draw.tolist())
        return cache[key, n]

    def load_of(self, wildcards) -> float:
        """The pair load W of a job's distribution at its N, from its wildcards (a Snakemake resources function)."""
        return self.pair_load(str(wildcards.dist), self.size_of(wildcards))

    def seed_container(self, wildcards) -> str:
        """The ``--container`` spec of a seeding job in a container, from its wildcards."""
        return self.container(str(wildcards.container)).spec

    def container_pattern(self, periodic_cube: bool) -> str:
        """The ``container`` wildcard's values of the seeding rule for the periodic cube (``periodic_cube``) or for
        the other containers: their names as a regular expression (one that matches nothing if there are none)."""
        keys = [c.key for c in self.containers if c.is_periodic_cube == periodic_cube] if self.has_containers else []
        return "|".join(re.escape(k) for k in keys) or "(?!)"

    def psd(self, wildcards) -> str:
        """The ``--psd`` spec of a seeding job, from its wildcards."""
        return self.distribution(str(wildcards.dist)).spec

    def psd_files(self, wildcards) -> list[str]:
        """The PSD files a seeding job reads (``table:``/``list:``), from its wildcards: inputs of the job, so that
        editing the file reruns what depends on it."""
        return self.distribution(str(wildcards.dist)).files

    def grid_runs(self, part: Part | None = None) -> list[GridRun]:
        """The validation-grid runs (re-jamming LS packings of the experiment; with a ladder, those at its largest
        N), of one part if given."""
        if not self.grid_enabled:
            return []
        if part is not None:
            return [g for g in self.grid_runs() if part.holds(self, g.source)]
        g = self.grid
        # the experiment's own rate values (equal to the grid's under fmt), so grid runs match their packing exactly
        canonical = {float(s): {fmt(x): x for x in self.rates_for("ls", float(s))} for s in g["sigmas"]}
        size = self.largest_n if self.n_ladder else None  # Fig. 3 at one N: the largest
        sources = [
            Run("ls", float(s), canonical[float(s)].get(fmt(float(r)), float(r)), k, size, self.reference_container)
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

    # --- seeds (Snakemake ``params`` functions of a job's wildcards) ---------------------------------------------
    def run_seed(self, purpose: str) -> Callable[[Any], int]:
        """The seed of a packing's job for ``purpose`` (``poisson``, ``ls``, ``mls``), from the job's wildcards."""
        return lambda wildcards: Run.from_wildcards(wildcards).seed(self.master_seed, purpose)

    def grid_seed(self, wildcards) -> int:
        """The seed of a validation-grid MLS job, from its wildcards."""
        return GridRun.from_wildcards(wildcards).seed(self.master_seed)

    # --- command-line arguments from the config --------------------------------------------------------------------
    @property
    def mls(self) -> dict[str, Any]:
        """The config's MLS section (the schema has filled in its defaults)."""
        return self.config["mls"]

    @property
    def mls_ladder(self) -> dict[str, float]:
        """The MLS rate ladder of the config (keywords of :func:`spherejam.workflow.cost_model.runtime_minutes`)."""
        return {k: self.mls[k] for k in ("initial_rate", "decrease_factor", "final_rate")}

    def mls_options(self) -> str:
        """The ``spherejam mls`` stall-rule and cut-off flags of the config."""
        mls = self.mls
        stall = mls["stall_windows"]
        flags = ["--no-stall-rule" if stall is None else f"--stall-windows {stall}"]
        if mls.get("max_collisions_per_particle") is not None:
            flags.append(f"--max-collisions-per-particle {mls['max_collisions_per_particle']}")
        if mls.get("max_wall_time") is not None:
            flags.append(f"--max-wall-time {mls['max_wall_time']}")
        return " ".join(flags)

    def fb_options(self) -> str:
        """The ``spherejam fb`` flags of the config: ``--phi-nominal`` if set (else FB's own default)."""
        phi = self.config["fb"].get("phi_nominal")
        return "" if phi is None else f"--phi-nominal {phi}"

    @property
    def calippso_threads(self) -> int:
        """Cores of one CALiPPSO job (the rule's ``threads``; the schema's default is 1)."""
        return int(self.config.get("calippso", {}).get("threads", 1))

    @property
    def calippso_interior_steps(self) -> bool | None:
        """``calippso.interior_steps``: True or False forces the LP path of every certification, None (absent or
        null) leaves it to N (:func:`spherejam.core.calippso_path.interior_steps_at`, docs/calippso.md §10.11)."""
        value = self.config.get("calippso", {}).get("interior_steps")
        return None if value is None else bool(value)

    def calippso_options(self) -> str:
        """The ``spherejam calippso`` flags of the config: ``--interior-steps`` or ``--no-interior-steps`` if
        ``calippso.interior_steps`` forces a path (else the package's rule by N)."""
        forced = self.calippso_interior_steps
        return "" if forced is None else ("--interior-steps" if forced else "--no-interior-steps")

    # --- paths -----------------------------------------------------------------------------------------------------
    def path(self, run: Run, stage: str) -> Path:
        """File of a run: stage is a key of :data:`PACKING_FILES` (``poisson``, ``initial`` (LS/FB output),
        ``jammed`` (MLS), ``structure`` (analysis JSON of the jammed packing), ``calippso`` (certification JSON),
        ``calippso_packing``)."""
        return Path(self.paths.packing(stage, run.key))

    def grid_path(self, grid_run: GridRun) -> Path:
        return Path(self.paths.grid(grid_run.key))

    def dataset_inputs(self, part: Part | None = None) -> list[str]:
        """Every file the dataset builder (:func:`spherejam.workflow.dataset.build_dataset`) reads besides the
        manifest: per packing its LS/FB and MLS outputs, its structure analysis (if enabled), CALiPPSO's summary and
        packing (if enabled); and every validation-grid output (of one part, if given)."""
        stages = ["initial", "jammed"]
        if self.config.get("analysis", {}).get("enabled", True):  # the schema's defaults
            stages.append("structure")
        files = []
        for run in self.runs(part=part):
            certified = ["calippso", "calippso_packing"] if self.certifies(run) else []
            files += [self.paths.packing(stage, run.key) for stage in stages + certified]
        return files + [self.paths.grid(g.key) for g in self.grid_runs(part)]


def mls_command(initial_rate: str, decrease_factor: str, final_rate: str) -> str:
    """The shell line of an MLS job, with Snakemake placeholders: the rate ladder as given (the config's through the
    job's params, a validation-grid run's through its wildcards), the rest from the job's params ``p_max``,
    ``max_eq``, ``seed``, ``options`` (:meth:`Experiment.mls_options`) and ``checkpoint`` (a stale one, of an older
    input, is discarded)."""
    return (
        f"spherejam mls {{input}} --initial-rate {initial_rate} --decrease-factor {decrease_factor}"
        f" --final-rate {final_rate} --p-max {{params.p_max}} --max-equilibration-windows {{params.max_eq}}"
        " --seed {params.seed} {params.options} --checkpoint {params.checkpoint} --discard-stale-checkpoint"
        " -o {output} > {log} 2>&1"
    )
