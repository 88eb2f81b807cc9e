"""N as an axis of the experiment: a ladder of N in the design (paths, seeds, rates per N), the cost per N, the
dataset's coordinate n, tables per N with rows extrapolated to N = 10^4 and N -> infinity, and a two-N run end to
end."""

import json
import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
import xarray as xr
import yaml

from spherejam.core.errors import InputError
from spherejam.workflow import cost_model
from spherejam.workflow.config import check_config
from spherejam.workflow.experiment import Experiment, Run
from spherejam.workflow.fits import design_matrix
from spherejam.workflow.tables import compute_tables, write_tables

ROOT = Path(__file__).resolve().parents[2]


def _tiny(**changes) -> dict:
    cfg = yaml.safe_load((ROOT / "config" / "tiny.yaml").read_text())
    cfg.update(changes)
    return cfg


# --- the design -----------------------------------------------------------------------------------------------------

def test_a_single_n_keeps_the_paths_and_seeds_of_before():
    """n: 80 gives the run keys and seeds of spherejam 0.1 (no N in either), so old results stay valid."""
    exp = Experiment(_tiny())
    run = exp.runs("ls")[0]
    assert run.n is None and run.key == "ls/sigma0/rate2/r0" and exp.size(run) == 80
    # the seed of spherejam 0.1: master seed, protocol, sigma, rate, replica, purpose
    assert run.seed(7) == Run("ls", "sigma0", 2.0, 0).seed(7)
    assert exp.paths.packing("poisson") == "results-tiny/packings/{protocol}/{dist}/rate{rate}/r{replica}/poisson.h5"


def test_a_ladder_puts_each_n_in_paths_and_seeds():
    exp = Experiment(_tiny(n=[80, 40]))
    assert exp.sizes == [40, 80] and exp.n_ladder and exp.largest_n == 80
    runs = exp.runs()
    assert len(runs) == 2 * len(Experiment(_tiny()).runs())
    keys = {r.key for r in runs}
    assert "n40/ls/sigma0/rate2/r0" in keys and "n80/ls/sigma0/rate2/r0" in keys
    a, b = (Run("ls", "sigma0", 2.0, 0, n) for n in (40, 80))
    assert len({a.seed(7), b.seed(7), Run("ls", "sigma0", 2.0, 0).seed(7)}) == 3  # independent starts
    assert exp.paths.packing("poisson").startswith("results-tiny/packings/n{n}/{protocol}/")
    # the validation grid re-jams packings at the largest N only; Fig. 1 shows one of them
    assert {g.source.n for g in exp.grid_runs()} == {80} and exp.figure1_run().n == 80
    assert "scaling" in exp.figure_names and "scaling" not in Experiment(_tiny()).figure_names
    one = Experiment(_tiny(n=[80]))  # a ladder of one N: the ladder's paths and seeds, nothing to scale
    assert one.n_ladder and not one.several_n and "scaling" not in one.figure_names
    assert one.runs()[0].key.startswith("n80/")


def test_extra_rates_can_be_limited_to_some_n():
    cfg = _tiny(n=[40, 80])
    cfg["ls"]["extra_rates"] = [{"sigmas": [0.1], "rates": [1e-3, 3e-4], "n": [80]}]
    exp = Experiment(cfg)
    assert len(exp.rates_for("ls", 0.1, 80)) == 7 and len(exp.rates_for("ls", 0.1, 40)) == 5
    assert len(exp.runs("ls", 80)) == len(exp.runs("ls", 40)) + 2
    cfg["ls"]["extra_rates"][0]["n"] = [60]
    with pytest.raises(InputError, match=r"^ls\.extra_rates\[0\]\.n\[0\]=60: not one of n \[40, 80\]$"):
        Experiment(cfg)


@pytest.mark.parametrize("n, needle", [
    ([], r"^n=\[\]: give at least one N$"),
    ([40, 1], r"^n\[1\]=1: must be an integer >= 2"),
    ([40, 40], r"^n=\[40, 40\]: an N appears twice$"),
    ([40, 2.5], r"^n\[1\]=2.5: must be an integer"),
])
def test_a_bad_ladder_is_one_line_naming_the_element(n, needle):
    with pytest.raises(InputError, match=needle):
        Experiment(check_config(_tiny(n=n)))


