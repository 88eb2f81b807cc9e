"""The Snakemake workflow: dry runs of every config, schema errors, and a tiny end-to-end run."""

import re
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import yaml

from spherejam.workflow.cost_model import load_configs
from spherejam.workflow.experiment import Experiment

ROOT = Path(__file__).resolve().parents[2]
SNAKEMAKE = [sys.executable, "-m", "snakemake"]


def snakemake(*args, cwd=ROOT, timeout=1200):
    return subprocess.run([*SNAKEMAKE, *args], cwd=cwd, capture_output=True, text=True, timeout=timeout)


@pytest.mark.parametrize("config", ["config.yaml", "tiny.yaml", "paper.yaml", "reproduction.yaml"])
def test_dry_run(config, tmp_path):
    cfg = yaml.safe_load((ROOT / "config" / config).read_text())
    cfg["results"] = str(tmp_path / "results")
    (tmp_path / "c.yaml").write_text(yaml.safe_dump(cfg))
    targets = []
    if config == "paper.yaml":
        # Its whole DAG (26 550 jobs) takes Snakemake 1.5-2.5 min to build; the rules are the same as the other
        # configs' and Experiment checks its paths. One LS, one FB and one grid run's MLS job carry its settings.
        exp = Experiment(cfg)
        targets = [exp.paths.packing("jammed", next(iter(exp.runs(p))).key) for p in ("ls", "fb")]
        targets.append(str(exp.grid_path(exp.grid_runs()[0])))
    r = snakemake(*targets, "-n", "-p", "--cores", "2", "--configfile", str(tmp_path / "c.yaml"))
    assert r.returncode == 0, r.stderr[-3000:]
    # every MLS job gets the MLS settings of its own config (the paper's must not inherit the default's cut)
    mls_jobs = [line for line in r.stdout.splitlines() if "spherejam mls " in line]
    assert mls_jobs
    mls = load_configs(ROOT / "config" / config)["mls"]  # a --configfile is the whole config
    cut = mls.get("max_collisions_per_particle")
    assert all(f"--stall-windows {mls['stall_windows']}" in job for job in mls_jobs)
    if cut is None:
        assert not any("--max-collisions-per-particle" in job for job in mls_jobs)
    else:
        assert all(f"--max-collisions-per-particle {float(cut)}" in job for job in mls_jobs)
    if config == "paper.yaml":
        assert cut is None


@pytest.mark.parametrize(
    "change, needle",
    [
        ({"n": 1}, "n"),
        ({"sigmas": [-0.1]}, "sigmas"),
        ({"unknown_key": 3}, "unknown_key"),
        ({"ls": {"rates": [0.0]}}, "rates"),
        ({"mls": {"decrease_factor": 1.0}}, "decrease_factor"),
        ({"mls": {"max_collisions_per_particle": 0}}, "max_collisions_per_particle"),
        ({"mls": {"stall_windows": 0}}, "stall_windows"),
        ({"ls": {"rates": [0.5, float("nan")], "p_max": 1e12}}, "config: ls.rates[1]=nan"),
        ({"fb": {"rates": [1.5], "phi_nominal": None}}, "config: fb.rates[0]=1.5"),
        ({"bands": {"method": "median"}}, "method"),
        # the grid re-jams packings of the experiment: a rate outside ls.rates is an error naming it
        ({"validation_grid": {"enabled": True, "sigmas": [0.0], "ls_rates": [0.3], "decrease_factors": [2],
                              "initial_rates": [10], "final_rates": [1.0e-2]}}, "ls_rates=0.3"),
    ],
)
def test_bad_config_stops_before_any_job(change, needle, tmp_path):
    cfg = yaml.safe_load((ROOT / "config" / "tiny.yaml").read_text())
    cfg["results"] = str(tmp_path / "results")
    cfg.update(change)
    (tmp_path / "bad.yaml").write_text(yaml.safe_dump(cfg))
    r = snakemake("-n", "--cores", "1", "--configfile", str(tmp_path / "bad.yaml"))
    assert r.returncode != 0
    assert needle in r.stdout + r.stderr
    assert not (tmp_path / "results").exists()


