"""SLURM resource estimates (spherejam.workflow.cost_model): calibration, monotonicity, limits and input checks."""

from __future__ import annotations

import ast
import math
from pathlib import Path

import pytest

from spherejam.core.errors import InputError
from spherejam.workflow import cost_model as cr

# LS collisions per particle from a Poisson start to p = 1e12, N = 1000, sigma = 0: our engine and the reference
# C++ code (reference-benchmark.md), at gamma = 1e-1, 1e-2, 1e-3.
MEASURED_LS = {1e-1: (523, 495), 1e-2: (2533, 2367), 1e-3: (20177, 18525)}


@pytest.mark.parametrize("rate", sorted(MEASURED_LS))
def test_ls_collision_model_matches_measured_runs(rate):
    model = cr.ls_collisions_per_particle(rate)
    for measured in MEASURED_LS[rate]:
        assert measured / 1.3 < model < measured * 1.3


def test_time_limits_cover_the_reference_codes_runs():
    # Wall times of the (slower) reference code on the same machine type: a limit that covers them leaves room
    # for a slow node or a slower engine than ours.
    assert cr.runtime_minutes("ls", 10000, rate=1e-2) * 60 > 114  # LS N=1e4, gamma=1e-2: 114 s
    assert cr.runtime_minutes("ls", 1000, rate=1e-3) * 60 > 71  # LS N=1000, gamma=1e-3: 71 s
    mls_p1000 = cr.runtime_minutes("mls", 1000, initial_rate=1e-2, final_rate=1e-4)  # LSGD: 420 s
    assert mls_p1000 * 60 > 420
    # ... and the per-particle MLS estimate is within a few times the measured 7.1e4 (N=500) and 1.2e5 (N=1000).
    per_particle = cr.mls_collisions_per_particle(1e-2, 2.0, 1e-4)
    assert 1.2e5 <= per_particle <= 5 * 1.2e5


# MLS searches of the band check (issue 4): N = 10^4, sigma = 0, fast LS start, the paper's ladder 10 -> 1e-4.
# CPU hours: measured for seed 1; estimated for seeds 2-5, which ran in pieces (from their collisions at 0.95-1.3e6/s).
MEASURED_MLS_1E4 = {"collisions": (5.98e9, 11.33e9, 9.19e9, 11.33e9, 16.0e9),
                    "cpu_hours": (1.27, 3.13, 2.47, 3.33, 4.68)}


def test_mls_model_matches_the_n_1e4_searches():
    per_particle = cr.mls_collisions_per_particle(n=10000)
    collisions = MEASURED_MLS_1E4["collisions"]
    assert min(collisions) < 10000 * per_particle < max(collisions)
    hours = cr.cpu_seconds("mls", 10000) / 3600
    assert min(MEASURED_MLS_1E4["cpu_hours"]) < hours < 1.5 * max(MEASURED_MLS_1E4["cpu_hours"])
    # the limit covers the slowest search on a node 2x slower than ours
    assert cr.runtime_minutes("mls", 10000) / 60 > 2 * max(MEASURED_MLS_1E4["cpu_hours"])
    # per particle the cost grows with N at every N (a larger packing unjams more often)
    assert cr.mls_collisions_per_particle(n=10000) > 3 * cr.mls_collisions_per_particle(n=1000)
    assert cr.mls_collisions_per_particle(n=250) < 0.6 * cr.mls_collisions_per_particle(n=1000)


#: Mean MLS collisions per particle of the reproduction ladder's searches from fast starts at sigma = 0 (32 per N,
#: archive/reproduction/dataset.nc; `benchmarks/cost_fit.py fit`, docs/algorithms.md §7.9).
MEASURED_MLS_REPRODUCTION = {250: 1.41e5, 500: 2.02e5, 1000: 3.04e5}


@pytest.mark.parametrize("n", sorted(MEASURED_MLS_REPRODUCTION))
def test_mls_model_matches_the_reproduction_searches(n):
    measured = MEASURED_MLS_REPRODUCTION[n]
    assert measured / 1.15 < cr.mls_collisions_per_particle(n=n) < measured * 1.15


def test_mls_rate_ladder_is_the_papers():
    rates = cr.mls_rates(10.0, 2.0, 1e-4)
    assert len(rates) == 18  # 10, 5, ..., 10 / 2^17
    assert rates[-1] == pytest.approx(10.0 / 2**17)
    assert rates[-2] > 1e-4 >= rates[-1]
    assert cr.mls_rates(1e-4, 2.0, 1e-4) == [1e-4]


