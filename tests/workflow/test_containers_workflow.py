"""Containers as an axis of the workflow: config validation, paths and seeds (the periodic cube's unchanged), the
CALiPPSO switch, `spherejam rcp --container --dry-run`, and a tiny container run through Snakemake."""

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import yaml

from spherejam.core.errors import InputError
from spherejam.workflow.config import validate_config
from spherejam.workflow.experiment import Experiment

ROOT = Path(__file__).resolve().parents[2]
SCHEMA = ROOT / "config" / "schema.yaml"


def tiny(**changes):
    cfg = yaml.safe_load((ROOT / "config" / "tiny.yaml").read_text())
    cfg.update(changes)
    return cfg


def checked(cfg):
    validate_config(cfg, SCHEMA)
    return Experiment(cfg)


@pytest.mark.parametrize("containers, words", [
    ({"col": "cylinder:diam=10"}, ["containers.col", "diam"]),
    ({"col": "tube:diameter=10"}, ["containers.col", "tube"]),
    ({"col": "cylinder:diameter=0.5"}, ["containers.col", "diameter=0.5"]),  # cannot hold a sphere
    ({"col": "sphere:diameter=1.2"}, ["containers.col", "holds about"]),  # fixes N below 2
    ({"ls": "cylinder:diameter=10"}, ["containers.ls"]),  # would read as the protocol in a run key
    ({"a": "cylinder:diameter=10", "b": "cylinder:diameter=10.0"}, ["containers.b", "containers.a"]),
    (["periodic", "cylinder:diameter=10"], ["containers"]),  # a mapping of names to specs
])
def test_bad_containers_are_one_line_naming_field_and_value(containers, words):
    with pytest.raises(InputError) as err:
        checked(tiny(containers=containers))
    text = str(err.value)
    assert "\n" not in text
    for w in words:
        assert w in text


def test_bad_container_stops_the_workflow_in_one_line(tmp_path):
    cfg = tiny(results=str(tmp_path / "r"), containers={"col": "cylinder:diameter=0.5"})
    (tmp_path / "c.yaml").write_text(yaml.safe_dump(cfg))
    r = subprocess.run([sys.executable, "-m", "snakemake", "-n", "--cores", "1", "--configfile",
                        str(tmp_path / "c.yaml")], cwd=ROOT, capture_output=True, text=True, timeout=300)
    assert r.returncode != 0
    line = next(x for x in (r.stdout + r.stderr).splitlines() if "containers.col" in x)
    assert "diameter=0.5" in line


def test_periodic_only_keeps_paths_and_seeds():
    """Without containers, or with the periodic cube alone, run keys and seeds are those of before containers.
    The pinned seed is the one main (7a6697a, before containers) gives this packing of config/tiny.yaml."""
    plain = checked(tiny())
    for cfg in (tiny(containers={}), tiny(containers={"bulk": "periodic"})):
        same = checked(cfg)
        assert not same.has_containers
        assert [r.key for r in same.runs()] == [r.key for r in plain.runs()]
        assert [r.seed(7) for r in same.runs()] == [r.seed(7) for r in plain.runs()]
        assert same.paths.packing("poisson") == plain.paths.packing("poisson")
        assert same.dataset_inputs() == plain.dataset_inputs()
    run = next(r for r in plain.runs() if r.key == "fb/sigma0/rate0.01/r0")
    assert run.seed(plain.master_seed, "poisson") == 3357583888383808547
    assert "{container}" not in plain.paths.packing("poisson")
    assert "containers" not in plain.figure_names and "profiles" not in plain.figure_names


def test_container_axis_in_keys_seeds_sizes_and_inputs():
    exp = checked(tiny(containers={"bulk": "periodic", "col": "cylinder:diameter=5", "ball": "sphere:diameter=6"},
                       validation_grid={"enabled": False}))
    assert exp.has_containers
    runs = exp.runs()
    assert len(runs) == 3 * len(checked(tiny()).runs())
    keys = {r.key.split("/")[0] for r in runs}
    assert keys == {"bulk", "col", "ball"}
    # the same packing in two containers: independent seeds, and not the periodic-only experiment's either
    same = [r for r in runs if r.key.endswith("ls/sigma0/rate0.5/r0")]
    seeds = {r.seed(7) for r in same} | {next(r for r in checked(tiny()).runs()
                                               if r.key == "ls/sigma0/rate0.5/r0").seed(7)}
    assert len(seeds) == 4
    # N: the experiment's where a length is free, the container's own where it gives every length
    col = next(r for r in runs if r.container == "col")
    ball = next(r for r in runs if r.container == "ball")
    assert exp.size(col) == 80 and exp.cell_n(ball) == 80
    assert 100 < exp.size(ball) < 150  # pi/6 * 6^3 * 0.62 / (pi/6) = 134 equal spheres
    # CALiPPSO certifies every container
    inputs = exp.dataset_inputs()
    assert exp.certifies(next(r for r in runs if r.container == "bulk")) and exp.certifies(col)
    assert any(p.endswith("bulk/ls/sigma0/rate0.5/r0/calippso.json") for p in inputs)
    assert exp.paths.packing("calippso", col.key) in inputs
    assert {"containers", "profiles"} <= set(exp.figure_names)


