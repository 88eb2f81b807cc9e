"""Issue 23: one set of limits for the CLI, the config schema and the manifest; errors name the field and element.

The property-based tests draw values just outside each limit (and NaN, inf, non-integers) and require exit code 2,
a one-line message naming the option or field, and no file written. They run in-process with few examples.
"""

import contextlib
import copy
import io
import json
import math
from pathlib import Path

import pytest
import yaml
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from spherejam.cli import main
from spherejam.core import validation
from spherejam.core.errors import InputError
from spherejam.core.validation import FIELDS, Bound
from spherejam.workflow.config import check_config, validate_config

ROOT = Path(__file__).resolve().parents[2]
SCHEMA = ROOT / "config" / "schema.yaml"
TINY = yaml.safe_load((ROOT / "config" / "tiny.yaml").read_text())


def cli(*args):
    err = io.StringIO()
    with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
        code = main([str(a) for a in args])
    return code, err.getvalue().strip().splitlines()


def schema_error(config) -> str:
    with pytest.raises(InputError) as info:
        validate_config(config, SCHEMA)
    message = str(info.value)
    assert "\n" not in message
    return message


def tiny(**changes):
    cfg = copy.deepcopy(TINY)
    for path, value in changes.items():
        *parents, last = path.split("__")
        node = cfg
        for key in parents:
            node = node[key]
        node[last] = value
    return cfg


# --- the shipped configs ------------------------------------------------------------------------------------------


def _schema_keys(schema, prefix=""):
    for name, sub in schema.get("properties", {}).items():
        yield prefix + name
        if sub.get("type") == "object" and "properties" in sub:
            yield from _schema_keys(sub, prefix + name + ".")


@pytest.mark.parametrize("path", sorted(p for p in (ROOT / "config").glob("*.yaml") if p.name != "schema.yaml"),
                         ids=lambda p: p.name)
def test_shipped_configs_are_complete_and_valid(path):
    """A --configfile is the whole experiment, so every shipped config sets every key the schema knows."""
    raw = yaml.safe_load(path.read_text())
    schema = yaml.safe_load(SCHEMA.read_text())
    missing = []
    for key in _schema_keys(schema):
        node = raw
        for part in key.split("."):
            node = node.get(part, KeyError) if isinstance(node, dict) else KeyError
        if node is KeyError and not (key.startswith("validation_grid.") and not raw["validation_grid"]["enabled"]) \
                and not (key == "sigmas" and raw.get("distributions")):
            missing.append(key)
    assert not missing, f"{path.name} relies on schema defaults for {missing}"
    validate_config(raw, SCHEMA)


def test_table_defaults_have_one_source():
    """fits, bands, fast and gcp_monodisperse: the schema states limits only; the defaults come from the tables'
    code, and a config without those sections gets exactly them."""
    from spherejam.workflow.bands import BAND_DEFAULTS
    from spherejam.workflow.tables import FAST_DEFAULTS, FIT_DEFAULTS, GCP_MONODISPERSE

    schema = yaml.safe_load(SCHEMA.read_text())
    for section in ("fits", "bands", "fast"):
        assert all("default" not in sub for sub in schema["properties"][section]["properties"].values()), section
    assert "default" not in schema["properties"]["gcp_monodisperse"]
    raw = yaml.safe_load((ROOT / "config" / "tiny.yaml").read_text())
    for section in ("fits", "bands", "fast", "gcp_monodisperse"):
        raw.pop(section)
    config = validate_config(raw, SCHEMA)
    assert config["fits"] == FIT_DEFAULTS and config["bands"] == BAND_DEFAULTS and config["fast"] == FAST_DEFAULTS
    assert config["gcp_monodisperse"] == GCP_MONODISPERSE


def _schema_node(schema, field):
    node = schema
    for key in field.removesuffix("[]").split("."):
        node = node["properties"][key]
        if "$ref" in node:
            node = schema["$defs"][node["$ref"].rsplit("/", 1)[1]]
    if field.endswith("[]"):
        if "oneOf" in node:
            return [b["items"] for b in node["oneOf"] if b["type"] == "array"] + [
                b["properties"][k] for b in node["oneOf"] if b["type"] == "object" for k in ("min", "max")]
        return [node["items"]]
    if "oneOf" in node:  # a number or a list of them (n: one N or a ladder)
        return [b["items"] if b["type"] == "array" else b for b in node["oneOf"]]
    return [node]