def test_costs_grow_with_n_and_with_slower_rates():
    for stage, kw in [("ls", {"rate": 1e-3}), ("fb", {"rate": 1e-5}), ("mls", {}), ("calippso", {})]:
        assert cr.cpu_seconds(stage, 10000, **kw) > cr.cpu_seconds(stage, 1000, **kw)
    assert cr.cpu_seconds("ls", 1000, 1e-4) > cr.cpu_seconds("ls", 1000, 1e-3) > cr.cpu_seconds("ls", 1000, 1.0)
    assert cr.cpu_seconds("fb", 1000, 1e-7) > cr.cpu_seconds("fb", 1000, 1e-3)
    # Validation grid: a smaller decrease factor or a lower final rate means more MLS phases.
    base = cr.mls_collisions_per_particle(10.0, 2.0, 1e-4)
    assert cr.mls_collisions_per_particle(10.0, 1.5, 1e-4) > base
    assert cr.mls_collisions_per_particle(10.0, 2.0, 1e-5) > 3 * base
    assert cr.runtime_minutes("ls", 10000, rate=1e-4) > cr.runtime_minutes("ls", 10000, rate=1e-2)


def test_calippso_model_matches_the_measured_certification_times(monkeypatch):
    """Mean LPs per certification in the reproduction ladder (3.9, 6.8 and 14.7 at N = 250, 500, 1000), then through
    the mean of the two whole certifications of N = 10^4 MLS outputs (29 and 173 LPs: 101); CPU s per LP on the
    vertex path through 30 whole N = 1000 certifications (0.52) and the N = 4096 run's LPs (27.2), then, with no LP
    warm-started, through the two N = 10^4 MLS outputs' whole certifications pooled (123.2); with interior steps
    through the same N = 1000 inputs' whole certifications (IPX below N = 4096) and the N = 16384 run's interior
    steps (benchmarks/calippso_cost_fit.py, docs/cluster.md §3). Each N is priced on the path that runs there."""
    from spherejam.calippso.lp import WARM_START_MAX_N
    from spherejam.core import calippso_path

    for n, lps in ((250, 3.9), (500, 6.8), (1000, 14.7), (10_000, 101)):
        assert cr.calippso_lps(n) == pytest.approx(lps, rel=0.1)
    assert cr.calippso_lps(1001) == pytest.approx(cr.calippso_lps(1000), rel=1e-3)  # one law, bent at N = 1000
    monkeypatch.setattr(calippso_path, "INTERIOR_STEPS_MIN_N", None)  # today's default: every LP a vertex
    assert cr.cpu_seconds("calippso", 1000) / cr.calippso_lps(1000) == pytest.approx(0.52, rel=0.05)
    # the law bends where the LP path does: from the N with no warm starts on, every LP is a cold solve
    assert cr.CALIPPSO_COLD_MIN_N == WARM_START_MAX_N
    assert cr.calippso_lp_seconds(4095) == pytest.approx(27.2, rel=0.05)
    assert cr.calippso_lp_seconds(4096) == pytest.approx(27.2, rel=0.05)
    assert cr.calippso_lp_seconds(10_000) == pytest.approx(123.2, rel=0.05)
    assert cr.calippso_lp_seconds(1000, interior_steps=True) == pytest.approx(0.787, rel=0.05)
    assert cr.calippso_lp_seconds(16384, interior_steps=True) == pytest.approx(120.0, rel=0.05)
    # a certification at N = 10^4 (~3.5 h expected on the vertex path) fits in one job within the 24 h ceiling
    monkeypatch.delenv("SPHEREJAM_MAX_RUNTIME", raising=False)
    assert cr.runtime_minutes("calippso", 10000) < cr.MAX_RUNTIME_MINUTES
    assert cr.runtime_minutes("calippso", 10000, interior_steps=True) < cr.MAX_RUNTIME_MINUTES
    # the path that runs: with the rule set, vertices below its N, interior steps from it on; a forced path wins
    monkeypatch.setattr(calippso_path, "INTERIOR_STEPS_MIN_N", 4096)
    assert cr.calippso_lp_seconds(4095) == cr.calippso_lp_seconds(4095, interior_steps=False)
    assert cr.calippso_lp_seconds(4096) == cr.calippso_lp_seconds(4096, interior_steps=True)
    assert cr.calippso_lp_seconds(10000) == cr.calippso_lp_seconds(10000, interior_steps=True)
    assert cr.calippso_lp_seconds(10000) != cr.calippso_lp_seconds(10000, interior_steps=False)