def test_configfile_is_not_completed_from_the_default(tmp_path):
    """A --configfile without `n` stops the run; it does not silently take N = 200 from config/config.yaml."""
    cfg = yaml.safe_load((ROOT / "config" / "tiny.yaml").read_text())
    cfg["results"] = str(tmp_path / "results")
    del cfg["n"]
    (tmp_path / "partial.yaml").write_text(yaml.safe_dump(cfg))
    r = snakemake("-n", "--cores", "1", "--configfile", str(tmp_path / "partial.yaml"))
    assert r.returncode != 0
    assert "config: n: required key missing" in r.stdout + r.stderr
    assert not (tmp_path / "results").exists()


def test_lint_is_clean():
    r = snakemake("--lint", "--cores", "1")
    assert r.returncode == 0, r.stdout[-3000:] + r.stderr[-3000:]


def test_pending_timers_are_cancelled():
    import threading

    from spherejam.workflow.run_hooks import cancel_pending_timers

    fired = []
    timer = threading.Timer(600, lambda: fired.append(1))
    timer.start()
    assert cancel_pending_timers() >= 1
    timer.join(5)
    assert not timer.is_alive() and not fired


def test_a_run_exits_when_its_jobs_are_done(tmp_path):
    """The local profile's 60 s job-rate timespan must not keep `snakemake` alive after its last job (run_hooks):
    one seed job, whose run Snakemake itself times at a few seconds, and the process must end soon after."""
    import time

    cfg = yaml.safe_load((ROOT / "config" / "tiny.yaml").read_text())
    cfg["results"] = str(tmp_path / "results")
    (tmp_path / "c.yaml").write_text(yaml.safe_dump(cfg))
    exp = Experiment(cfg)
    target = exp.paths.packing("poisson", next(iter(exp.runs("ls"))).key)
    t = time.monotonic()
    r = snakemake(target, "--cores", "1", "--configfile", str(tmp_path / "c.yaml"))
    wall = time.monotonic() - t
    assert r.returncode == 0, r.stderr[-3000:]
    h, m, s = re.search(r"Elapsed time: (\d+):(\d+):([\d.]+)", r.stderr).groups()
    inside = 3600 * int(h) + 60 * int(m) + float(s)
    assert wall - inside < 40, (wall, inside)  # start-up only; the timer kept it 60 s longer


@pytest.fixture(scope="module")
def tiny_run(tmp_path_factory):
    """Run config/tiny.yaml end to end once (about a minute on 2 cores)."""
    out = tmp_path_factory.mktemp("tiny")
    cfg = yaml.safe_load((ROOT / "config" / "tiny.yaml").read_text())
    cfg["results"] = str(out / "results")
    (out / "tiny.yaml").write_text(yaml.safe_dump(cfg))
    r = snakemake("--cores", "2", "--configfile", str(out / "tiny.yaml"), timeout=1500)
    assert r.returncode == 0, r.stderr[-5000:]
    return out / "results", out / "tiny.yaml"