@pytest.mark.parametrize("field", [f for f in FIELDS if f != "rates.count"])
def test_schema_carries_the_same_limits(field):
    schema = yaml.safe_load(SCHEMA.read_text())
    bound = FIELDS[field]
    for node in _schema_node(schema, field):
        lo = node.get("exclusiveMinimum", node.get("minimum"))
        hi = node.get("exclusiveMaximum", node.get("maximum"))
        assert (lo, "exclusiveMinimum" in node) == (bound.lo, bound.lo_open if bound.lo is not None else False)
        assert (hi, "exclusiveMaximum" in node) == (bound.hi, bound.hi_open if bound.hi is not None else False)
        types = node["type"] if isinstance(node["type"], list) else [node["type"]]
        assert ("integer" in types) == bound.integer


# --- the config defects -----------------------------------------------------------------------------------


@pytest.mark.parametrize("changes, first", [
    ({"ls__rates": [float("nan")]}, "config: ls.rates[0]=nan"),
    ({"sigmas": [0.0, float("nan")]}, "config: sigmas[1]=nan"),
    ({"phi_nominal": float("nan")}, "config: phi_nominal=nan"),
    ({"ls__p_max": float("nan")}, "config: ls.p_max=nan"),
    ({"ls__p_max": float("inf")}, "config: ls.p_max=inf"),
    ({"fb__rates": [1.5]}, "config: fb.rates[0]=1.5"),
    ({"fb__rates": [0.01, 1e-300]}, "config: fb.rates[1]=1e-300"),
    ({"ls__rates": [0.1, 0]}, "config: ls.rates[1]=0"),
    ({"ls__rates": {"min": 1e-3, "max": 0.0, "count": 5}}, "config: ls.rates.max=0.0"),
    ({"n": -5}, "config: n=-5"),
    ({"n": 10**9}, "config: n=1000000000"),
    ({"mls__initial_rate": 1.0, "mls__final_rate": 5.0}, "config: mls.final_rate=5.0: must be <= mls.initial_rate"),
    ({"mls__decrease_factor": 1e300}, "config: mls.decrease_factor=1e+300"),
    ({"validation_grid__sigmas": [0.3]}, "config: validation_grid.sigmas[0]=0.3: not one of sigmas"),
    ({"validation_grid__final_rates": [20.0]}, "config: validation_grid.final_rates[0]=20.0: must be <="),
])
def test_config_error_names_field_and_element_first(changes, first):
    assert schema_error(tiny(**changes)).startswith(first)


@pytest.mark.parametrize("section", ["n", "seed", "sigmas", "ls", "fb"])
def test_missing_required_section_is_an_error(section):
    cfg = tiny()
    del cfg[section]
    assert schema_error(cfg).startswith(f"config: {section}: required key missing")


def test_missing_rates_inside_a_section():
    cfg = tiny()
    del cfg["fb"]["rates"]
    assert schema_error(cfg).startswith("config: fb.rates: required key missing")


def test_manifest_validates_what_it_records(tmp_path):
    for bad, needle in ((tiny(n=-5), "n=-5"), (tiny(ls__rates=[float("nan")]), "ls.rates[0]=nan")):
        code, err = cli("manifest", "--config-json", json.dumps(bad), "-o", tmp_path / "m.json")
        assert code == 2 and len(err) == 1 and needle in err[0], err
        assert not (tmp_path / "m.json").exists()
    assert cli("manifest", "--config-json", json.dumps(tiny()), "-o", tmp_path / "m.json")[0] == 0


# --- property-based: just outside every limit -------------------------------------------------------------------


def outside(bound: Bound):
    """Values that ``bound`` must reject: non-finite, just beyond either end, and non-integers for integers."""
    options = [st.sampled_from([math.nan, math.inf, -math.inf])]
    if bound.integer:
        lo = int(bound.lo)
        options += [st.integers(min_value=lo - 10**6, max_value=lo - 1),
                    st.integers(min_value=lo, max_value=lo + 10**6).map(lambda i: i + 0.5)]
        if bound.hi is not None:
            options.append(st.integers(min_value=int(bound.hi) + 1, max_value=int(bound.hi) * 10 + 10))
        return st.one_of(options)
    if bound.lo is not None:
        options.append(st.floats(max_value=bound.lo, exclude_max=not bound.lo_open, allow_nan=False,
                                 allow_infinity=False, min_value=-1e300))
    if bound.hi is not None:
        options.append(st.floats(min_value=bound.hi, exclude_min=not bound.hi_open, allow_nan=False,
                                 allow_infinity=False, max_value=1e300))
    return st.one_of(options)


def _set(cfg, field, value, index):
    keys = field.removesuffix("[]").split(".")
    node = cfg
    for k in keys[:-1]:
        node = node[k]
    if field.endswith("[]"):
        current = node[keys[-1]]
        items = list(current) if isinstance(current, list) else [current["min"]]
        items[index % len(items)] = value
        node[keys[-1]] = items
        return f"{'.'.join(keys)}[{index % len(items)}]"
    node[keys[-1]] = value
    return ".".join(keys)