def test_floor_ceiling_and_attempts(monkeypatch):
    monkeypatch.delenv("SPHEREJAM_MAX_RUNTIME", raising=False)
    tiny = cr.runtime_minutes("seed", 40)
    assert tiny == cr.FLOOR_MINUTES["seed"]
    assert cr.runtime_minutes("seed", 40, attempt=3) == 3 * tiny
    huge = cr.runtime_minutes("mls", 10000, initial_rate=20.0, decrease_factor=1.5, final_rate=1e-5)
    assert huge == cr.MAX_RUNTIME_MINUTES
    assert cr.runtime_minutes("mls", 10000, attempt=10) == cr.MAX_RUNTIME_MINUTES
    monkeypatch.setenv("SPHEREJAM_MAX_RUNTIME", "120")
    assert cr.runtime_minutes("mls", 10000) == 120
    assert cr.runtime_minutes("seed", 40) == tiny
    monkeypatch.setenv("SPHEREJAM_MAX_RUNTIME", "two days")
    with pytest.raises(InputError, match="SPHEREJAM_MAX_RUNTIME"):
        cr.runtime_minutes("seed", 40)


def test_paper_sized_jobs_ask_for_plausible_limits(monkeypatch):
    monkeypatch.delenv("SPHEREJAM_MAX_RUNTIME", raising=False)
    # N = 1e4 MLS 10 -> 1e-4: hours, not minutes and not days.
    assert 60 <= cr.runtime_minutes("mls", 10000) <= 24 * 60
    # Fast LS compressions and FB runs at N = 1e4 stay short, so they do not queue behind long jobs.
    assert cr.runtime_minutes("ls", 10000, rate=1.0) <= 15
    assert cr.runtime_minutes("fb", 10000, rate=1e-3) <= 15
    for stage in cr.STAGES:
        est = cr.estimate(stage, 10000, rate=1e-3)
        assert isinstance(est.runtime, int) and est.runtime >= 1
        assert isinstance(est.mem_mb, int) and est.mem_mb >= cr.BASE_MEM_MB
        assert est.cpus_per_task == 1
        assert math.isfinite(est.cpu_seconds) and est.cpu_seconds > 0


def test_memory_grows_with_n_and_attempt():
    assert cr.mem_mb("calippso", 10000) >= 4000
    assert cr.mem_mb("calippso", 10000) > cr.mem_mb("calippso", 1000)
    assert cr.mem_mb("ls", 40) >= cr.BASE_MEM_MB
    assert cr.mem_mb("ls", 10000, attempt=2) == 2 * cr.mem_mb("ls", 10000)


def test_job_resources_are_snakemake_resource_callables():
    """job_resources gives the rules' resources: (wildcards, attempt) -> int, wildcard values arriving as text; an
    LS job's time from its rate wildcard, an MLS job's from its ladder."""
    from types import SimpleNamespace

    w = SimpleNamespace(rate="0.01")
    ls = cr.job_resources("ls", 256)
    assert set(ls) == {"runtime", "mem_mb", "cpus_per_task"} and ls["cpus_per_task"] == 1
    assert ls["runtime"](w, 1) == cr.runtime_minutes("ls", 256, 0.01) < ls["runtime"](w, 2)
    assert ls["mem_mb"](w, 2) == cr.mem_mb("ls", 256, 2)
    n = 10000
    ladder = {"initial_rate": 10.0, "decrease_factor": 2.0, "final_rate": 1e-4}
    paper = cr.job_resources("mls", n, lambda wildcards: ladder)["runtime"](w, 1)
    short = cr.job_resources("mls", n, lambda wildcards: {**ladder, "final_rate": 1e-2})["runtime"](w, 1)
    assert paper == cr.runtime_minutes("mls", n, **ladder) > short  # the rate wildcard is not an MLS parameter
    with pytest.raises(InputError, match="^stage="):
        cr.job_resources("jam", 256)