def test_tiny_end_to_end(tiny_run):
    from spherejam.core.packing_io import read_packing
    from spherejam.workflow.dataset import dataset_config, open_dataset

    results, _ = tiny_run
    ds = open_dataset(results / "dataset.nc")
    cfg = dataset_config(ds)
    assert ds.sizes["packing"] == 2 * len(cfg["sigmas"]) * 5
    assert ds.sizes["grid_run"] == 2
    # every packing was jammed by MLS, at or above its initial density
    assert np.all(np.isfinite(ds.phi_J.values))
    assert np.all(ds.phi_J.values >= ds.phi.values - 1e-12)
    assert np.all(ds.pressure_J.values >= 1e11)
    assert np.all(ds.mls_completed.values == 1)  # no wall-time cap in tiny.yaml
    assert np.all((ds.phi_J.values > 0.55) & (ds.phi_J.values < 0.74))
    # provenance travels with the dataset
    for key in ("config", "config_hash", "git_commit", "package_versions", "created"):
        assert ds.attrs[key]
    assert ds.phi_J.attrs["units"] == "1" and ds.phi_J.attrs["long_name"]
    # CALiPPSO's "phi" describes calippso_phi only, not the generated packing's phi
    assert ds.phi.attrs["long_name"] == "packing fraction of the generated packing"
    assert ds.calippso_phi.attrs["long_name"].startswith("CALiPPSO:")
    # the files behind one entry are valid packings whose phi matches the dataset
    key = str(ds.key.values[0])
    jammed = read_packing(results / "packings" / key / "jammed.h5")
    assert jammed.phi == pytest.approx(float(ds.phi_J.values[0]), rel=1e-12)
    for name in ("table2", "table3", "table4"):
        for ext in ("csv", "md", "tex"):
            assert (results / "tables" / f"{name}.{ext}").stat().st_size > 0
    # sensible tables: every Table 2 cell is a number or says why not; Table 3 has both protocols' bands
    import pandas as pd

    t2 = pd.read_csv(results / "tables" / "table2.csv", keep_default_na=False)
    for value, status in zip(t2.phi_gcp, t2.status):
        assert status.startswith("not estimable (n = ") if value == "" else 0.6 < float(value) < 0.7
    t3 = pd.read_csv(results / "tables" / "table3.csv")
    assert (t3.ls_n_fast >= 1).all() and (t3.fb_n_fast >= 1).all()
    assert "Comparison with the paper" in (results / "tables" / "comparison.md").read_text()
    for name in ("fig2", "fig3", "fig4", "fig5", "fig6", "fig7", "structure", "forces"):
        for ext in ("png", "pdf"):
            assert (results / "figures" / f"{name}.{ext}").stat().st_size > 1000
    # no temporary or checkpoint files are left behind
    assert not list(results.rglob("*.tmp*"))


def test_dataset_reads_only_the_inputs_of_its_rule(tiny_run, monkeypatch):
    """Every file the dataset builder opens is an input of the dataset rule, so Snakemake rebuilds the dataset when
    any of them changes (CALiPPSO's packings with their contact forces among them)."""
    import json

    import h5py

    from spherejam.workflow.dataset import build_dataset

    results, _ = tiny_run
    manifest = results / "experiment.json"
    opened = set()
    h5_file, read_text = h5py.File, Path.read_text

    def spy_h5(name, *args, **kwargs):
        opened.add(str(name))
        return h5_file(name, *args, **kwargs)

    def spy_text(path, *args, **kwargs):
        opened.add(str(path))
        return read_text(path, *args, **kwargs)

    monkeypatch.setattr(h5py, "File", spy_h5)
    monkeypatch.setattr(Path, "read_text", spy_text)
    build_dataset(manifest)
    monkeypatch.undo()
    inputs = {str(manifest), *Experiment(json.loads(manifest.read_text())["config"]).dataset_inputs()}
    read = {f for f in opened if f.startswith(f"{results}/")}  # not the package metadata of the provenance
    assert read <= inputs, sorted(read - inputs)[:5]
    assert any(f.endswith("calippso.h5") for f in read) and any(f.endswith("structure.json") for f in read)


def test_single_figure_rebuild_does_not_rerun_simulations(tiny_run):
    results, cfg = tiny_run
    target = results / "figures" / "fig4.pdf"
    target.unlink()
    r = snakemake(str(target), "--cores", "2", "--dry-run", "--configfile", str(cfg))
    assert r.returncode == 0
    planned = r.stdout
    assert "rule figure:" in planned and not any(f"rule {r}:" in planned for r in ("seed", "ls", "fb", "mls"))
    r = snakemake(str(target), "--cores", "2", "--configfile", str(cfg))
    assert r.returncode == 0 and target.exists()


