"""The experiment design: validation-grid rates must be packings of the experiment; per-sigma extra rates; the
workflow's paths, seeds and MLS command line come from it alone, unchanged from the results folders already made."""

import re
import tokenize
from types import SimpleNamespace

import pytest
import yaml
from test_workflow import ROOT

from spherejam import InputError
from spherejam.workflow.cost_model import load_configs
from spherejam.workflow.experiment import (
    GRID_KEY,
    RUN_KEY,
    WILDCARD_CONSTRAINTS,
    Experiment,
    GridRun,
    Run,
    mls_command,
)


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
    """config/reproduction.yaml stands alone (every section) and the cost model prices it within 30 % of its measured
    cost."""
    from spherejam.workflow.cost_model import plan

    cfg = yaml.safe_load((ROOT / "config" / "reproduction.yaml").read_text())
    schema = yaml.safe_load((ROOT / "config" / "schema.yaml").read_text())
    assert set(cfg) == set(schema["properties"])
    tables = plan(cfg)
    # the ladder measured 10.98 core-hours from its jobs' wall time (docs/reproduction.md); the refitted model
    # (docs/algorithms.md §7.9) prices it at 12.6
    modelled = sum(row["cpu_hours"] for table in tables.values() for row in table.values())
    assert 10.98 / 1.3 < modelled < 10.98 * 1.3
    exp = Experiment(cfg)
    assert exp.sizes == [250, 500, 1000] and exp.n_ladder and not exp.grid_runs()
    for n in exp.sizes:  # 16 fast LS compressions per band at every N; the slow series at the ends of the ladder
        fast = [r for r in exp.runs("ls", n) if 1 / r.rate < 5]
        assert len(fast) == 2 * 16
        slow = len(exp.rates_for("ls", 0.3, n)) - 16
        assert slow == (14 if n in (250, 1000) else 0) and len(exp.rates_for("ls", 0.0, n)) == 16


def _wildcards(pattern: str, path: str) -> SimpleNamespace:
    """The wildcards Snakemake would read from ``path`` for ``pattern`` (with the workflow's constraints)."""
    regex, pos = "", 0
    for m in re.finditer(r"{(\w+)}", pattern):
        regex += re.escape(pattern[pos:m.start()]) + f"(?P<{m[1]}>{WILDCARD_CONSTRAINTS.get(m[1], '.+')})"
        pos = m.end()
    match = re.fullmatch(regex + re.escape(pattern[pos:]), path)
    assert match, (pattern, path)
    return SimpleNamespace(**match.groupdict())


def test_rule_patterns_match_the_runs_files_and_give_back_the_run():
    """The rules' patterns (Experiment.paths with its wildcard defaults) and the files of the experiment's runs are
    one layout: each run's file matches its pattern, and the wildcards read from it give back the run."""
    exp = Experiment(tiny())
    for run in exp.runs():
        for stage in ("poisson", "initial", "jammed", "structure", "calippso", "calippso_packing"):
            w = _wildcards(exp.paths.packing(stage), str(exp.path(run, stage)))
            assert Run.from_wildcards(w) == run
            assert exp.paths.packing(stage).format(**vars(w)) == str(exp.path(run, stage))
    for g in exp.grid_runs():
        w = _wildcards(exp.paths.grid(), str(exp.grid_path(g)))
        assert GridRun.from_wildcards(w) == g
        assert exp.paths.packing("initial").format(**vars(w)) == str(exp.path(g.source, "initial"))
    key = RUN_KEY.format(protocol="ls", dist="sigma0.1", rate="0.5", replica=0)
    assert key == Run("ls", 0.1, 0.5, 0).key == "ls/sigma0.1/rate0.5/r0"
    assert GRID_KEY.startswith(RUN_KEY)


