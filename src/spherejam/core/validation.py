"""What every number a user gives may be: one set of limits for the CLI arguments, the config schema and the manifest.

Each limit is a :class:`Bound` named after its config field (``mls.final_rate``). The CLI builds its argparse
types from them (:meth:`Bound.arg`), :func:`check_config` applies them to an experiment config together with the
consistency rules a JSON schema cannot express, and ``config/schema.yaml`` carries the same numbers (a test checks
that they agree). The limits are those of the engines (an FB rate must be < 1), those that let a run end (a rate of
1e-300 never jams) and those of a machine (N spheres must fit in memory).

Every rule raises :class:`~spherejam.core.errors.InputError` whose one-line message starts with the field path and the
offending element, e.g. ``ls.rates[1]=0.0: must be >= 1e-08``.
"""

from __future__ import annotations

import argparse
import math
import numbers
import os
from dataclasses import dataclass
from typing import Any

from .errors import InputError

#: Largest N: 10^7 spheres take ~1 GB in the engines' arrays; the paper uses 10^4.
N_MAX = 10_000_000
#: Seeds are stored as signed 64-bit integers in the packing files.
SEED_MAX = 2**63 - 1
#: LS / MLS compression rates gamma = d rho/dt (units m = kB = 1, T = 0.2). Below the minimum a compression to
#: p_max takes more than ~10^4 times the paper's slowest run (1/gamma = 10^4); above the maximum the spheres grow
#: by their own size within a mean free time.
LS_RATE_MIN, LS_RATE_MAX = 1e-8, 1e3
#: FB contraction rate per iteration: the engine needs gamma < 1; below 1e-9 the paper's nominal-density rule
#: leaves (0, 1) (at 1e-19) long after the run has become endless (iterations ~ 1/gamma; the paper's slowest 1e-7).
FB_RATE_MIN, FB_RATE_MAX = 1e-9, 1.0
#: MLS rate divisor per stage: beyond 100 the last stage's rate final_rate/f falls far below final_rate.
DECREASE_FACTOR_MAX = 100.0
#: Reduced-pressure threshold: > 1, and reachable in double precision (gaps ~ 1/p, relative precision 1e-16).
P_MAX_MAX = 1e15
#: Most configurations a config may ask for (runs of one protocol, sigma, gamma and replica).
MAX_RUNS = 1_000_000


@dataclass(frozen=True)
class Bound:
    """A closed or open interval for a number; ``integer`` also requires a whole number."""

    lo: float | None = None
    hi: float | None = None
    lo_open: bool = False
    hi_open: bool = False
    integer: bool = False

    def rule(self) -> str:
        kind = "an integer" if self.integer else "a finite number"
        text = (lambda x: str(int(x))) if self.integer else (lambda x: f"{x:g}")
        parts = []
        if self.lo is not None:
            parts.append(f"{'>' if self.lo_open else '>='} {text(self.lo)}")
        if self.hi is not None:
            parts.append(f"{'<' if self.hi_open else '<='} {text(self.hi)}")
        return f"must be {kind}" + (f" {' and '.join(parts)}" if parts else "")

    def ok(self, value: Any) -> bool:
        if isinstance(value, bool) or not isinstance(value, numbers.Real):
            return False
        if self.integer and not isinstance(value, numbers.Integral):
            return False
        if not math.isfinite(value):
            return False
        if self.lo is not None and (value <= self.lo if self.lo_open else value < self.lo):
            return False
        return not (self.hi is not None and (value >= self.hi if self.hi_open else value > self.hi))

    def check(self, field: str, value: Any):
        if not self.ok(value):
            raise InputError(f"{field}={value!r}: {self.rule()}")
        return value

    def arg(self, text: str):
        """Parse a command-line value (argparse ``type=``); integers also as ``1e6``."""
        try:
            value: Any = int(text) if self.integer else float(text)
        except ValueError:
            value = _whole(text) if self.integer else None
            if value is None:
                raise argparse.ArgumentTypeError(
                    f"{text!r} is not {'an integer' if self.integer else 'a number'}") from None
        if not self.ok(value):
            raise argparse.ArgumentTypeError(f"{text!r}: {self.rule()}")
        return value


def _whole(text: str) -> int | None:
    try:
        x = float(text)
    except ValueError:
        return None
    return int(x) if math.isfinite(x) and x == int(x) else None