@pytest.mark.parametrize(
    ("call", "field"),
    [
        (lambda: cr.runtime_minutes("md", 100), "stage"),
        (lambda: cr.runtime_minutes("ls", 100), "rate"),
        (lambda: cr.runtime_minutes("ls", 100, rate=-1.0), "rate"),
        (lambda: cr.runtime_minutes("ls", 100, rate=float("nan")), "rate"),
        (lambda: cr.runtime_minutes("fb", 100, rate=2.0), "rate"),
        (lambda: cr.runtime_minutes("ls", 1, rate=0.1), "n"),
        (lambda: cr.runtime_minutes("ls", 100.5, rate=0.1), "n"),
        (lambda: cr.runtime_minutes("seed", 100, attempt=0), "attempt"),
        (lambda: cr.runtime_minutes("mls", 100, decrease_factor=1.0), "decrease_factor"),
        (lambda: cr.runtime_minutes("mls", 100, final_rate=0.0), "final_rate"),
        (lambda: cr.mem_mb("seed", 100, attempt=True), "attempt"),
        (lambda: cr.mls_collisions_per_particle(n=1), "n"),
    ],
)
def test_bad_input_names_the_field(call, field):
    with pytest.raises(InputError, match=rf"^{field}="):
        call()


def _top_level_imports(module) -> set[str]:
    imported = set()
    for node in ast.parse(Path(module.__file__).read_text()).body:
        if isinstance(node, ast.Import):
            imported |= {a.name.split(".")[0] for a in node.names}
        elif isinstance(node, ast.ImportFrom):
            imported.add("." * node.level + (node.module or ""))
    return imported


def test_module_imports_nothing_heavy():
    # Snakemake evaluates these functions for every job while building the DAG; only the sizing helpers
    # (plan, load_configs) import more, inside the functions.
    from spherejam.core import calippso_path, rate_ladder
    from spherejam.workflow import pair_load

    allowed = {"__future__", "math", "operator", "os", "dataclasses", "..core.errors", "..core.rate_ladder",
               ".pair_load", "..core.calippso_path"}
    assert _top_level_imports(cr) <= allowed
    assert _top_level_imports(rate_ladder) <= {"__future__", "math"}
    assert _top_level_imports(calippso_path) <= {"__future__"}
    assert _top_level_imports(pair_load) <= {"__future__", "math", "..core.errors"}


def test_plan_counts_the_workflows_jobs():
    import yaml

    from spherejam.workflow.experiment import Experiment

    root = Path(__file__).resolve().parents[2]
    config = yaml.safe_load((root / "config" / "config.yaml").read_text())
    [table] = cr.plan(config).values()  # one N
    exp = Experiment(config)
    runs = exp.runs()
    assert table["seed"]["jobs"] == table["mls"]["jobs"] == len(runs)
    assert table["ls"]["jobs"] == len(exp.runs("ls")) and table["fb"]["jobs"] == len(exp.runs("fb"))
    assert table.get("mls_grid", {"jobs": 0})["jobs"] == len(exp.grid_runs())
    for row in table.values():
        assert row["requested_hours"] >= row["cpu_hours"] > 0


def test_load_configs_merges_later_files_over_earlier_recursively(tmp_path):
    (tmp_path / "a.yaml").write_text("n: 200\nmls: {final_rate: 1.0e-4, max_collisions_per_particle: 5.0e+5}\n")
    (tmp_path / "b.yaml").write_text("n: 10000\nmls: {max_collisions_per_particle: null}\n")
    merged = cr.load_configs(tmp_path / "a.yaml", tmp_path / "b.yaml")
    assert merged == {"n": 10000, "mls": {"final_rate": 1e-4, "max_collisions_per_particle": None}}


def test_cost_command_prints_the_plan(tmp_path, capsys):
    """`spherejam cost` (the one way to print the cost model) prints one row per stage of :func:`plan`, named as
    the workflow's rules, and the total."""
    from spherejam.cli import main

    root = Path(__file__).resolve().parents[2] / "config"
    configs = [str(root / "config.yaml"), str(root / "paper.yaml")]
    assert main(["cost", *configs]) == 0
    table = capsys.readouterr().out
    [plan] = cr.plan(cr.load_configs(*configs)).values()  # one N
    rows = {line.split()[0]: line.split()[1:] for line in table.splitlines()[3:]}
    assert set(rows) == set(plan) | {"total"}
    assert set(plan) == {"seed", "ls", "fb", "mls", "mls_grid", "analyze", "calippso"}
    for stage, row in plan.items():
        assert rows[stage] == [str(row["jobs"]), f"{row['cpu_hours']:.1f}", f"{row['requested_hours']:.1f}"]
    total_jobs = sum(row["jobs"] for row in plan.values())
    assert table.splitlines()[1] == "N = 10000" and rows["total"][0] == str(total_jobs)
    (tmp_path / "bad.yaml").write_text("n: [\n")
    (tmp_path / "list.yaml").write_text("- 1\n")
    for bad, needle in (("missing.yaml", "no such config file"), ("bad.yaml", "not valid YAML"),
                        ("list.yaml", "mapping")):
        assert main(["cost", str(tmp_path / bad)]) == 2
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and bad in err[0] and needle in err[0]