def test_browse_filters_and_exports(tiny_run, tmp_path):
    results, _ = tiny_run
    out = tmp_path / "sel.csv"
    r = subprocess.run(
        [sys.executable, "-m", "spherejam.cli", "browse", str(results / "dataset.nc"), "--protocol", "ls",
         "--sigma", "0.1", "--csv", str(out), "--figure", "fig5", "-o", str(tmp_path / "fig5")],
        capture_output=True, text=True,
    )
    assert r.returncode == 0, r.stderr
    import pandas as pd

    df = pd.read_csv(out)
    assert len(df) == 5 and set(df.protocol) == {"ls"} and set(df.sigma) == {0.1}
    assert (tmp_path / "fig5.png").exists()


def test_browse_one_packing(tiny_run, tmp_path, capsys):
    """browse --packing: the dataset's values and the files of one packing, its MLS history plot, and a dataset
    copied away from its results folder (what is there is listed, what is missing is said)."""
    from spherejam.cli import main
    from spherejam.workflow.dataset import open_dataset

    results, _ = tiny_run
    key = "ls/sigma0/rate0.5/r0"  # the validation grid's source packing
    ds = open_dataset(results / "dataset.nc")
    i = list(ds.key.values).index(key)
    assert main(["browse", str(results / "dataset.nc"), "--packing", key, "--plot", "-o", str(tmp_path / "mls")]) == 0
    out = capsys.readouterr().out
    assert "phi_J " in out and f"{float(ds.phi_J.values[i]):.10g}" in out
    assert "mls_collisions " in out and "closest jamming density (MLS)" in out
    assert out.count("validation-grid run") == 2
    for name in ("poisson.h5", "initial.h5", "jammed.h5", "structure.json", "calippso.json"):
        assert str(results / "packings" / key / name) in out
    assert str(results / "logs" / "mls" / f"{key}.log") in out and "missing" not in out
    assert (tmp_path / "mls.png").stat().st_size > 10000

    # archived elsewhere with one packing's folder, one file lost
    archive = tmp_path / "archive"
    shutil.copytree(results / "packings" / key, archive / "packings" / key)
    (archive / "packings" / key / "calippso.h5").unlink()
    shutil.copy(results / "dataset.nc", archive / "dataset.nc")
    assert main(["browse", str(archive / "dataset.nc"), "--packing", key]) == 0
    out = capsys.readouterr().out
    assert str(archive / "packings" / key / "jammed.h5") in out and "missing: calippso.h5" in out

    # the dataset alone, from a machine where its results folder does not exist
    moved = ds.copy()
    moved.attrs["config"] = moved.attrs["config"].replace(str(results), str(tmp_path / "gone"))
    moved.to_netcdf(tmp_path / "alone.nc", engine="h5netcdf")
    assert main(["browse", str(tmp_path / "alone.nc"), "--packing", key]) == 0
    out = capsys.readouterr().out
    assert "packing files: not found" in out and str(tmp_path / "gone" / "packings" / key) in out
    assert f"{float(ds.phi_J.values[i]):.10g}" in out  # the dataset's own values are all still there
    assert main(["browse", str(tmp_path / "alone.nc"), "--packing", key, "--plot"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "jammed.h5" in err[0]
    assert main(["browse", str(results / "dataset.nc"), "--packing", "ls/sigma9/rate1/r0"]) == 2
    assert "no such packing" in capsys.readouterr().err


def test_archive_of_a_run_is_browsable(tiny_run, tmp_path, capsys):
    """spherejam archive packs the dataset, tables, figures and chosen packings with a README; browse --tables,
    --packing and --figure work on the archive as on the run; a too-large archive is refused before writing."""
    from spherejam.cli import main
    from spherejam.core.packing_io import read_packing
    from spherejam.workflow.dataset import open_dataset

    results, _ = tiny_run
    archive = tmp_path / "archive"
    assert main(["archive", str(results), "-o", str(archive), "--packings", "ls/sigma0/*"]) == 0
    assert (archive / "tables" / "table4.md").is_file() and (archive / "figures" / "fig5.png").is_file()
    readme = (archive / "README.md").read_text()
    ds = open_dataset(archive / "dataset.nc")
    assert ds.attrs["git_commit"] in readme and ds.attrs["config_hash"] in readme
    assert "the files of 5 of them here" in readme
    assert sorted(p.parent.name for p in (archive / "packings").rglob("jammed.h5"))[0] == "r0"
    assert not list((archive / "packings").rglob("poisson.h5"))
    capsys.readouterr()
    assert main(["browse", str(archive / "dataset.nc"), "--tables"]) == 0
    assert "table4" in capsys.readouterr().out
    key = "ls/sigma0/rate0.5/r0"
    assert main(["browse", str(archive / "dataset.nc"), "--packing", key]) == 0
    out = capsys.readouterr().out
    assert str(archive / "packings" / key / "jammed.h5") in out
    assert main(["browse", str(archive / "dataset.nc"), "--figure", "fig4", "-o", str(tmp_path / "f4")]) == 0
    assert (tmp_path / "f4.png").stat().st_size > 1000
    # without the run histories: the packing is the same, its file smaller, its provenance kept
    slim = tmp_path / "slim"
    assert main(["archive", str(results), "-o", str(slim), "--packings", key, "--no-history"]) == 0
    full, stripped = results / "packings" / key / "jammed.h5", slim / "packings" / key / "jammed.h5"
    a, b = read_packing(full), read_packing(stripped)
    assert np.array_equal(a.positions, b.positions) and a.phi == b.phi and a.metadata == b.metadata
    assert read_packing(stripped, with_history=True)[1] == {} and stripped.stat().st_size < full.stat().st_size
    assert "without their run histories" in (slim / "README.md").read_text()
    assert main(["archive", str(results), "-o", str(slim), "--packings", "*", "--no-history", "--max-mb", "0.01"]) == 2
    assert (slim / "packings" / key / "jammed.h5").is_file()  # refused after writing: the old archive is intact
    # again, with fewer packings: the archive is replaced as a whole
    assert main(["archive", str(results), "-o", str(archive)]) == 0
    assert not (archive / "packings").exists()
    assert main(["archive", str(results), "-o", str(archive), "--packings", "*", "--max-mb", "0.01"]) == 2
    assert "--max-mb=0.01: the archive would hold" in capsys.readouterr().err
    assert (archive / "dataset.nc").is_file()  # the refused archive left the old one as it was


def test_killed_job_rerun_completes(tiny_run, tmp_path):
    """A workflow killed mid-job (SIGKILL, as on a node crash) leaves no partial output; the rerun completes."""
    import os
    import signal
    import time

    from spherejam.core.packing_io import read_packing

    results, cfg = tiny_run
    work = tmp_path / "copy"
    shutil.copytree(results, work / "results")
    c = yaml.safe_load(Path(cfg).read_text())
    c["results"] = str(work / "results")
    (work / "c.yaml").write_text(yaml.safe_dump(c))
    jammed = work / "results" / "packings" / "ls/sigma0.1/rate0.5/r0" / "jammed.h5"
    jammed.unlink()  # the state of a run killed before this MLS job and the dataset were done
    (work / "results" / "dataset.nc").unlink()
    proc = subprocess.Popen(
        [*SNAKEMAKE, str(jammed), "--cores", "1", "--configfile", str(work / "c.yaml")],
        cwd=ROOT, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, start_new_session=True,
    )
    log = work / "results" / "logs" / "mls" / "ls/sigma0.1/rate0.5/r0.log"
    deadline = time.time() + 120
    while not log.exists() and time.time() < deadline and proc.poll() is None:
        time.sleep(0.05)
    time.sleep(0.5)
    os.killpg(proc.pid, signal.SIGKILL)
    proc.wait()
    if jammed.exists():  # the job won the race: its output must then be complete and valid
        read_packing(jammed)
    assert not list(jammed.parent.glob("*.tmp*")) or not jammed.exists()
    subprocess.run([*SNAKEMAKE, "--unlock", "--cores", "1", "--configfile", str(work / "c.yaml")], cwd=ROOT,
                   capture_output=True, check=True)
    r = snakemake("--cores", "2", "--configfile", str(work / "c.yaml"))
    assert r.returncode == 0, r.stderr[-3000:]
    assert read_packing(jammed).phi > 0.55 and (work / "results" / "dataset.nc").exists()
    assert not list((work / "results" / "packings").rglob("*.tmp*"))


def test_report_holds_every_figure_and_table(tiny_run, tmp_path):
    results, cfg = tiny_run
    report = tmp_path / "report.html"
    r = snakemake("--report", str(report), "--configfile", str(cfg))
    assert r.returncode == 0, r.stderr[-3000:]
    text = report.read_text(errors="replace")
    for name in ("fig2", "fig3", "fig4", "fig5", "fig7", "structure", "forces", "table2", "table3", "table4",
                 "comparison", "Comparison with the paper"):
        assert name in text


def test_a_config_change_remakes_the_dataset_without_snakemake_metadata(tiny_run, tmp_path):
    """A config that changes only the tables (bands.alpha), run from a working directory with no .snakemake/
    metadata: Snakemake's params trigger cannot fire, yet the dataset and tables must be made again (the manifest
    of the old config is written anew at start), and no packing."""
    results, configfile = tiny_run
    cfg = yaml.safe_load(configfile.read_text())
    cfg["bands"] = {**cfg.get("bands", {}), "alpha": 0.9}
    (tmp_path / "changed.yaml").write_text(yaml.safe_dump(cfg))
    r = snakemake("-n", "--cores", "1", "--snakefile", str(ROOT / "Snakefile"), "--directory", str(tmp_path),
                  "--configfile", str(tmp_path / "changed.yaml"))
    assert r.returncode == 0, r.stderr[-3000:]
    assert "written for another config" in r.stderr
    jobs = set(re.findall(r"^(?:local)?rule (\w+):", r.stdout + r.stderr, flags=re.M))
    assert {"dataset", "tables"} <= jobs and not jobs & {"seed", "ls", "fb", "mls", "calippso", "analyze"}, jobs



def test_per_cell_sample_is_the_only_calippso_jobs(tmp_path):
    """calippso.per_cell: 1 (tiny config, 2 cells of 10 packings): the DAG holds one CALiPPSO job per cell, for the
    packing Experiment.certifies, and every packing's MLS job still."""
    cfg = yaml.safe_load((ROOT / "config" / "tiny.yaml").read_text())
    cfg["results"] = str(tmp_path / "results")
    cfg["calippso"]["per_cell"] = 1
    (tmp_path / "c.yaml").write_text(yaml.safe_dump(cfg))
    r = snakemake("-n", "-p", "--cores", "2", "--configfile", str(tmp_path / "c.yaml"))
    assert r.returncode == 0, r.stderr[-3000:]
    jobs = [line.split("spherejam calippso ")[1] for line in r.stdout.splitlines() if "spherejam calippso " in line]
    exp = Experiment(cfg)
    sample = [run for run in exp.runs() if exp.certifies(run)]
    assert len(sample) == 2 and len(jobs) == 2
    assert sorted(job.split()[0] for job in jobs) == sorted(str(exp.path(run, "jammed")) for run in sample)
    assert sum("spherejam mls " in line for line in r.stdout.splitlines()) >= len(exp.runs())