LS_RATE = Bound(LS_RATE_MIN, LS_RATE_MAX)
FB_RATE = Bound(FB_RATE_MIN, FB_RATE_MAX, hi_open=True)
P_MAX = Bound(1.0, P_MAX_MAX, lo_open=True)
SIGMA = Bound(0.0, 1.0)
UNIT_OPEN = Bound(0.0, 1.0, lo_open=True, hi_open=True)
SECONDS = Bound(0.0, None, lo_open=True)  # wall-time limits: > 0 (0 would stop before the first step)
#: Threads of one job (HiGHS and HiPO's BLAS in a CALiPPSO certification).
THREADS = Bound(1, 256, integer=True)
INTERVAL = Bound(0.0, None)  # checkpoint and progress intervals: >= 0 seconds, 0 = at every window or iteration

#: Limits by config field (also the names of the matching CLI options' values).
FIELDS: dict[str, Bound] = {
    "n": Bound(2, N_MAX, integer=True),
    "seed": Bound(0, SEED_MAX, integer=True),
    "phi_nominal": UNIT_OPEN,
    "sigmas[]": SIGMA,
    "replicas": Bound(1, 10_000, integer=True),
    "rates.count": Bound(1, 100_000, integer=True),
    "ls.rates[]": LS_RATE,
    "ls.p_max": P_MAX,
    "fb.rates[]": FB_RATE,
    "fb.phi_nominal": UNIT_OPEN,
    "mls.initial_rate": LS_RATE,
    "mls.decrease_factor": Bound(1.0, DECREASE_FACTOR_MAX, lo_open=True),
    "mls.final_rate": LS_RATE,
    "mls.p_max": P_MAX,
    "mls.max_equilibration_windows": Bound(1, 1_000_000, integer=True),
    "mls.stall_windows": Bound(1, 100_000_000, integer=True),
    "mls.max_collisions_per_particle": Bound(0.0, 1e12, lo_open=True),
    "mls.max_wall_time": SECONDS,
    "validation_grid.sigmas[]": SIGMA,
    "validation_grid.ls_rates[]": LS_RATE,
    "validation_grid.replicas": Bound(1, 10_000, integer=True),
    "validation_grid.decrease_factors[]": Bound(1.0, DECREASE_FACTOR_MAX, lo_open=True),
    "validation_grid.initial_rates[]": LS_RATE,
    "validation_grid.final_rates[]": LS_RATE,
    "fits.confidence": UNIT_OPEN,
    "fast.ls_max_inverse_rate": Bound(0.0, None, lo_open=True),
    "fast.fb_max_inverse_rate": Bound(0.0, None, lo_open=True),
    "gcp_monodisperse": UNIT_OPEN,
    "calippso.threads": THREADS,
}

#: Limits of CLI-only values.
EVENTS_PER_PARTICLE = Bound(1, 1_000_000, integer=True)
MAX_COLLISIONS = Bound(1, 10**15, integer=True)
PORE_SAMPLES = Bound(1, 1_000_000_000, integer=True)
CALIPPSO_ITERATIONS = Bound(1, 1_000_000, integer=True)
FB_ITERATIONS = Bound(0, 10**12, integer=True)
OVERLAP_TOLERANCE = Bound(0.0, 1.0)
IMAGE_SIZE = Bound(16, 8192, integer=True)
#: The side L of a packing's box, in any length unit, for every reader, writer and ``import --box``: L**d (d <= 5)
#: and N ball volumes stay finite, normal doubles, so phi and the cell list cannot overflow.
BOX_MIN, BOX_MAX = 1e-50, 1e50
BOX_SIDE = Bound(BOX_MIN, BOX_MAX)
#: The HiGHS solvers CALiPPSO's LPs can be sent to (here, not in calippso.py, so that the CLI need not load numba).
LP_SOLVERS = ("hipo", "ipx", "simplex")


def check_mls(initial_rate: float, decrease_factor: float, final_rate: float,
              names: tuple[str, str, str] = ("mls.initial_rate", "mls.decrease_factor", "mls.final_rate")) -> None:
    """MLS consistency: final rate <= initial rate, and the last stage's rate (>= final_rate/f) still ends.

    ``names`` are how the three values are called where they came from (config fields or CLI options)."""
    g0, f, gf = names
    if final_rate > initial_rate:
        raise InputError(f"{gf}={final_rate!r}: must be <= {g0} ({initial_rate!r})")
    if final_rate / decrease_factor < LS_RATE_MIN:
        raise InputError(f"{f}={decrease_factor!r}: with {gf} {final_rate!r} the last stage may run at gamma = "
                         f"{final_rate / decrease_factor:.3g} < {LS_RATE_MIN:g}, which never jams")