# --- the size distribution's factor (issue 47, docs/algorithms.md §7.9) -------------------------------------------
#: Slow-down of LS against equal spheres (mono's collisions per CPU second / the mixture's, one invocation per N) of
#: bidisperse mixtures 30 % small by volume, gamma = 1e-2 from phi = 0.58 to p = 1e12, the engine the package's
#: constants were fitted to (before the copies by field, docs/algorithms.md §7.11): the fit rows
#: of `benchmarks/cost_fit.py fit` (N = 300 and 1000: `bench_ls.py wide`, 2026-12-05, benchmarks/records/cost_fit;
#: N = 10^4: docs/algorithms.md §7.6-7.7). (N, size ratio) -> slow-down; 1:5 at N = 300 and 1:10 at N = 1000 are in
#: the engine's multi-image mode.
MEASURED_SLOWDOWN = {(300, 3.0): 1.47, (300, 5.0): 8.56, (1000, 3.0): 1.57, (1000, 5.0): 2.10, (1000, 10.0): 7.00,
                     (10000, 3.0): 1.38, (10000, 5.0): 2.04, (10000, 10.0): 3.37}
MULTI_IMAGE_ROWS = {(300, 5.0), (1000, 10.0)}


def _psd_rows(path: Path) -> dict[str, tuple[str, int, float]]:
    import csv

    with open(path, newline="") as f:
        rows = csv.DictReader(line for line in f if not line.startswith("#"))
        return {r["row"]: (r["spec"], int(r["n"]), float(r["cpu_minutes"])) for r in rows}


#: The PSD acceptance rows, row -> (spec, N, recorded CPU minutes) (docs/psd.md §8; one file with cost_fit.py).
PSD_ROWS = _psd_rows(Path(__file__).resolve().parents[2] / "benchmarks" / "records" / "psd_acceptance_cpu.csv")
def _bidisperse(ratio: float, n: int) -> list[float]:
    import numpy as np

    from spherejam.core.size_distribution import parse

    return parse(f"bidisperse:ratio={ratio},small=0.3,by=volume").draw(n, np.random.default_rng(0)).tolist()


def test_distribution_factor_is_one_for_equal_spheres():
    assert cr.pair_load([0.7] * 50) == pytest.approx(1.0, abs=1e-12)
    assert cr.distribution_factor(1.0, 300) == cr.distribution_factor(1.0, 10000) == 1.0
    for stage, kw in (("ls", {"rate": 1e-2}), ("mls", {})):
        assert cr.cpu_seconds(stage, 10000, load=1.0, **kw) == cr.cpu_seconds(stage, 10000, **kw)
    # a monodisperse config's plan and time limits are those of the model by N alone
    import yaml

    from spherejam.workflow.experiment import Experiment

    root = Path(__file__).resolve().parents[2]
    config = yaml.safe_load((root / "config" / "config.yaml").read_text())
    config.update(sigmas=[0.0], validation_grid={"enabled": False})
    exp = Experiment(config)
    assert exp.pair_load("sigma0", exp.largest_n) == pytest.approx(1.0, abs=1e-12)
    [table] = cr.plan(config).values()
    n = exp.largest_n
    assert table["mls"]["cpu_hours"] == pytest.approx(
        len(exp.runs()) * cr.cpu_seconds("mls", n, **exp.mls_ladder) / 3600, rel=1e-12)
    assert cr.pair_load([1.0, 1.0, 2.0]) > 1.0
    with pytest.raises(InputError, match="^diameters="):
        cr.pair_load([1.0, 0.0])
    with pytest.raises(InputError, match="^load="):
        cr.distribution_factor(0.0, 1000)


