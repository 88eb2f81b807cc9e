"""The experiment design: validation-grid rates must be packings of the experiment; per-sigma extra rates."""

import pytest
import yaml
from test_workflow import ROOT

from spherejam import InputError
from spherejam.workflow.cost_model import load_configs
from spherejam.workflow.experiment import Experiment


def tiny():
    return yaml.safe_load((ROOT / "config" / "tiny.yaml").read_text())


def test_grid_rate_outside_ls_rates_is_an_error_naming_it():
    cfg = tiny()
    cfg["validation_grid"]["ls_rates"] = [0.5, 0.3]
    with pytest.raises(InputError, match=r"validation_grid.ls_rates=0.3: not one of ls.rates \(nearest: 0.5\)"):
        Experiment(cfg)
    cfg["validation_grid"]["ls_rates"] = [0.5]
    cfg["validation_grid"]["sigmas"] = [0.2]
    with pytest.raises(InputError, match=r"validation_grid.sigmas=0.2: not one of sigmas"):
        Experiment(cfg)
    cfg["validation_grid"]["enabled"] = False
    assert Experiment(cfg).grid_runs() == []  # a disabled grid is not checked


def test_grid_sources_are_packings_of_the_experiment():
    for name in ("config.yaml", "tiny.yaml", "paper.yaml", "reproduction.yaml"):
        exp = Experiment(load_configs(ROOT / "config" / "config.yaml", ROOT / "config" / name))
        runs = {r.key for r in exp.runs()}
        assert all(g.source.key in runs for g in exp.grid_runs()), name


def test_extra_rates_apply_to_their_sigmas_only():
    cfg = tiny()
    cfg["ls"]["extra_rates"] = [{"sigmas": [0.1], "rates": [1e-3, 0.5]}]  # 0.5 is already in ls.rates
    exp = Experiment(cfg)
    assert exp.rates_for("ls", 0.0) == [2.0, 0.5, 0.1, 0.03, 0.01]
    assert exp.rates_for("ls", 0.1) == [2.0, 0.5, 0.1, 0.03, 0.01, 1e-3]
    assert len(exp.runs("ls")) == 11 and len(exp.runs("fb")) == 10
    cfg["ls"]["extra_rates"] = [{"sigmas": [0.2], "rates": [1e-3]}]
    with pytest.raises(InputError, match="extra_rates.sigmas=0.2"):
        Experiment(cfg)


def test_reproduction_config_is_complete_and_within_its_budget():
    """config/reproduction.yaml stands alone (every section) and the cost model keeps it within 8 CPU-hours."""
    from spherejam.workflow.cost_model import plan

    cfg = yaml.safe_load((ROOT / "config" / "reproduction.yaml").read_text())
    schema = yaml.safe_load((ROOT / "config" / "schema.yaml").read_text())
    assert set(cfg) == set(schema["properties"])
    table = plan(cfg)
    assert sum(row["cpu_hours"] for row in table.values()) <= 8.0
    exp = Experiment(cfg)
    fast = [r for r in exp.runs() if r.protocol == "ls" and 1 / r.rate < 5]
    assert len(fast) == 2 * 16 and not exp.grid_runs()
    assert len(exp.rates_for("ls", 0.0)) == 16 and len(exp.rates_for("ls", 0.3)) == 16 + 14