def test_cost_is_priced_per_n(capsys):
    from spherejam.cli import main

    cfg = _tiny(n=[40, 80])
    plan = cost_model.plan(cfg)
    assert list(plan) == [40, 80]
    assert plan[40]["mls"]["jobs"] == plan[80]["mls"]["jobs"] == len(Experiment(cfg).runs(n=40))
    assert plan[80]["mls"]["cpu_hours"] > plan[40]["mls"]["cpu_hours"]
    path = ROOT / "config" / "reproduction.yaml"
    assert main(["cost", str(path)]) == 0
    out = capsys.readouterr().out
    assert "N = 250" in out and "N = 500" in out and "N = 1000" in out and "all N" in out


# --- tables of a ladder ---------------------------------------------------------------------------------------------

GCP = {0.0: 0.65, 0.3: 0.678}
COEF = np.array([0.0, -0.05, 0.3, -1.2])
MU_INF = {0.0: 0.640, 0.3: 0.665}


def ladder_dataset(sizes=(250, 500, 1000), fast=16, seed=1, jump=0.0) -> xr.Dataset:
    """Packings at several N with known answers: slow curves (Table 2) whose phi_GCP shifts as -0.01 N^-1/2, and
    fast phi_J drawn from a normal of mean MU_INF - 0.06 N^-1/2 and width 0.08 N^-1/2 (plus ``jump`` at the largest
    N)."""
    rng = np.random.default_rng(seed)
    cols = {k: [] for k in ("n", "protocol", "sigma", "rate", "phi", "phi_J")}

    def add(*values):
        for k, v in zip(cols, values):
            cols[k].append(v)

    for n in sizes:
        for p, slow, fast_rates in (("ls", np.geomspace(1e-4, 0.03, 14), np.geomspace(0.21, 10, fast)),
                                    ("fb", np.geomspace(1e-7, 4e-4, 12), np.geomspace(1.05e-3, 5e-3, fast))):
            for s in (0.0, 0.3):
                for g in slow:
                    curve = GCP[s] + design_matrix(np.array([g]))[0] @ COEF - 0.01 * n**-0.5
                    add(n, p, s, g, curve - 0.002, curve)
                shift = jump if n == max(sizes) else 0.0
                for g, x in zip(fast_rates, rng.normal(MU_INF[s] - 0.06 * n**-0.5 + shift, 0.08 * n**-0.5, fast)):
                    add(n, p, s, g, x - 0.05, x)
    config = {"n": list(sizes), "sigmas": [0.0, 0.3], "fits": {"ls_initial": 14, "ls_densified": 9, "fb_initial": 12,
              "fb_densified": 12, "max_half_width": 0.01}, "bands": {"method": "minmax"},
              "fast": {"ls_max_inverse_rate": 5, "fb_max_inverse_rate": 1000}}
    rate = np.array(cols["rate"])
    m = len(rate)
    return xr.Dataset(
        {"phi": ("packing", np.array(cols["phi"])), "phi_J": ("packing", np.array(cols["phi_J"])),
         "z_nonrattler": ("packing", np.full(m, 6.0))},
        coords={"n": ("packing", np.array(cols["n"])), "protocol": ("packing", np.array(cols["protocol"])),
                "sigma": ("packing", np.array(cols["sigma"])), "rate": ("packing", rate),
                "inverse_rate": ("packing", 1 / rate), "replica": ("packing", np.zeros(m, int))},
        attrs={"config": json.dumps(config)})


@pytest.fixture(scope="module")
def ladder_tables():
    return compute_tables(ladder_dataset())


