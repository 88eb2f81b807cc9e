"""Size distributions as the experiment's axis: keys, seeds, file inputs, config errors, old datasets, tables."""

import json
from types import SimpleNamespace

import numpy as np
import pytest
import xarray as xr

from spherejam import InputError
from spherejam.analysis.psd_models import predictions
from spherejam.cli.rcp import named_specs, print_summary
from spherejam.workflow.config import check_config
from spherejam.workflow.dataset import with_distributions
from spherejam.workflow.experiment import Experiment, Run
from spherejam.workflow.tables import compute_tables, formatted


def _config(**extra):
    cfg = {"n": 50, "seed": 3, "sigmas": [0.0, 0.1], "ls": {"rates": [1.0]}, "fb": {"rates": [0.01]}}
    cfg.update(extra)
    return cfg


def test_named_distributions_join_the_axis_and_shorthand_keeps_its_keys_and_seeds(tmp_path):
    table = tmp_path / "p.csv"
    table.write_text("size,volume\n1,0.5\n2,0.5\n")
    old = Experiment(_config())
    exp = Experiment(_config(distributions={"gauss": "gaussian:delta=0.2", "powder": f"table:{table}"}))
    assert [d.key for d in exp.distributions] == ["sigma0", "sigma0.1", "gauss", "powder"]
    keys = {r.key for r in exp.runs()}
    assert {r.key for r in old.runs()} <= keys and "ls/gauss/rate1/r0" in keys and "fb/powder/rate0.01/r0" in keys
    for r in old.runs():  # the sigmas runs' seeds are those of an experiment without named distributions
        assert Run(r.protocol, r.dist, r.rate, r.replica).seed(3) == r.seed(3)
    seeds = {r.seed(3) for r in exp.runs()}
    assert len(seeds) == len(exp.runs())
    w = SimpleNamespace(protocol="fb", dist="powder", rate="0.01", replica="0")
    assert exp.psd(w) == f"table:{table}" and exp.psd_files(w) == [str(table)]
    assert exp.psd_files(SimpleNamespace(protocol="ls", dist="sigma0.1", rate="1", replica="0")) == []
    assert exp.psd(SimpleNamespace(dist="sigma0.1")) == "lognormal:sigma=0.1"
    assert np.isnan(Run("ls", "gauss", 1.0, 0).sigma) and Run("ls", 0.1, 1.0, 0).sigma == 0.1


@pytest.mark.parametrize("distributions, message", [
    ({"sigma0.2": "gaussian:delta=0.1"}, "distributions.sigma0.2: a name is a letter"),
    ({"2x": "gaussian:delta=0.1"}, "distributions.2x"),
    ({"g": "gaussian:delta=-1"}, "distributions.g='gaussian:delta=-1': gaussian.delta=-1.0"),
    ({"g": "tabel:x.csv"}, "unknown family 'tabel'"),
    ({"g": 0.2}, "distributions.g=0.2: must be a spec string"),
])
def test_bad_distribution_in_config_is_one_line(distributions, message):
    with pytest.raises(InputError) as err:
        check_config(_config(distributions=distributions))
    assert message in str(err.value) and "\n" not in str(err.value)


def test_list_length_must_match_n(tmp_path):
    lst = tmp_path / "d.txt"
    lst.write_text("1\n2\n3\n")
    with pytest.raises(InputError, match=r"distributions.mine=.* holds 3 diameters, n = 50"):
        Experiment(_config(distributions={"mine": f"list:{lst}"}))


def test_distributions_alone_suffice_and_none_is_an_error():
    cfg = _config(distributions={"g": "gaussian:delta=0.1"})
    del cfg["sigmas"]
    assert [d.key for d in Experiment(check_config(cfg)).distributions] == ["g"]
    cfg = _config()
    del cfg["sigmas"]
    with pytest.raises(InputError, match="sigmas"):
        check_config(cfg)


def _dataset(named: bool):
    """A synthetic dataset: sigma 0 and, if ``named``, a Gaussian named 'gauss'; phi_J spread in known bands."""
    rng = np.random.default_rng(0)
    rows = []
    groups = [("sigma0", 0.0, "lognormal:sigma=0", 0.0, 0.640)]
    if named:
        groups.append(("gauss", np.nan, "gaussian:delta=0.2", 0.2, 0.650))
    for key, sigma, spec, delta, base in groups:
        for protocol, rates in (("ls", [2.0, 1.0, 0.5, 0.3, 0.21, 0.25]), ("fb", [0.005, 0.003, 0.002, 0.0015,
                                                                               0.0012, 0.004])):
            for g in rates:
                rows.append((protocol, sigma, g, key, spec, delta, base + 0.004 * rng.random()))
    p, s, g, k, spec, d, phi = map(np.array, zip(*rows))
    config = {"n": 100, "sigmas": [0.0], **({"distributions": {"gauss": "gaussian:delta=0.2"}} if named else {})}
    coords = {"protocol": ("packing", p), "sigma": ("packing", s.astype(float)), "rate": ("packing", g),
              "inverse_rate": ("packing", 1 / g), "replica": ("packing", np.zeros(len(g), int))}
    if named:
        coords.update(distribution=("packing", k), psd=("packing", spec), psd_delta=("packing", d.astype(float)))
    return xr.Dataset({"phi": ("packing", phi - 0.01), "phi_J": ("packing", phi)}, coords=coords,
                      attrs={"config": json.dumps(config)})