# --- the experiment config ---------------------------------------------------------------------------------------


def check_config(config: Any) -> dict:
    """Check an experiment config (already through the JSON schema, or not) against every limit and consistency
    rule; return it unchanged. The first offending element is named by its path (``validation_grid.sigmas[1]``)."""
    if not isinstance(config, dict):
        raise InputError(f"config={_short(config)}: must be a mapping of keys to values")
    _check_finite("", config)
    for key in ("n", "seed", "sigmas", "ls", "fb"):
        if key not in config:
            raise InputError(f"{key}: required key missing")
    for section in ("ls", "fb"):
        if not isinstance(config[section], dict) or "rates" not in config[section]:
            raise InputError(f"{section}.rates: required key missing")
    for field, bound in FIELDS.items():
        for path, value in _values(config, field):
            if value is None and field in _NULLABLE:
                continue
            bound.check(path, value)
    mls = config.get("mls") or {}
    if all(k in mls for k in ("initial_rate", "decrease_factor", "final_rate")):
        check_mls(mls["initial_rate"], mls["decrease_factor"], mls["final_rate"])
    grid = config.get("validation_grid") or {}
    if grid.get("enabled", False):
        sigmas = {round(float(s), 12) for s in config["sigmas"]}
        for i, s in enumerate(grid.get("sigmas", [])):
            if round(float(s), 12) not in sigmas:
                raise InputError(f"validation_grid.sigmas[{i}]={s!r}: not one of sigmas {config['sigmas']}")
        for a, g0 in enumerate(grid.get("initial_rates", [])):
            for b, f in enumerate(grid.get("decrease_factors", [])):
                for c, gf in enumerate(grid.get("final_rates", [])):
                    names = (f"initial_rates[{a}]", f"decrease_factors[{b}]", f"final_rates[{c}]")
                    check_mls(g0, f, gf, tuple(f"validation_grid.{name}" for name in names))
    from ..workflow.experiment import PROTOCOLS, rate_grid

    total = 0
    for protocol in PROTOCOLS:
        try:
            rates = rate_grid(config[protocol]["rates"])
        except InputError as exc:
            raise InputError(f"{protocol}.{exc}") from None
        bound = LS_RATE if protocol == "ls" else FB_RATE
        total += len(rates) * len(config["sigmas"]) * int(config.get("replicas", 1))
        for k, extra in enumerate(config[protocol].get("extra_rates") or []):
            where = f"{protocol}.extra_rates[{k}]"
            for i, s in enumerate(extra.get("sigmas", [])):
                SIGMA.check(f"{where}.sigmas[{i}]", s)
            try:
                extra_rates = rate_grid(extra.get("rates", []))
            except InputError as exc:
                raise InputError(f"{where}.{exc}") from None
            for i, r in enumerate(extra_rates):
                bound.check(f"{where}.rates[{i}]", r)
            total += len(extra_rates) * len(extra.get("sigmas", [])) * int(config.get("replicas", 1))
    if total > MAX_RUNS:
        raise InputError(f"sigmas x rates x replicas = {total} runs: at most {MAX_RUNS}")
    return config


_NULLABLE = {"fb.phi_nominal", "mls.stall_windows", "mls.max_collisions_per_particle", "mls.max_wall_time"}


def _values(config: dict, field: str):
    """(path, value) of every element a field pattern names: ``a.b`` a scalar, ``a[]`` each list element,
    ``rates.count``/``x.rates[]`` also inside ``{min, max, count}`` grids."""
    if field == "rates.count":
        for section in ("ls", "fb"):
            spec = (config.get(section) or {}).get("rates")
            if isinstance(spec, dict) and "count" in spec:
                yield f"{section}.rates.count", spec["count"]
        return
    keys = field.rstrip("[]").split(".")
    node: Any = config
    for k in keys:
        if not isinstance(node, dict) or k not in node:
            return
        node = node[k]
    name = ".".join(keys)
    if field.endswith("[]"):
        if isinstance(node, dict):  # a {min, max, count} rate grid
            for k in ("min", "max"):
                if k in node:
                    yield f"{name}.{k}", node[k]
        elif isinstance(node, list):
            for i, v in enumerate(node):
                yield f"{name}[{i}]", v
        else:
            raise InputError(f"{name}={_short(node)}: must be a list")
    else:
        yield name, node