def test_ladder_tables_have_rows_per_n_and_extrapolated(ladder_tables):
    t3, t4 = ladder_tables["table3"], ladder_tables["table4"]
    assert sorted(set(t3.n)) == [250, 500, 1000, 10000, math.inf]
    assert list(t3.extrapolated) == [False] * 6 + [True] * 4
    # each measured row is that N's own Table 3: the sample extremes of its 16 fast packings
    ds = ladder_dataset()
    at = (ds.n.values == 500) & (ds.protocol.values == "ls") & (ds.sigma.values == 0.3) & (ds.inverse_rate.values < 5)
    row = t3[(t3.n == 500) & (t3.sigma == 0.3)].iloc[0]
    assert row.ls_phi_max_fast == ds.phi_J.values[at].max() and row.ls_n_fast == 16
    # at N -> infinity the band closes on mu_inf, which the data were drawn with (within the bootstrap interval)
    for s in (0.0, 0.3):
        limit = t4[(t4.n == math.inf) & (t4.sigma == s)].iloc[0]
        assert limit.phi_LT == pytest.approx(limit.phi_RCP)
        assert abs(limit.phi_RCP - MU_INF[s]) < 2 * limit.phi_RCP_half_width
        paper_n = t3[(t3.n == 10000) & (t3.sigma == s)].iloc[0]
        assert paper_n.ls_n_fast == 85 and paper_n.fb_n_fast == 165  # the paper's sample sizes
        mu_inf = t3[(t3.n == math.inf) & (t3.sigma == s)].iloc[0]
        assert mu_inf.ls_phi_min_fast == mu_inf.ls_phi_max_fast  # the width vanishes
        assert paper_n.ls_phi_min_fast < mu_inf.ls_phi_min_fast and paper_n.ls_phi_min_fast < paper_n.ls_phi_max_fast
    # phi_GCP(N) = phi_GCP(inf) - 0.01 N^-1/2 exactly in the data: the extrapolation recovers it
    t2 = ladder_tables["table2"]
    gcp = t2[(t2.n == math.inf) & (t2.curve == "LS, densified")].iloc[0]
    assert gcp.phi_gcp == pytest.approx(GCP[0.3], abs=1e-6) and gcp.extrapolated


def test_a_single_n_has_the_tables_of_before():
    ds = ladder_dataset(sizes=(1000,))
    tables = compute_tables(ds)
    assert all("n" not in t.columns for t in tables.values())


def test_ladder_tables_and_finite_size_check_are_written(tmp_path):
    paths = write_tables(ladder_dataset(), tmp_path)
    assert (tmp_path / "finite_size.md") in paths
    text = (tmp_path / "table4.md").read_text()
    assert "| 0.3 | 10000 (extrapolated) | φ_RCP |" in text and "∞ (extrapolated)" in text
    check = pd.read_csv(tmp_path / "finite_size.csv")
    assert len(check) == 2 * 2 * 2 and (check.held_out_n == 1000).all()
    assert check.within.all()  # data of the model's own form: the held-out edge is inside its prediction interval


def test_the_held_out_check_fails_when_the_largest_n_breaks_the_scaling(tmp_path):
    write_tables(ladder_dataset(jump=0.02), tmp_path)
    check = pd.read_csv(tmp_path / "finite_size.csv")
    assert not check.within.any() and (check.error < -0.01).all()


def test_an_old_dataset_without_n_gets_it_on_reading(tmp_path):
    from spherejam.workflow.dataset import open_dataset, sizes_in

    ds = ladder_dataset(sizes=(1000,)).drop_vars("n")
    ds.attrs["n"] = 1000
    path = tmp_path / "old.nc"
    ds.to_netcdf(path, engine="h5netcdf")
    again = open_dataset(path)
    assert (again.n.values == 1000).all() and sizes_in(again) == [1000]


# --- a two-N run, end to end ----------------------------------------------------------------------------------------

def test_a_two_n_tiny_run_end_to_end(tmp_path):
    """A ladder of N = 40 and 80 through every rule: packings per N, the dataset's n, tables per N with extrapolated
    rows, and the finite-size scaling figure."""
    from spherejam.core.packing_io import read_packing
    from spherejam.workflow.dataset import open_dataset

    cfg = _tiny(n=[40, 80], sigmas=[0.0], results=str(tmp_path / "results"))
    cfg["ls"]["rates"] = [2.0, 1.0, 0.5]
    cfg["fb"]["rates"] = [0.01, 0.005, 0.003]
    cfg["validation_grid"] = {"enabled": False}
    cfg["bands"]["min_packings"] = 3
    (tmp_path / "c.yaml").write_text(yaml.safe_dump(cfg))
    r = subprocess.run([sys.executable, "-m", "snakemake", "--cores", "2", "--configfile", str(tmp_path / "c.yaml")],
                       cwd=ROOT, capture_output=True, text=True, timeout=1500)
    assert r.returncode == 0, r.stderr[-5000:]
    results = tmp_path / "results"
    ds = open_dataset(results / "dataset.nc")
    assert sorted(ds.n.values.tolist()) == [40] * 6 + [80] * 6
    for key, n in zip(ds.key.values, ds.n.values):
        assert str(key).startswith(f"n{n}/")
        assert read_packing(results / "packings" / str(key) / "jammed.h5").n == n
    assert len(set(ds.seed.values.tolist())) == 12
    t4 = pd.read_csv(results / "tables" / "table4.csv")
    assert [str(x) for x in t4.n] == ["40.0", "80.0", "10000.0", "inf"]
    assert np.isfinite(t4.phi_RCP).all()
    assert "(extrapolated)" in (results / "tables" / "table3.md").read_text()
    assert (results / "tables" / "finite_size.md").is_file()
    for ext in ("png", "pdf"):
        assert (results / "figures" / f"scaling.{ext}").stat().st_size > 1000
    _check_a_run_in_parts_merges_to_the_whole(tmp_path / "c.yaml", results, ds)