def test_old_dataset_gets_distribution_coordinates():
    ds = with_distributions(_dataset(named=False))
    assert set(ds.distribution.values) == {"sigma0"} and set(ds.psd.values) == {"lognormal:sigma=0"}
    assert np.all(ds.psd_delta.values == 0) and np.all(ds.psd_z.values == 1)


def test_tables_per_distribution_with_models():
    old = compute_tables(_dataset(named=False))["table4"]
    assert "distribution" not in old.columns and list(old.sigma) == [0.0]
    t = compute_tables(_dataset(named=True))
    t3, t4 = t["table3"], t["table4"]
    assert list(t4.distribution) == ["sigma0", "gauss"] and list(t3.distribution) == ["sigma0", "gauss"]
    gauss = t4.set_index("distribution").loc["gauss"]
    assert np.isnan(gauss.phi_RCP_paper) and np.isfinite(t4.set_index("distribution").loc["sigma0", "phi_RCP_paper"])
    assert gauss.phi_GCP != 0.65  # not monodisperse: no conventional value (and no slow runs: not estimable)
    mono_rcp = t4.set_index("distribution").loc["sigma0", "phi_RCP"]
    assert gauss.santos_phi_mono == pytest.approx(mono_rcp)  # Santos' input is our own monodisperse phi_RCP
    expected = {p.model: p.phi for p in predictions("gaussian:delta=0.2", mono_rcp)}
    for model, value in expected.items():
        assert gauss[f"model_{model}"] == pytest.approx(value)
        assert gauss[f"phi_RCP_minus_{model}"] == pytest.approx(gauss.phi_RCP - value)
    assert list(formatted("table4", t4).index.unique()) == ["sigma0", "gauss"]
    # the sigma-0 rows equal those of the dataset without the named distribution (same packings, same numbers)
    cols = [c for c in old.columns if not c.startswith(("model_", "phi_RCP_minus_", "santos"))]
    np.testing.assert_array_equal(old[cols].iloc[0].values.astype(str),
                                  t4[cols].iloc[0].values.astype(str))


def test_named_specs():
    assert named_specs(["g=gaussian:delta=0.1", "table:examples/powder.csv", "uniform:ratio=2"]) == {
        "g": "gaussian:delta=0.1", "powder": "table:examples/powder.csv", "uniform-ratio-2": "uniform:ratio=2"}
    with pytest.raises(InputError, match="given twice"):
        named_specs(["a=uniform:ratio=2", "a=uniform:ratio=3"])


def test_rcp_summary_prints_intervals_or_not_estimable(tmp_path, capsys):
    t = compute_tables(_dataset(named=True))
    t["table4"].to_csv(tmp_path / "t4.csv", index=False)
    t["table3"].to_csv(tmp_path / "t3.csv", index=False)
    print_summary(tmp_path / "t4.csv", tmp_path / "t3.csv")
    out = capsys.readouterr().out
    assert "gauss (gaussian:delta=0.2)" in out and "Desmond–Weeks" in out
    assert "CI not estimable (n = 6 LS + 6 FB fast packings)" in out  # quantile CIs need n >= 72


def test_rcp_reports_each_failed_jobs_error(tmp_path):
    from spherejam.cli.rcp import failed_jobs

    job_log = tmp_path / "r0.log"
    job_log.write_text("progress...\nspherejam ls: error: box L=6.2 is too small for the largest sphere (diameter "
                       "2.53): the minimum image convention needs L > ~2.5 diameters (too few spheres?)\n")
    log = tmp_path / "snakemake.log"
    log.write_text(f"1 of 9 steps (11%) done\nError in rule ls:\n    jobid: 7\n    log: {job_log} (check log file(s) "
                   "for error details)\n    shell:\n        spherejam ls ...\n")
    (line,) = failed_jobs(log)
    assert line.startswith(str(job_log)) and "needs L > ~2.5 diameters" in line