def test_calippso_off_certifies_no_container():
    exp = checked(tiny(containers={"bulk": "periodic", "col": "cylinder:diameter=5"}, calippso={"enabled": False}))
    assert not any(exp.certifies(r) for r in exp.runs())
    assert not any("calippso" in p for p in exp.dataset_inputs())


def test_a_ladder_refuses_a_container_that_fixes_n():
    with pytest.raises(InputError, match="containers.ball"):
        checked(tiny(n=[40, 80], containers={"ball": "sphere:diameter=6"}))


def test_cost_prices_each_container_at_its_n():
    from spherejam.workflow.cost_model import plan

    cfg = tiny(containers={"bulk": "periodic", "ball": "sphere:diameter=20"})
    validate_config(cfg, SCHEMA)
    p = plan(cfg)
    ball = next(k for k in p if "ball" in str(k))
    bulk = next(k for k in p if "bulk" in str(k))
    assert ball.startswith("49") and bulk.startswith("80 ")  # 0.62 * 20^3 = 4960 equal spheres
    assert "calippso" in p[bulk] and "calippso" in p[ball]
    assert p[ball]["calippso"]["cpu_hours"] > p[bulk]["calippso"]["cpu_hours"]  # 62 times the spheres
    # the same jobs at a larger N cost more
    assert p[ball]["mls"]["cpu_hours"] > p[bulk]["mls"]["cpu_hours"]