def test_paths_and_seeds_are_those_of_existing_results_folders():
    """Existing results folders stay valid: the same files, checkpoints (resumed from after a restart) and seeds as
    before the workflow took them from experiment.py (values read off a dry run of config/tiny.yaml then)."""
    exp = Experiment(tiny())
    run = Run("ls", 0.0, 0.5, 0)
    key = run.key
    assert key == "ls/sigma0/rate0.5/r0"
    r = "results-tiny"
    assert str(exp.path(run, "calippso_packing")) == f"{r}/packings/{key}/calippso.h5"
    assert exp.paths.checkpoint("ls", key) == f"{r}/checkpoints/ls/sigma0/rate0.5/r0.h5"
    assert exp.paths.log("fb", "fb/sigma0/rate0.01/r0") == f"{r}/logs/fb/sigma0/rate0.01/r0.log"
    assert exp.paths.checkpoint("mls", key) == f"{r}/checkpoints/mls/{key}.h5"
    assert exp.paths.log("analyze", key) == f"{r}/logs/structure/{key}.log"
    assert exp.paths.benchmark("calippso", key) == f"{r}/benchmarks/calippso/{key}.tsv"
    grid = exp.grid_runs()[1]
    assert exp.paths.checkpoint("mls_grid", grid.key) == f"{r}/checkpoints/validation/{key}/f4_g10_gf0.01.h5"
    assert exp.paths.tables(["csv"])[0] == f"{r}/tables/table2.csv" and exp.paths.dataset == f"{r}/dataset.nc"

    def wildcards(run):
        return SimpleNamespace(protocol=run.protocol, dist=run.dist, rate=f"{run.rate:g}",
                               replica=str(run.replica))

    assert exp.run_seed("poisson")(wildcards(Run("fb", 0.1, 1e-5, 0))) == 1500353117813921369
    assert exp.run_seed("ls")(wildcards(Run("ls", 0.1, 0.01, 0))) == 5496374529805661334
    assert exp.run_seed("mls")(wildcards(Run("ls", 0.0, 0.03, 0))) == 1623693035185507168
    w = _wildcards(exp.paths.grid(), str(exp.grid_path(grid)))
    assert exp.grid_seed(w) == grid.seed(exp.master_seed) == 7424266578111144428


def test_one_mls_command_for_the_search_and_the_grid():
    """Both MLS rules run mls_command; only where the rate ladder comes from differs."""
    search = mls_command("{params.initial_rate}", "{params.decrease_factor}", "{params.final_rate}")
    grid = mls_command("{wildcards.g0}", "{wildcards.factor}", "{wildcards.gf}")
    assert search.startswith("spherejam mls {input} --initial-rate {params.initial_rate} ")
    assert search.replace("params.initial_rate", "wildcards.g0").replace("params.decrease_factor", "wildcards.factor") \
        .replace("params.final_rate", "wildcards.gf") == grid
    exp = Experiment(tiny())
    assert exp.mls_options() == "--stall-windows 1000 --max-collisions-per-particle 500000.0"
    exp.config["mls"].update(stall_windows=None, max_collisions_per_particle=None, max_wall_time=3600)
    assert exp.mls_options() == "--no-stall-rule --max-wall-time 3600"
    assert exp.fb_options() == "" and Experiment({**tiny(), "fb": {**tiny()["fb"], "phi_nominal": 0.5}}).fb_options() \
        == "--phi-nominal 0.5"


def _strings(path):
    with open(path) as fh:
        return [eval(t.string) for t in tokenize.generate_tokens(fh.readline) if t.type == tokenize.STRING]


def test_rules_spell_no_path_seed_or_mls_command():
    """Paths, seeds and the MLS command line live in spherejam.workflow.experiment: the rule files name no file but
    their own sources (config, conda env, report captions), derive no seed and write no `spherejam mls`."""
    files = [ROOT / "Snakefile", *sorted((ROOT / "rules").glob("*.smk"))]
    assert len(files) > 5
    for path in files:
        text = path.read_text()
        for s in _strings(path):
            assert "/" not in s or (path.parent / s).is_file(), (path.name, s)
        assert "spherejam mls" not in "".join(_strings(path)), path.name
        assert "derive_seed" not in text and ".seed(" not in text and "master_seed" not in text, path.name
        assert not re.search(r"\{(protocol|sigma|rate|replica)\}", "".join(_strings(path))), path.name


def test_dataset_inputs_follow_the_enabled_stages():
    cfg = tiny()
    exp = Experiment(cfg)
    files = exp.dataset_inputs()
    assert len(files) == len(exp.runs()) * 5 + len(exp.grid_runs())
    assert str(exp.path(exp.runs()[0], "calippso_packing")) in files
    cfg["calippso"]["enabled"] = False
    cfg["analysis"]["enabled"] = False
    files = Experiment(cfg).dataset_inputs()
    assert len(files) == len(exp.runs()) * 2 + len(exp.grid_runs()) and not any("calippso" in f for f in files)
