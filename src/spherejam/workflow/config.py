"""The experiment config: the JSON schema (with its defaults) and every limit and consistency rule beyond it.

:func:`validate_config` is the workflow's check (``rules/common.smk``); :func:`check_config` applies the limits of
:mod:`spherejam.core.validation` and the consistency rules a JSON schema cannot express (the manifest, ``spherejam
cost``). Every rule raises :class:`~spherejam.core.errors.InputError` whose one-line message starts with the field path
and the offending element, e.g. ``ls.rates[1]=0.0: must be >= 1e-08``.
"""

from __future__ import annotations

import math
import os
from typing import Any

from ..core.errors import InputError
from ..core.validation import FB_RATE, FIELDS, LS_RATE, MAX_RUNS, SIGMA, check_mls
from .bands import BAND_DEFAULTS, FAST_DEFAULTS
from .experiment import PROTOCOLS, distributions_of, rate_grid, sizes_of
from .fits import FIT_DEFAULTS, GCP_MONODISPERSE


def check_config(config: Any) -> dict:
    """Check an experiment config (already through the JSON schema, or not) against every limit and consistency
    rule; return it unchanged. The first offending element is named by its path (``validation_grid.sigmas[1]``)."""
    if not isinstance(config, dict):
        raise InputError(f"config={_short(config)}: must be a mapping of keys to values")
    _check_finite("", config)
    for key in ("n", "seed", "ls", "fb"):
        if key not in config:
            raise InputError(f"{key}: required key missing")
    if not config.get("sigmas") and not config.get("distributions"):
        raise InputError("sigmas: required key missing (or give distributions)")
    for section in ("ls", "fb"):
        if not isinstance(config[section], dict) or "rates" not in config[section]:
            raise InputError(f"{section}.rates: required key missing")
    for field, bound in FIELDS.items():
        if field == "n" and isinstance(config["n"], list):  # a ladder of N: each element is an N
            field = "n[]"
        for path, value in _values(config, field):
            if value is None and field in _NULLABLE:
                continue
            bound.check(path, value)
    interior = (config.get("calippso") or {}).get("interior_steps")
    if interior is not None and not isinstance(interior, bool):  # YAML's "yes"/"no" are already booleans
        raise InputError(f"calippso.interior_steps={_short(interior)}: must be true, false or null")
    mls = config.get("mls") or {}
    if all(k in mls for k in ("initial_rate", "decrease_factor", "final_rate")):
        check_mls(mls["initial_rate"], mls["decrease_factor"], mls["final_rate"])
    grid = config.get("validation_grid") or {}
    if grid.get("enabled", False):
        sigmas = {round(float(s), 12) for s in config.get("sigmas") or []}
        for i, s in enumerate(grid.get("sigmas", [])):
            if round(float(s), 12) not in sigmas:
                raise InputError(f"validation_grid.sigmas[{i}]={s!r}: not one of sigmas {config.get('sigmas')}")
        for a, g0 in enumerate(grid.get("initial_rates", [])):
            for b, f in enumerate(grid.get("decrease_factors", [])):
                for c, gf in enumerate(grid.get("final_rates", [])):
                    names = (f"initial_rates[{a}]", f"decrease_factors[{b}]", f"final_rates[{c}]")
                    check_mls(g0, f, gf, tuple(f"validation_grid.{name}" for name in names))
    distributions = distributions_of(config)
    for d in distributions:
        if d.sigma is None:
            d.model()  # a named spec must parse (and its file read): one line naming distributions.<name>
    n_dist = len(distributions) * len(sizes_of(config)[0])
    total = 0
    for protocol in PROTOCOLS:
        try:
            rates = rate_grid(config[protocol]["rates"])
        except InputError as exc:
            raise InputError(f"{protocol}.{exc}") from None
        bound = LS_RATE if protocol == "ls" else FB_RATE
        total += len(rates) * n_dist * int(config.get("replicas", 1))
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
            total += (len(extra_rates) * len(extra.get("sigmas", [])) * len(sizes_of(config)[0])
                      * int(config.get("replicas", 1)))
    if total > MAX_RUNS:
        raise InputError(f"N x distributions x rates x replicas = {total} runs: at most {MAX_RUNS}")
    return config


_NULLABLE = {"calippso.per_cell", "fb.phi_nominal", "mls.stall_windows", "mls.max_collisions_per_particle",
             "mls.max_wall_time"}


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


def load_config_file(path: str | os.PathLike, field: str | None = None, empty_ok: bool = True) -> dict | None:
    """A YAML config file, the one loader of every command that reads one (``spherejam cost``, ``rcp --template``,
    the cost model): read as ``yaml.safe_load`` does, but a mapping that repeats a key is refused (YAML loaders keep
    the last value silently, so a typo'd copy would win), and so is anything that is not a mapping of keys to values.
    Every problem is one :class:`InputError` naming ``field`` (the option, if the path came from one) and the file:
    a missing or special file (a FIFO would block), invalid YAML, a file that is not UTF-8 text, a list or a scalar,
    and with ``empty_ok`` false an empty file. Returns the mapping (None for an empty file)."""
    import yaml

    from ..core.input_paths import regular_file

    where = f"{field}={str(path)!r}" if field else str(path)
    regular_file(path, "config file", error=InputError, missing="no such config file")

    class StrictLoader(yaml.SafeLoader):
        pass

    def mapping(loader, node):
        seen = set()
        for key_node, _ in node.value:
            if key_node.tag == "tag:yaml.org,2002:merge":  # "<<: *anchor" merges; its keys may be overridden
                continue
            key = loader.construct_object(key_node, deep=True)
            if key in seen:
                raise InputError(f"{where}: line {key_node.start_mark.line + 1}: key {key!r} is given twice (the "
                                 "last would silently win); keep one")
            seen.add(key)
        return loader.construct_mapping(node, deep=True)

    StrictLoader.add_constructor(yaml.resolver.BaseResolver.DEFAULT_MAPPING_TAG, mapping)
    try:
        with open(path, encoding="utf-8") as fh:
            data = yaml.load(fh, Loader=StrictLoader)  # noqa: S506 - a SafeLoader subclass
    except yaml.YAMLError as exc:
        raise InputError(f"{where}: not valid YAML ({str(exc).splitlines()[0]})") from None
    except UnicodeDecodeError as exc:
        raise InputError(f"{where}: not a UTF-8 text file (byte {exc.start})") from None
    if data is None and not empty_ok:
        raise InputError(f"{where}: an empty file; a config is a mapping of keys to values")
    if not isinstance(data, (dict, type(None))):
        raise InputError(f"{where}: a config is a mapping of keys to values, this file holds a "
                         f"{type(data).__name__}")
    return data


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
        fill_table_defaults(config)
        return check_config(config)
    except InputError as exc:
        raise InputError(f"config: {exc}") from None


def fill_table_defaults(config: dict) -> dict:
    """Write the defaults of the table sections (``fits``, ``bands``, ``fast``, ``gcp_monodisperse``) into a
    config. Their one source is the code that uses them (:mod:`.fits`, :mod:`.bands`); the schema states only
    their limits."""
    for section, defaults in (("fits", FIT_DEFAULTS), ("bands", BAND_DEFAULTS), ("fast", FAST_DEFAULTS)):
        node = config.setdefault(section, {})
        if isinstance(node, dict):
            for key, value in defaults.items():
                node.setdefault(key, value)
    config.setdefault("gcp_monodisperse", GCP_MONODISPERSE)
    return config


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