def test_rcp_container_dry_run_prices_both(tmp_path):
    r = subprocess.run([sys.executable, "-m", "spherejam.cli", "rcp", "mono=lognormal:sigma=0", "--container",
                        "cylinder:diameter=10", "--n", "400", "--dry-run", "-o", str(tmp_path / "r")],
                       cwd=tmp_path, capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stderr
    out = r.stdout
    assert "N = 400 in bulk (periodic)" in out
    assert "N = 400 in cylinder-diameter-10 (cylinder:diameter=10.0)" in out
    # both containers' packings are certified and priced
    assert out.count("calippso") >= 2 and "CALiPPSO not run" not in out
    config = yaml.safe_load(out[out.index("results:"):])
    assert config["containers"] == {"bulk": "periodic", "cylinder-diameter-10": "cylinder:diameter=10.0"}
    bad = subprocess.run([sys.executable, "-m", "spherejam.cli", "rcp", "mono=lognormal:sigma=0", "--container",
                          "cylinder:diam=10", "--dry-run", "-o", str(tmp_path / "r")],
                         cwd=tmp_path, capture_output=True, text=True, timeout=300)
    assert bad.returncode == 2
    assert bad.stderr.strip().count("\n") == 0 and "--container='cylinder:diam=10'" in bad.stderr


@pytest.fixture(scope="module")
def container_run(tmp_path_factory):
    """A tiny experiment in the periodic cube and in a cylinder, through Snakemake (N = 24)."""
    out = tmp_path_factory.mktemp("containers")
    cfg = tiny(results=str(out / "results"), n=24, sigmas=[0.0], containers={"bulk": "periodic",
                                                                           "col": "cylinder:diameter=3"})
    cfg["ls"]["rates"] = [0.5]
    cfg["fb"]["rates"] = [0.01]
    cfg["validation_grid"] = {"enabled": False}
    cfg["figures"] = {"render_fig1": False, "view_pages": True}
    (out / "c.yaml").write_text(yaml.safe_dump(cfg))
    r = subprocess.run([sys.executable, "-m", "snakemake", "--cores", "2", "--configfile", str(out / "c.yaml")],
                       cwd=ROOT, capture_output=True, text=True, timeout=1500)
    assert r.returncode == 0, r.stderr[-5000:]
    return out / "results"


@pytest.mark.slow
def test_tiny_container_run(container_run):
    import pandas as pd

    from spherejam.core.packing_io import read_packing
    from spherejam.workflow.dataset import open_dataset

    ds = open_dataset(container_run / "dataset.nc")
    assert sorted(set(ds.container.values.tolist())) == ["bulk", "col"]
    col = ds.container.values == "col"
    assert np.all(np.isfinite(ds.phi_J.values))
    # the cylinder's achieved D/<d> is that of its jammed packing, near the 3 asked for
    key = str(ds.key.values[col][0])
    jammed = read_packing(container_run / "packings" / key / "jammed.h5")
    assert jammed.container.curved == "cylinder"
    d_over_d = 2 * jammed.container.radius / jammed.mean_diameter
    assert float(ds.container_size.values[col][0]) == pytest.approx(d_over_d, rel=1e-12)
    assert 2.5 < d_over_d < 3.5
    assert np.all(np.isnan(ds.container_size.values[~col]))
    # CALiPPSO certified the packings in both containers (wall rows in the cylinder), isostatic by each one's count
    assert np.all(ds.calippso_converged.values == 1)
    assert np.all(ds.calippso_is_isostatic.values == 1)
    assert not any("calippso" in s for s in ds.not_available.values[col])
    assert all("voronoi" in s for s in ds.not_available.values[col])
    # the exact profile: porosity 1 at the wall (no sphere centre is closer than its radius)
    prof = ds.profile_porosity.values[col]
    assert np.all(prof[:, 0] > 0.9) and np.all(np.isnan(ds.profile_porosity.values[~col]))
    # tables per container, the bulk beside the paper, the cylinder without it
    t4 = pd.read_csv(container_run / "tables" / "table4.csv")
    assert t4.container.tolist() == ["bulk", "col"]
    assert np.isnan(t4.phi_RCP_paper[t4.container == "col"]).all()
    assert not np.isnan(t4.phi_RCP_paper[t4.container == "bulk"]).all()
    for name in ("containers", "profiles", "fig2"):
        assert (container_run / "figures" / f"{name}.png").stat().st_size > 10_000
    pages = sorted((container_run / "views").rglob("*.html"))
    assert [p.relative_to(container_run / "views").parts[0] for p in pages] == ["bulk", "col"]


def _two_containers():
    """The synthetic dataset of test_tables twice: in the periodic cube and, 0.02 looser, in a cylinder."""
    import xarray as xr

    from test_tables import synthetic_dataset

    bulk, col = synthetic_dataset(), synthetic_dataset()
    col["phi_J"] = col["phi_J"] - 0.02
    n = bulk.sizes["packing"]
    parts = []
    for ds, key, spec, size in ((bulk, "bulk", "periodic", np.nan), (col, "col", "cylinder:diameter=7.0", 7.1)):
        profile = np.tile(np.linspace(1.0, 0.4, 20), (n, 1)) if key == "col" else np.full((n, 20), np.nan)
        parts.append(ds.assign_coords(container=("packing", np.full(n, key)),
                                      container_spec=("packing", np.full(n, spec)),
                                      container_shape=("packing", np.full(n, spec.partition(":")[0])),
                                      wall_distance=("wall_distance", (np.arange(20) + 0.5) * 0.05))
                     .assign(container_size=("packing", np.full(n, size)),
                             profile_porosity=(("packing", "wall_distance"), profile)))
    return xr.concat(parts, dim="packing")


def test_tables_per_container_and_the_container_figures(tmp_path):
    from spherejam.workflow import figures
    from spherejam.workflow.tables import compute_tables

    ds = _two_containers()
    t = compute_tables(ds)
    t4 = t["table4"]
    assert t4.container.tolist() == ["bulk", "bulk", "col", "col"]
    bulk = t4[t4.container == "bulk"].set_index("sigma")
    col = t4[t4.container == "col"].set_index("sigma")
    # each container's rows from its own packings: the cylinder's phi_J are 0.02 lower, so are its band edges
    assert col.loc[0.3, "phi_RCP"] == pytest.approx(bulk.loc[0.3, "phi_RCP"] - 0.02, abs=1e-12)
    assert np.isfinite(bulk.loc[0.0, "phi_RCP_paper"]) and np.isnan(col.loc[0.0, "phi_RCP_paper"])
    assert bulk.loc[0.0, "phi_GCP"] == 0.65 and np.isnan(col.loc[0.0, "phi_GCP"])  # 0.65 is the bulk's
    # the paper's figures show the bulk alone; the container figures draw
    only_bulk = figures.reference_packings(ds)
    assert set(only_bulk.container.values.tolist()) == {"bulk"}
    for name in ("containers", "profiles", "fig2"):
        out = figures.save_figure(figures.draw(name, ds), tmp_path / name)
        assert all(p.stat().st_size > 10_000 for p in out)