def test_psd_file_is_an_input_of_the_jobs_that_read_it(tmp_path):
    """A table: file named in a config is an input of the seeding, dataset, table and figure jobs (dry run)."""
    import subprocess
    import sys
    from pathlib import Path

    import yaml

    root = Path(__file__).resolve().parents[2]
    powder = tmp_path / "powder.csv"
    powder.write_text("size,volume\n1,0.5\n1.3,0.5\n")
    config = yaml.safe_load((root / "config" / "psd.yaml").read_text())
    config.update(results=str(tmp_path / "res"), n=20, replicas=1, distributions={"powder": f"table:{powder}"})
    (tmp_path / "c.yaml").write_text(yaml.safe_dump(config))
    target = tmp_path / "res" / "figures" / "fig5.png"
    r = subprocess.run([sys.executable, "-m", "snakemake", str(target), str(tmp_path / "res" / "tables" / "table4.csv"),
                        "-n", "--cores", "1", "--configfile",
                        str(tmp_path / "c.yaml")], cwd=root, capture_output=True, text=True, timeout=600)
    assert r.returncode == 0, r.stdout + r.stderr
    import re

    jobs = re.split(r"\n\s*(?:local)?rule ", r.stdout + r.stderr)
    for rule in ("seed", "dataset", "tables", "figure"):
        blocks = [b for b in jobs if b.startswith(f"{rule}:")]
        assert blocks and all(str(powder) in b.split("output:")[0] for b in blocks), rule
    assert Experiment(config).psd_inputs() == [str(powder)]


def test_forces_and_gaps_are_pooled_per_distribution_named_ones_too(monkeypatch, tmp_path):
    """Each distribution (a ``sigmas`` key or a named one) pools the contacts of its own CALiPPSO packings only, and
    the force figure draws every one of them; a dataset pooled per sigma (before) reads with today's dimension."""
    import spherejam.core.packing_io as packing_io
    from spherejam.workflow.dataset import POOLED, collect_distributions, pooled_by_distribution
    from spherejam.workflow.figures import draw

    exp = Experiment(_config(results=str(tmp_path), distributions={"gauss": "gaussian:delta=0.2"}))
    per_packing = {"sigma0": 4, "sigma0.1": 6, "gauss": 10}  # contacts per packing, different per distribution
    rng = np.random.default_rng(0)

    def contacts(path, group):
        assert group == "contacts"
        dist = next(k for k in per_packing if f"/{k}/" in str(path))
        m = per_packing[dist]
        return {"forces": rng.exponential(size=m), "extended": np.ones(m), "gaps": rng.uniform(1e-6, 1e-2, m)}

    monkeypatch.setattr(packing_io, "read_group", contacts)
    out = collect_distributions(exp)
    coords = out.pop("_coords")
    assert list(coords[POOLED][1]) == ["sigma0", "sigma0.1", "gauss"]
    sigma = coords["dist_sigma"][1]
    assert list(sigma[:2]) == [0.0, 0.1] and np.isnan(sigma[2])
    runs_per_dist = len(exp.runs()) // 3
    assert list(out["n_forces"][1]) == [runs_per_dist * m for m in per_packing.values()]
    assert list(out["n_gaps"][1]) == list(out["n_forces"][1])
    assert list(out["n_packings"][1]) == [runs_per_dist] * 3
    # calippso.per_cell: 1 pools the one certified packing of each cell, and says so (n_packings)
    one = Experiment(_config(results=str(tmp_path), distributions={"gauss": "gaussian:delta=0.2"},
                             calippso={"enabled": True, "per_cell": 1}))
    sampled = collect_distributions(one)
    assert list(sampled["n_packings"][1]) == [1, 1, 1]
    assert list(sampled["n_forces"][1]) == list(per_packing.values())
    assert out["force_pdf"][1].shape == (3, 40) and np.all(out["gap_pdf"][1].sum(axis=1) > 0)

    ds = xr.Dataset({k: v for k, v in out.items()}, coords=coords)
    fig = draw("forces", ds)
    labels = [t.get_text() for t in fig.axes[0].get_legend().get_texts()]
    assert [t.split(":")[0] for t in labels[:4]] == ["σ = 0", "all contacts", "σ = 0.1", "gauss"]
    assert labels[3].startswith("gauss: θ_e = ")
    old = ds.drop_vars(POOLED).swap_dims({POOLED: "dist_sigma"}).isel(dist_sigma=[0, 1])
    assert "dist_sigma" in old.dims
    new = pooled_by_distribution(old)
    assert list(new[POOLED].values) == ["sigma0", "sigma0.1"]
    np.testing.assert_array_equal(new.force_pdf.values, ds.force_pdf.values[:2])