def _check_finite(path: str, node: Any) -> None:
    if isinstance(node, dict):
        for k, v in node.items():
            _check_finite(f"{path}.{k}" if path else str(k), v)
    elif isinstance(node, list):
        for i, v in enumerate(node):
            _check_finite(f"{path}[{i}]", v)
    elif isinstance(node, float) and not math.isfinite(node):
        raise InputError(f"{path}={node!r}: must be a finite number")


def _short(value: Any) -> str:
    text = repr(value)
    return text if len(text) <= 60 else text[:57] + "..."


def load_config_file(path: str | os.PathLike) -> Any:
    """A YAML config file, read as ``yaml.safe_load`` does, but a mapping that repeats a key is refused (one line
    naming the file, line and key): YAML loaders keep the last value silently, so a typo'd copy would win."""
    import yaml

    class StrictLoader(yaml.SafeLoader):
        pass

    def mapping(loader, node):
        seen = set()
        for key_node, _ in node.value:
            if key_node.tag == "tag:yaml.org,2002:merge":  # "<<: *anchor" merges; its keys may be overridden
                continue
            key = loader.construct_object(key_node, deep=True)
            if key in seen:
                raise InputError(f"{path}: line {key_node.start_mark.line + 1}: key {key!r} is given twice (the "
                                 "last would silently win); keep one")
            seen.add(key)
        return loader.construct_mapping(node, deep=True)

    StrictLoader.add_constructor(yaml.resolver.BaseResolver.DEFAULT_MAPPING_TAG, mapping)
    with open(path) as fh:
        return yaml.load(fh, Loader=StrictLoader)  # noqa: S506 - a SafeLoader subclass


def validate_config(config: dict, schema_path: str | os.PathLike) -> dict:
    """The workflow's check: the JSON schema (filling in its defaults) and then :func:`check_config`.

    The first line of the error names the field path and the offending element, e.g.
    ``config: ls.rates[1]=0: 0 is less than the minimum of 1e-08``.
    """
    import jsonschema
    import yaml

    with open(schema_path) as fh:
        schema = yaml.safe_load(fh)
    try:
        if not isinstance(config, dict):
            raise InputError(f"config={_short(config)}: must be a mapping of keys to values")
        _check_finite("", config)  # before the schema: NaN passes every JSON-schema bound
        validator = _with_defaults(jsonschema.Draft202012Validator)(schema)
        errors = sorted(validator.iter_errors(config), key=lambda e: (len(e.absolute_path), list(map(str, e.path))))
        if errors:
            error = _deepest(errors[0])
            where = _format_path(error.absolute_path)
            if error.validator == "required":
                missing = [k for k in error.validator_value if k not in error.instance]
                where = ".".join([*([where] if error.absolute_path else []), str(missing[0])])
                raise InputError(f"{where}: required key missing (a --configfile must be complete by itself)")
            raise InputError(f"{where}={_short(error.instance)}: {error.message}")
        return check_config(config)
    except InputError as exc:
        raise InputError(f"config: {exc}") from None


def _deepest(error):
    """For ``oneOf``/``anyOf`` failures, the error of the branch that matched the value's type, so that
    ``[0.1, 0]`` reports ``rates[1]=0`` rather than 'not valid under any of the given schemas'."""
    while error.context:
        typed = [e for e in error.context if e.validator != "type"]
        if not typed:
            break
        error = max(typed, key=lambda e: len(e.absolute_path))
    return error


def _format_path(path) -> str:
    text = ""
    for part in path:
        text += f"[{part}]" if isinstance(part, int) else (f".{part}" if text else str(part))
    return text or "(top level)"


def _with_defaults(validator_class):
    """A validator that also writes each property's ``default`` into the instance (as Snakemake's validate does)."""
    import jsonschema

    set_properties = validator_class.VALIDATORS["properties"]

    def properties(validator, properties, instance, schema):
        if isinstance(instance, dict):
            for name, sub in properties.items():
                if "default" in sub and name not in instance:
                    import copy

                    instance[name] = copy.deepcopy(sub["default"])
        yield from set_properties(validator, properties, instance, schema)

    return jsonschema.validators.extend(validator_class, {"properties": properties})