def test_distribution_factor_follows_the_measured_slowdowns():
    """The factor against the measured LS slow-downs (the fit's rows): it grows with the size ratio at each N, falls
    with N at each ratio, and lies within 30 % of each single-image row; the two multi-image rows, which one factor
    M prices, within a factor 1.7 (0.59 and 1.64 of the measured, docs/algorithms.md §7.9)."""
    from spherejam.workflow import pair_load

    factor = {}
    for (n, ratio), measured in MEASURED_SLOWDOWN.items():
        d = _bidisperse(ratio, n)
        assert (pair_load.image_span(d) >= pair_load.MULTI_IMAGE_SPAN) == ((n, ratio) in MULTI_IMAGE_ROWS)
        factor[n, ratio] = cr.distribution_factor(cr.pair_load(d), n)
        band = 1.7 if (n, ratio) in MULTI_IMAGE_ROWS else 1.3
        assert measured / band < factor[n, ratio] < measured * band, (n, ratio, factor[n, ratio], measured)
    for n in (1000, 10000):
        assert factor[n, 3.0] < factor[n, 5.0] < factor[n, 10.0]
    assert factor[300, 3.0] > factor[1000, 3.0] > factor[10000, 3.0]
    assert factor[300, 5.0] > factor[1000, 5.0] > factor[10000, 5.0]
    # the multi-image factor: 1:4 at N = 300 spans 0.43 L (multi-image), at N = 600 0.34 L (not)
    assert pair_load.image_span(_bidisperse(4.0, 300)) > pair_load.MULTI_IMAGE_SPAN > pair_load.image_span(
        _bidisperse(4.0, 600))
    d = _bidisperse(4.0, 300)
    assert cr.pair_load(d) == pytest.approx(pair_load.list_load(d) * pair_load.MULTI_IMAGE_FACTOR)


def _psd_row_minutes(spec: str, n: int) -> float:
    import yaml

    root = Path(__file__).resolve().parents[2]
    config = yaml.safe_load((root / "config" / "psd.yaml").read_text())
    config.update(distributions={"row": spec}, n=n, replicas=1, results="unused")
    [table] = cr.plan(config).values()
    return 60.0 * sum(row["cpu_hours"] for row in table.values())


#: The row the refitted model misses (strict: the test fails if it comes within): the model has no term for a narrow
#: distribution's cost beyond equal spheres' (Gaussian delta = 0.2: W = 1.12, LS at N = 300 0.98 of mono's rate), and
#: the measured row cost 1.32 x the mono row (docs/algorithms.md §7.9).
PSD_MISSED = {"gauss02": "estimate 8.6 against 11.9 measured CPU-min (x 1/1.38); its LS runs at mono's speed"}


@pytest.mark.parametrize("row", [pytest.param(r, marks=pytest.mark.xfail(strict=True, reason=PSD_MISSED[r]))
                                 if r in PSD_MISSED else r for r in PSD_ROWS])
def test_psd_acceptance_rows_are_priced_within_30_percent(row, monkeypatch):
    """docs/psd.md §8: each row's recorded CPU minutes (one `spherejam rcp` call: 5 LS + 5 FB packings, each then
    MLS and CALiPPSO) against the cost model's estimate of that call. No row is in the model's fit (docs/algorithms.md
    §7.9)."""
    monkeypatch.chdir(Path(__file__).resolve().parents[2])  # the powder row's table file is relative to the repository
    spec, n, measured = PSD_ROWS[row]
    estimate = _psd_row_minutes(spec, n)
    assert measured / 1.3 < estimate < measured * 1.3, (row, estimate, measured)


@pytest.mark.parametrize("row", [r for r in PSD_ROWS if not r.startswith("mono")])
def test_psd_acceptance_rows_relative_to_mono_within_30_percent(row, monkeypatch):
    """The distribution's part alone: each row's cost relative to the mono row of the same N, measured and
    estimated (the N-part of the model cancels)."""
    monkeypatch.chdir(Path(__file__).resolve().parents[2])
    spec, n, measured = PSD_ROWS[row]
    mono_spec, _, mono_measured = PSD_ROWS[f"mono{n}"]
    estimated = _psd_row_minutes(spec, n) / _psd_row_minutes(mono_spec, n)
    assert measured / mono_measured / 1.3 < estimated < measured / mono_measured * 1.3, (row, estimated)