CONFIG_FIELDS = [f for f in FIELDS if f != "rates.count" and not f.startswith(("fits.", "fast.", "gcp"))]


@pytest.mark.parametrize("field", CONFIG_FIELDS)
@settings(max_examples=8, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(data=st.data())
def test_config_values_outside_their_limits(field, data, tmp_path):
    value = data.draw(outside(FIELDS[field]), label="value")
    cfg = tiny()
    path = _set(cfg, field, value, data.draw(st.integers(0, 3), label="index"))
    message = schema_error(cfg)
    assert message.startswith(f"config: {path}"), message
    # the manifest applies the same limits (NaN cannot travel through JSON, so only finite values go there)
    if math.isfinite(value):
        out = tmp_path / "m.json"
        code, err = cli("manifest", "--config-json", json.dumps(cfg), "-o", out)
        assert code == 2 and len(err) == 1 and path in err[0], err
        assert not out.exists()


CLI_OPTIONS = [  # (argv before the value, option, the limit; the output is always OUT)
    (["seed", "-o", "OUT", "--n"], "--n", FIELDS["n"]),
    (["seed", "-o", "OUT", "--n", "5", "--sigma"], "--sigma", FIELDS["sigmas[]"]),
    (["seed", "-o", "OUT", "--n", "5", "--seed"], "--seed", FIELDS["seed"]),
    (["seed", "-o", "OUT", "--n", "5", "--phi-nominal"], "--phi-nominal", FIELDS["phi_nominal"]),
    (["ls", "IN", "-o", "OUT", "--rate", "0.1", "--p-max"], "--p-max", FIELDS["ls.p_max"]),
    (["ls", "IN", "-o", "OUT", "--rate", "0.1", "--events-per-particle"], "--events-per-particle",
     validation.EVENTS_PER_PARTICLE),
    (["ls", "IN", "-o", "OUT", "--rate", "0.1", "--max-wall-time"], "--max-wall-time", validation.SECONDS),
    (["ls", "IN", "-o", "OUT", "--rate", "0.1", "--checkpoint-interval"], "--checkpoint-interval",
     validation.INTERVAL),
    (["mls", "IN", "-o", "OUT", "--initial-rate"], "--initial-rate", FIELDS["mls.initial_rate"]),
    (["mls", "IN", "-o", "OUT", "--decrease-factor"], "--decrease-factor", FIELDS["mls.decrease_factor"]),
    (["mls", "IN", "-o", "OUT", "--final-rate"], "--final-rate", FIELDS["mls.final_rate"]),
    (["mls", "IN", "-o", "OUT", "--stall-windows"], "--stall-windows", FIELDS["mls.stall_windows"]),
    (["fb", "IN", "-o", "OUT", "--rate"], "--rate", FIELDS["fb.rates[]"]),
    (["fb", "IN", "-o", "OUT", "--rate", "0.01", "--phi-nominal"], "--phi-nominal", FIELDS["fb.phi_nominal"]),
    (["fb", "IN", "-o", "OUT", "--rate", "0.01", "--progress-interval"], "--progress-interval",
     validation.INTERVAL),
    (["calippso", "IN", "-o", "OUT", "--max-iterations"], "--max-iterations", validation.CALIPPSO_ITERATIONS),
    (["analyze", "IN", "-o", "OUT", "--pore-samples"], "--pore-samples", validation.PORE_SAMPLES),
]


@pytest.fixture(scope="module")
def packing(tmp_path_factory):
    path = tmp_path_factory.mktemp("p") / "p.h5"
    assert main(["seed", "--n", "20", "--seed", "1", "-o", str(path)]) == 0
    return path


@pytest.mark.parametrize("argv, option, bound", CLI_OPTIONS, ids=[o for _, o, _ in CLI_OPTIONS])
@settings(max_examples=8, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(data=st.data())
def test_cli_numbers_outside_their_limits(argv, option, bound, data, packing, tmp_path):
    value = data.draw(outside(bound), label="value")
    out = tmp_path / "out.h5"
    code, err = cli(*[{"IN": packing, "OUT": out}.get(a, a) for a in argv], repr(value))
    assert code == 2 and len(err) == 1 and option in err[0], err
    assert not out.exists()


def test_extra_rates_count_toward_the_run_limit():
    from spherejam.core.validation import MAX_RUNS

    cfg = yaml.safe_load((ROOT / "config" / "tiny.yaml").read_text())
    check_config(cfg)
    cfg["ls"]["extra_rates"] = [{"sigmas": cfg["sigmas"], "rates": {"min": 1e-4, "max": 1.0, "count": MAX_RUNS}}]
    with pytest.raises(InputError, match="runs: at most"):
        check_config(cfg)