def _check_a_run_in_parts_merges_to_the_whole(configfile, results, whole):
    """The same run in parts: each N's dataset from its own Snakemake target, merged by `spherejam merge`, is the
    dataset of the run made in one go (values, coordinates, order), and its tables are the same."""
    from spherejam.cli import main
    from spherejam.workflow.dataset import open_dataset

    parts = [results / "parts" / f"n{n}" / "sigma0" / "dataset.nc" for n in (40, 80)]
    r = subprocess.run([sys.executable, "-m", "snakemake", *map(str, parts), "--cores", "2", "--configfile",
                        str(configfile)], cwd=ROOT, capture_output=True, text=True, timeout=600)
    assert r.returncode == 0, r.stderr[-5000:]
    assert "rule mls" not in r.stdout + r.stderr  # the packings are made already: only the parts' datasets run
    assert open_dataset(parts[0]).n.values.tolist() == [40] * 6
    merged = results.parent / "merged"
    assert main(["merge", str(parts[1]), str(parts[0]), "-o", str(merged / "dataset.nc")]) == 0
    again = open_dataset(merged / "dataset.nc")
    xr.testing.assert_equal(again, whole)
    assert again.attrs["config_hash"] == whole.attrs["config_hash"] and "merged" in again.attrs["history"]
    assert main(["tables", str(merged / "dataset.nc"), "--outdir", str(merged / "tables")]) == 0
    for name in ("table2", "table3", "table4", "finite_size"):
        assert (merged / "tables" / f"{name}.md").read_text() == (results / "tables" / f"{name}.md").read_text()
    assert main(["merge", str(parts[0]), "-o", str(merged / "half.nc")]) == 2  # N = 80 is in no part
    assert main(["merge", str(parts[0]), str(parts[0]), "-o", str(merged / "twice.nc")]) == 2


def test_a_merged_dataset_keeps_every_string_whole(tmp_path):
    """Parts of a ladder hold strings of different lengths ("sigma0" and "sigma0.3"). A dataset read from a file
    remembers each string's width there, and a concatenation keeps the first part's: the merged dataset must still
    be written with every string whole (it once came out "sigma0" for every packing, and keys cut short)."""
    from spherejam.workflow.dataset import write_dataset

    def part(dist, key):
        path = tmp_path / f"{dist}.nc"
        write_dataset(xr.Dataset({"phi_J": ("packing", [0.64, 0.66])},
                                 coords={"distribution": ("packing", [dist] * 2), "key": ("packing", [key] * 2)}),
                      path)
        return xr.load_dataset(path, engine="h5netcdf")

    parts = [part("sigma0", "n1000/ls/sigma0/rate2/r0"), part("sigma0.3", "n250/fb/sigma0.3/rate0.000155565/r0")]
    merged = xr.concat(parts, dim="packing", data_vars="minimal", coords="minimal")
    write_dataset(merged, tmp_path / "merged.nc")
    again = xr.load_dataset(tmp_path / "merged.nc", engine="h5netcdf")
    assert again.distribution.values.tolist() == ["sigma0"] * 2 + ["sigma0.3"] * 2
    assert again.key.values.tolist()[-1] == "n250/fb/sigma0.3/rate0.000155565/r0"


def test_browse_selects_one_n(tmp_path, capsys):
    from spherejam.cli import main

    path = tmp_path / "ladder.nc"
    ladder_dataset().to_netcdf(path, engine="h5netcdf")
    assert main(["browse", str(path), "--n", "500", "--csv", str(tmp_path / "sel.csv")]) == 0
    sel = pd.read_csv(tmp_path / "sel.csv")
    assert len(sel) == (14 + 12 + 2 * 16) * 2 and (sel.n == 500).all()
    assert main(["browse", str(path), "--n", "300"]) == 2
    assert capsys.readouterr().err.strip().endswith("--n=300: not in this dataset (have N = 250, 500, 1000)")
