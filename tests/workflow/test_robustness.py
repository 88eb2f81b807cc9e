"""Issue 33: each class of failure made impossible (docs/robustness.md).

Special files are made with mknod/mkfifo in a private folder, never on the real /dev; a full disk is a small tmpfs
mounted in a private folder (skipped where mounting is not allowed). Signals are real, sent to a subprocess.
"""

import contextlib
import io
import os
import signal
import stat
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from spherejam.cli import main
from spherejam.core.atomic import atomic_folder, atomic_output
from spherejam.core.checkpoint import Checkpoint
from spherejam.core.errors import InputError, OutputError
from spherejam.core.packing_io import read_packing, write_packing
from spherejam.core.seeding import poisson_packing

SRC = str(Path(__file__).resolve().parents[2] / "src")
#: The device numbers of /dev/null, for a private node with the same device (the real /dev is never touched).
_NULL_NUMBERS = os.stat(os.devnull).st_rdev


def cli(*args):
    """(exit code, stderr lines, stdout) of ``spherejam ARGS``, run in-process."""
    err, out = io.StringIO(), io.StringIO()
    with contextlib.redirect_stderr(err), contextlib.redirect_stdout(out):
        code = main([str(a) for a in args])
    return code, err.getvalue().strip().splitlines(), out.getvalue()


@pytest.fixture
def packing_file(tmp_path):
    path = tmp_path / "p.h5"
    write_packing(path, poisson_packing(30, 0.1, 1))
    return path


# --- data loss: special files -------------------------------------------------------------------------------------


def _special_files(folder: Path) -> dict[str, Path]:
    """A device node (/dev/zero's numbers), a block device node, a FIFO, a symlink to the device node and a symlink
    through /proc/self/fd (what /dev/stdout is), all inside ``folder``."""
    if os.geteuid() != 0:
        pytest.skip("mknod needs root")
    made = {"char": folder / "zero", "block": folder / "loop", "fifo": folder / "fifo", "link": folder / "link",
            "stdout": folder / "stdout"}
    os.mknod(made["char"], 0o666 | stat.S_IFCHR, os.makedev(1, 5))
    os.mknod(made["block"], 0o666 | stat.S_IFBLK, os.makedev(7, 0))
    os.mkfifo(made["fifo"])
    made["link"].symlink_to(made["char"])
    made["stdout"].symlink_to("/proc/self/fd/1")
    return made


@pytest.mark.parametrize("kind", ["char", "block", "fifo", "link", "stdout"])
@pytest.mark.parametrize("command", ["seed", "export", "checkpoint"])
def test_a_special_file_is_never_replaced(tmp_path, packing_file, kind, command):
    target = _special_files(tmp_path)[kind]
    before = os.lstat(target)
    argv = {"seed": ["seed", "--n", 10, "-o", target],
            "export": ["export", packing_file, "--format", "lammps", "-o", target],
            "checkpoint": ["ls", packing_file, "--rate", 1, "--checkpoint", target, "-o", tmp_path / "o.h5"]}[command]
    code, err, _ = cli(*argv)
    assert code == 2 and len(err) == 1, err
    assert "not a regular file" in err[0] and ("-o/--output" in err[0] or "--checkpoint" in err[0])
    after = os.lstat(target)
    assert (after.st_mode, after.st_ino, after.st_rdev) == (before.st_mode, before.st_ino, before.st_rdev)


def test_the_atomic_write_itself_refuses_a_special_file(tmp_path):
    target = _special_files(tmp_path)["fifo"]
    with pytest.raises(InputError, match="FIFO"), atomic_output(target) as tmp:
        tmp.write_text("x")
    assert stat.S_ISFIFO(os.lstat(target).st_mode)


def test_the_null_device_discards_the_output(tmp_path):
    if os.geteuid() != 0:
        pytest.skip("mknod needs root")
    null = tmp_path / "null"  # a private node with /dev/null's numbers: the same device, not the real /dev
    os.mknod(null, 0o666 | stat.S_IFCHR, _NULL_NUMBERS)
    assert os.stat(null).st_rdev == os.stat(os.devnull).st_rdev
    code, err, out = cli("seed", "--n", 10, "-o", null)
    assert code == 0, err
    assert stat.S_ISCHR(os.lstat(null).st_mode)
    assert os.listdir(tmp_path) == ["null"]  # no temporary file left beside it


def test_a_symlink_to_a_regular_file_writes_its_target(tmp_path):
    target, link = tmp_path / "real.h5", tmp_path / "link.h5"
    target.write_text("old")
    link.symlink_to(target)
    assert cli("seed", "--n", 10, "-o", link)[0] == 0
    assert link.is_symlink() and read_packing(target).n == 10


def test_long_file_names(tmp_path):
    code, err, _ = cli("seed", "--n", 10, "-o", tmp_path / ("a" * 300 + ".h5"))
    assert code == 2 and len(err) == 1 and "-o/--output" in err[0] and "255" in err[0], err
    ok = tmp_path / ("b" * 250 + ".h5")  # fits, though its temporary name would not without shortening
    assert cli("seed", "--n", 10, "-o", ok)[0] == 0 and read_packing(ok).n == 10


# --- data loss: a full disk and multi-file outputs ----------------------------------------------------------------


@pytest.fixture
def small_disk(tmp_path):
    """A 256 kB tmpfs mounted in a private folder (root only)."""
    mount = tmp_path / "disk"
    mount.mkdir()
    done = subprocess.run(["mount", "-t", "tmpfs", "-o", "size=256k", "tmpfs", str(mount)], capture_output=True)
    if done.returncode != 0:
        pytest.skip(f"cannot mount a tmpfs here ({done.stderr.decode().strip()})")
    try:
        yield mount
    finally:
        subprocess.run(["umount", str(mount)], check=True)


def test_disk_full_is_one_line_naming_the_option_and_keeps_the_old_file(small_disk):
    out = small_disk / "big.h5"
    assert cli("seed", "--n", 10, "-o", out)[0] == 0
    old = out.read_bytes()
    code, err, _ = cli("seed", "--n", 20000, "-o", out)
    assert code == 1 and len(err) == 1, err
    assert "-o/--output" in err[0] and "no space left" in err[0]
    assert out.read_bytes() == old
    assert sorted(p.name for p in small_disk.iterdir()) == ["big.h5"]


def test_export_folder_on_a_full_disk_leaves_no_folder(small_disk, tmp_path):
    big = tmp_path / "big.h5"
    write_packing(big, poisson_packing(20000, 0.0, 1))
    code, err, _ = cli("export", big, "--format", "packing-generation", "-o", small_disk / "pg")
    assert code == 1 and len(err) == 1 and "no space left" in err[0], err
    assert list(small_disk.iterdir()) == []


def test_a_file_set_is_all_new_or_all_old(small_disk):
    folder = small_disk / "tables"
    names = ("a.csv", "b.csv", "c.csv")
    with atomic_folder(folder, names) as tmp:
        for name in names:
            (tmp / name).write_text(f"old {name}")
    with pytest.raises(OutputError, match="no space left"), atomic_folder(folder, names) as tmp:
        (tmp / "a.csv").write_text("new a")
        (tmp / "b.csv").write_text("x" * 400_000)  # does not fit
        (tmp / "c.csv").write_text("new c")
    assert {p.name: p.read_text() for p in folder.iterdir()} == {n: f"old {n}" for n in names}
    assert sorted(p.name for p in small_disk.iterdir()) == ["tables"]


def test_tables_write_through_one_folder_swap(tmp_path, monkeypatch):
    """write_tables hands its whole set to atomic_folder: a failure in the last file leaves the old set."""
    from test_tables import synthetic_dataset

    from spherejam.workflow import tables

    out = tmp_path / "tables"
    first = tables.write_tables(synthetic_dataset(), out)
    old = {p.name: p.read_bytes() for p in out.iterdir()}
    real = Path.write_text

    def fail_on_last(self, text, *args, **kwargs):
        if self.name == "comparison.md":
            raise OSError(28, "No space left on device", str(self))
        return real(self, text, *args, **kwargs)

    monkeypatch.setattr(Path, "write_text", fail_on_last)
    with pytest.raises(OutputError):
        tables.write_tables(synthetic_dataset(), out)
    assert {p.name: p.read_bytes() for p in out.iterdir()} == old and len(first) == len(old)


# --- data loss: checkpoints -------------------------------------------------------------------------------------


def test_resume_removes_temporary_files_of_a_killed_save(tmp_path):
    ckpt = tmp_path / "run.ckpt.h5"
    leftovers = [tmp_path / ".run.ckpt.h5.k3j_9x2a.tmp.h5", tmp_path / ".run.ckpt.h5.AbCdEfGh.tmp.h5"]
    kept = [tmp_path / ".run.ckpt.h5.notmine.tmp.h5", tmp_path / "other.h5", tmp_path / ".other.h5.abcdefgh.tmp.h5"]
    for p in leftovers + kept:
        p.write_text("partial")
    assert Checkpoint(ckpt, "ls", "f", 300.0).resume() is None
    assert not any(p.exists() for p in leftovers)
    assert all(p.exists() for p in kept)


def _run_until_signal(argv, sig, cwd, marker):
    """Start ``spherejam ARGV``, send ``sig`` once stderr shows ``marker``; (exit code, stderr)."""
    env = {**os.environ, "PYTHONPATH": SRC}
    proc = subprocess.Popen([sys.executable, "-m", "spherejam.cli", *map(str, argv)], cwd=cwd, env=env,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    lines = []
    deadline = time.monotonic() + 300
    for line in proc.stderr:
        lines.append(line)
        if marker in line:
            proc.send_signal(sig)
            break
        assert time.monotonic() < deadline
    rest = proc.stderr.read()
    proc.wait(timeout=300)
    return proc.returncode, "".join(lines) + rest


@pytest.mark.parametrize("sig", [signal.SIGTERM, signal.SIGINT])
def test_a_signal_saves_a_checkpoint_and_the_rerun_resumes_it(tmp_path, sig):
    start = tmp_path / "start.h5"
    write_packing(start, poisson_packing(60, 0.0, 3))
    common = ["ls", start, "--rate", "0.01", "--seed", 5, "--progress-interval", 0, "--checkpoint-interval", 1e6]
    code, err = _run_until_signal([*common, "--checkpoint", tmp_path / "c.h5", "-o", tmp_path / "out.h5"], sig,
                                  tmp_path, "window 3:")
    assert code == 128 + sig, err
    assert f"stopped by {signal.Signals(sig).name}" in err and "checkpoint saved" in err
    assert (tmp_path / "c.h5").exists() and not (tmp_path / "out.h5").exists()
    # the rerun (what Snakemake's resubmission does) resumes and ends where an uninterrupted run ends
    assert cli(*common, "--checkpoint", tmp_path / "c.h5", "-o", tmp_path / "out.h5", "-q")[0] == 0
    assert cli(*common, "-o", tmp_path / "straight.h5", "-q")[0] == 0
    resumed, straight = read_packing(tmp_path / "out.h5"), read_packing(tmp_path / "straight.h5")
    assert resumed.metadata["counters"]["resumed"] is True
    assert np.array_equal(resumed.positions, straight.positions)
    assert np.array_equal(resumed.diameters, straight.diameters)
    assert not (tmp_path / "c.h5").exists()


def test_calippso_saves_its_checkpoint_on_sigterm(tmp_path):
    start = tmp_path / "start.h5"
    ls = tmp_path / "ls.h5"
    write_packing(start, poisson_packing(40, 0.0, 2))
    assert cli("ls", start, "--rate", 1, "--p-max", 1e3, "-o", ls, "-q")[0] == 0
    code, err = _run_until_signal(["calippso", ls, "--checkpoint", tmp_path / "c.h5", "-o", tmp_path / "j.h5"],
                                  signal.SIGTERM, tmp_path, "calippso")
    assert code == 143, err
    assert "stopped by SIGTERM after" in err and (tmp_path / "c.h5").exists()
    assert cli("calippso", ls, "--checkpoint", tmp_path / "c.h5", "-o", tmp_path / "j.h5", "-q")[0] == 0


# --- wrong results ------------------------------------------------------------------------------------------------


def test_lammps_header_count_below_the_atoms_rows_is_refused(tmp_path, packing_file):
    data = tmp_path / "p.data"
    assert cli("export", packing_file, "--format", "lammps", "-o", data)[0] == 0
    data.write_text(data.read_text().replace("30 atoms", "29 atoms"))
    code, err, _ = cli("import", data, "-o", tmp_path / "back.h5")
    assert code == 2 and len(err) == 1 and "holds 30 atoms but the header says 29" in err[0], err
    assert not (tmp_path / "back.h5").exists()


def _touching_lattice() -> "np.ndarray":
    """A simple cubic lattice of touching spheres (every sphere has 6 contacts), shifted off float32's grid."""
    a, m = 1.1, 4
    grid = np.stack(np.meshgrid(*[np.arange(m)] * 3, indexing="ij"), axis=-1).reshape(-1, 3) * a + 0.123456789
    return grid, np.full(len(grid), a), m * a


def test_a_float32_gsd_import_writes_no_overlaps(tmp_path):
    import gsd.hoomd

    positions, diameters, L = _touching_lattice()
    frame = gsd.hoomd.Frame()  # what HOOMD writes: float32, centred box, no spherejam chunks
    frame.particles.N = len(diameters)
    frame.particles.position = (positions - L / 2).astype(np.float32)
    frame.particles.diameter = diameters.astype(np.float32)
    frame.configuration.box = [L, L, L, 0, 0, 0]
    with gsd.hoomd.open(tmp_path / "h.gsd", "w") as traj:
        traj.append(frame)
    code, err, out = cli("import", tmp_path / "h.gsd", "--tolerance", "1e-6", "-o", tmp_path / "p.h5")
    assert code == 0, err
    assert "diameters scaled by" in out
    back = read_packing(tmp_path / "p.h5")  # the default 1e-10 tolerance: every other command reads it
    scale = back.metadata["source"]["diameter_scale"]
    assert 1 - 1e-6 < scale < 1 - 1e-9  # the round-off of float32, no more
    assert back.check(1e-10).ok and back.closest_pair()[2] == pytest.approx(1.0, abs=1e-15)
    assert cli("check", tmp_path / "p.h5")[0] == 0


def test_rates_that_share_a_path_are_refused():
    from spherejam.workflow.experiment import Experiment

    config = {"n": 20, "seed": 1, "sigmas": [0.0], "ls": {"rates": [0.1, 0.1000000000001, 0.5]},
              "fb": {"rates": [0.01]}}
    with pytest.raises(InputError, match=r"ls.rates\[1\]=0.1000000000001: differs from 0.1 only beyond"):
        Experiment(config)
    with pytest.raises(InputError, match=r"sigmas\[1\]"):
        Experiment({**config, "ls": {"rates": [0.1]}, "sigmas": [0.1, 0.10000001]})
    extra = {"rates": [0.1], "extra_rates": [{"sigmas": [0.0], "rates": [0.1000000000001]}]}
    with pytest.raises(InputError, match="extra_rates"):
        Experiment({**config, "ls": extra})
    assert [r.rate for r in Experiment({**config, "ls": {"rates": [0.1, 0.1, 0.5]}}).runs("ls")] == [0.1, 0.5]
    assert Experiment(config | {"ls": {"rates": [0.1, 0.5]}}).runs("ls")[0].key == "ls/sigma0/rate0.1/r0"  # as before


def test_the_geometric_isostaticity_is_not_named_as_a_verdict(tmp_path):
    """The gap count is `isostatic_at_tolerance`; an old dataset's `is_isostatic` reads under that name, and browse
    says which flag certifies."""
    from test_tables import synthetic_dataset

    from spherejam.workflow.dataset import open_dataset

    ds = synthetic_dataset()
    ds["is_isostatic"] = ("packing", np.zeros(ds.sizes["packing"]), {"long_name": "1 if K' == K_0 exactly, else 0"})
    ds.to_netcdf(tmp_path / "old.nc", engine="h5netcdf")
    back = open_dataset(tmp_path / "old.nc")
    assert "is_isostatic" not in back and "isostatic_at_tolerance" in back
    assert "not a verdict on jamming" in back["isostatic_at_tolerance"].attrs["long_name"]
    code, err, out = cli("browse", tmp_path / "old.nc")
    assert code == 0, err
    assert "jamming is certified by calippso_is_isostatic" in out


# --- tracebacks ---------------------------------------------------------------------------------------------------


def _set_box(path: Path, box: float) -> None:
    import h5py

    with h5py.File(path, "r+") as f:
        f.attrs["box"] = box


@pytest.mark.parametrize("argv", [["info", "IN"], ["check", "IN"], ["ls", "IN", "--rate", 1, "-o", "OUT"],
                                  ["mls", "IN", "-o", "OUT"], ["fb", "IN", "--rate", 0.1, "-o", "OUT"],
                                  ["calippso", "IN", "-o", "OUT"], ["analyze", "IN"],
                                  ["export", "IN", "--format", "lammps", "-o", "OUT"]])
def test_a_huge_box_is_refused_on_read_by_every_command(tmp_path, packing_file, argv):
    _set_box(packing_file, 1e300)
    code, err, _ = cli(*[{"IN": packing_file, "OUT": tmp_path / "out"}.get(a, a) for a in argv])
    assert code == 2 and len(err) == 1 and "box side is 1e+300" in err[0], err


def test_import_box_has_the_same_limit(tmp_path, packing_file):
    dat = tmp_path / "p.dat"
    assert cli("export", packing_file, "--format", "calippso-jl", "-o", dat)[0] == 0
    code, err, _ = cli("import", dat, "--box", "1e300", "-o", tmp_path / "back.h5")
    assert code == 2 and len(err) == 1 and "--box" in err[0] and "1e+50" in err[0], err


def test_a_seed_beyond_the_box_limit_is_refused_in_one_line(tmp_path):
    code, err, _ = cli("seed", "--n", 10, "--dim", 5, "--phi-nominal", "1e-300", "-o", tmp_path / "s.h5")
    assert code == 2 and len(err) == 1 and "box side" in err[0], err
    assert not (tmp_path / "s.h5").exists()


def test_analyze_after_a_tiny_nominal_density(tmp_path):
    """seed --phi-nominal 1e-60 makes a box of 3e20; the Voronoi tessellation works in box units."""
    from spherejam.analysis.voronoi import voronoi_volumes

    p = poisson_packing(60, 0.1, 4, phi_nominal=1e-60)
    assert p.box > 1e19
    small = p.replace(positions=p.positions / p.box, diameters=p.diameters / p.box, box=1.0)
    np.testing.assert_allclose(voronoi_volumes(p) / p.box**3, voronoi_volumes(small), rtol=1e-9)
    write_packing(tmp_path / "s.h5", p)
    code, err, _ = cli("analyze", tmp_path / "s.h5", "--pore-samples", 1000, "-q")
    assert code == 0, err


def _packing_generation(tmp_path, packing_file) -> Path:
    folder = tmp_path / "pg"
    assert cli("export", packing_file, "--format", "packing-generation", "-o", folder)[0] == 0
    return folder


def test_packing_generation_size_zero_is_refused(tmp_path, packing_file):
    folder = _packing_generation(tmp_path, packing_file)
    for name, key in (("generation.conf", "Packing size:"), ("packing.nfo", " Dimensions:")):  # agreeing files
        path = folder / name
        path.write_text("\n".join(f"{key} 0 0 0" if line.startswith(key) else line
                                  for line in path.read_text().splitlines()) + "\n")
    code, err, _ = cli("import", folder, "-o", tmp_path / "back.h5")
    assert code == 2 and len(err) == 1 and "Packing size [0.0, 0.0, 0.0]" in err[0], err


# --- unclear errors -----------------------------------------------------------------------------------------------


def test_a_negative_diameter_in_xyzd_is_named(tmp_path, packing_file):
    folder = _packing_generation(tmp_path, packing_file)
    data = np.fromfile(folder / "packing.xyzd", dtype="<f8").reshape(-1, 4)
    data[3, 3] = -data[3, 3]
    data.tofile(folder / "packing.xyzd")
    code, err, _ = cli("import", folder, "-o", tmp_path / "back.h5")
    assert code == 2 and len(err) == 1 and "sphere 3 has diameter -" in err[0] and "porosity" not in err[0], err


def test_import_of_a_folder_as_a_one_file_format(tmp_path):
    code, err, _ = cli("import", tmp_path, "--format", "lammps", "-o", tmp_path / "x.h5")
    assert code == 2 and len(err) == 1 and "is a directory" in err[0] and "no such file" not in err[0], err


def test_fb_max_iterations_says_so_on_stderr_and_writes_the_partial_result(tmp_path, packing_file):
    code, err, out = cli("fb", packing_file, "--rate", 0.01, "--max-iterations", 3, "-o", tmp_path / "fb.h5", "-q")
    assert code == 1 and len(err) == 1 and "--max-iterations" in err[0] and out == "", (err, out)
    partial = read_packing(tmp_path / "fb.h5")
    assert partial.metadata["counters"]["completed"] is False
    assert partial.metadata["counters"]["stop_reason"] == "max_iterations"


def test_browse_on_a_packing_file_is_one_line(packing_file):
    proc = subprocess.run([sys.executable, "-m", "spherejam.cli", "browse", str(packing_file)], capture_output=True,
                          text=True, env={**os.environ, "PYTHONPATH": SRC})
    assert proc.returncode == 2 and len(proc.stderr.strip().splitlines()) == 1, proc.stderr
    assert "a spherejam packing file, not a results dataset" in proc.stderr


def test_third_party_info_lines_are_not_shown(packing_file):
    """freud logs "Using SciPy's fftpack" at INFO when imported; only spherejam's own lines are shown."""
    for quiet in ([], ["-q"]):
        proc = subprocess.run([sys.executable, "-m", "spherejam.cli", "analyze", str(packing_file),
                               "--pore-samples", "1000", *quiet], capture_output=True, text=True,
                              env={**os.environ, "PYTHONPATH": SRC})
        assert proc.returncode == 0 and "fftpack" not in proc.stderr, proc.stderr


def test_browse_empty_figure_names_figure(tmp_path):
    from test_tables import synthetic_dataset

    synthetic_dataset().to_netcdf(tmp_path / "ds.nc", engine="h5netcdf")
    code, err, _ = cli("browse", tmp_path / "ds.nc", "--figure", "", "-o", tmp_path / "f")
    assert code == 2 and len(err) == 1 and err[0].startswith("spherejam browse: error: --figure=''"), err


def test_duplicate_yaml_keys_are_refused(tmp_path):
    from spherejam.workflow.config import load_config_file

    path = tmp_path / "c.yaml"
    path.write_text("n: 20\nls:\n  rates: [0.1]\n  p_max: 1e12\n  rates: [0.5]\n")
    with pytest.raises(InputError, match=r"line 5: key 'rates' is given twice"):
        load_config_file(path)
    code, err, _ = cli("cost", path)
    assert code == 2 and len(err) == 1 and "given twice" in err[0], err
    path.write_text("a: &x {b: 1}\nc:\n  <<: *x\n  d: 2\n")  # a merge key is not a repeat
    assert load_config_file(path) == {"a": {"b": 1}, "c": {"b": 1, "d": 2}}


@pytest.mark.parametrize("results", ["", "  ", None])
def test_an_empty_results_folder_is_refused(results):
    from spherejam.workflow.experiment import Experiment

    config = {"n": 20, "seed": 1, "sigmas": [0.0], "ls": {"rates": [0.1]}, "fb": {"rates": [0.01]},
              "results": results}
    with pytest.raises(InputError, match="results="):
        Experiment(config)


def test_a_special_file_as_input_is_refused_not_read(tmp_path):
    """A FIFO given as a packing would block the HDF5 reader for ever."""
    fifo = _special_files(tmp_path)["fifo"]
    code, err, _ = cli("info", fifo)
    assert code == 2 and len(err) == 1 and "is a FIFO, not a packing file" in err[0], err


def test_grid_values_that_share_a_path_are_refused():
    from spherejam.workflow.experiment import Experiment

    config = {"n": 20, "seed": 1, "sigmas": [0.0], "ls": {"rates": [0.1]}, "fb": {"rates": [0.01]},
              "validation_grid": {"enabled": True, "sigmas": [0.0], "ls_rates": [0.1],
                                  "initial_rates": [10, 10.0000001], "decrease_factors": [2], "final_rates": [1e-3]}}
    with pytest.raises(InputError, match=r"validation_grid.initial_rates\[1\]"):
        Experiment(config)


def test_a_figure_to_the_null_device_is_refused(tmp_path):
    if os.geteuid() != 0:
        pytest.skip("mknod needs root")
    null = tmp_path / "null"
    os.mknod(null, 0o666 | stat.S_IFCHR, _NULL_NUMBERS)
    code, err, _ = cli("figure", "fig2", tmp_path / "ds.nc", "-o", null)
    assert code == 2 and len(err) == 1 and "not a stem" in err[0], err
    assert os.listdir(tmp_path) == ["null"]


# --- issue 49 -------------------------------------------------------------------------------------------------------

REPRODUCTION = Path(__file__).resolve().parents[2] / "archive" / "reproduction"


def _spherejam(*args, cwd=None, timeout=120):
    """(exit code, stderr) of ``spherejam ARGS`` in a subprocess: a reader that blocks fails the test, not the run."""
    env = {**os.environ, "PYTHONPATH": SRC}
    proc = subprocess.run([sys.executable, "-m", "spherejam.cli", *map(str, args)], cwd=cwd, env=env,
                          capture_output=True, text=True, timeout=timeout)
    return proc.returncode, proc.stderr.strip().splitlines()


@pytest.mark.parametrize("argv", [
    ["merge", "{fifo}", "-o", "{out}/m.nc"],
    ["browse", "{fifo}"],
    ["tables", "{fifo}", "--outdir", "{out}/t"],
    ["dataset", "{fifo}", "-o", "{out}/d.nc"],
    ["cost", "{fifo}"],
    ["psd", "table:{fifo}"],
    ["import", "{fifo}", "--format", "lammps", "-o", "{out}/i.h5"],
])
def test_a_fifo_as_input_is_refused_by_every_reader(tmp_path, argv):
    fifo = tmp_path / "fifo"
    os.mkfifo(fifo)
    code, err = _spherejam(*[a.format(fifo=fifo, out=tmp_path) for a in argv], timeout=60)
    assert code == 2 and len(err) == 1 and "is a FIFO, not a" in err[0], err


def test_a_fifo_inside_a_results_folder_is_refused_by_the_dataset_readers(tmp_path):
    """`dataset` reads each packing's HDF5 attributes, its structure.json and calippso.json, and the contact forces
    of calippso.h5: a FIFO in place of any of them is one error, not a hang."""
    for name in ("calippso.h5", "jammed.h5", "structure.json"):
        os.mkfifo(tmp_path / name)
    script = (
        "import sys\n"
        "from pathlib import Path\n"
        "from spherejam.core.errors import PackingFileError\n"
        "from spherejam.core.packing_io import read_group\n"
        "from spherejam.workflow.dataset import _attrs, _json_scalars\n"
        f"folder = Path({str(tmp_path)!r})\n"
        "for call in (lambda: read_group(folder / 'calippso.h5', 'contacts'), lambda: _attrs(folder / 'jammed.h5'),\n"
        "             lambda: _json_scalars(folder / 'structure.json', '')):\n"
        "    try:\n"
        "        call()\n"
        "    except PackingFileError as exc:\n"
        "        print(exc)\n")
    proc = subprocess.run([sys.executable, "-c", script], env={**os.environ, "PYTHONPATH": SRC}, capture_output=True,
                          text=True, timeout=60)
    lines = proc.stdout.strip().splitlines()
    assert len(lines) == 3 and all("is a FIFO, not a" in line for line in lines), (lines, proc.stderr)


@pytest.mark.parametrize("content, message", [
    ({"z_nonrattler": "six", "n_contacts": 300}, "z_nonrattler=\"six\": must be a number"),
    ({"z_nonrattler": [6.0]}, "z_nonrattler=[6.0]: must be a number"),
    ([1, 2, 3], "a JSON list; expected an object"),
    ({"scalars": "x"}, "a JSON str; expected an object"),
])
def test_a_non_numeric_results_value_is_one_line(tmp_path, content, message):
    import json

    from spherejam.core.errors import PackingFileError
    from spherejam.workflow.dataset import _json_scalars

    path = tmp_path / "structure.json"
    path.write_text(json.dumps(content))
    with pytest.raises(PackingFileError) as err:
        _json_scalars(path, "")
    assert message in str(err.value) and "\n" not in str(err.value), str(err.value)
    path.write_text(json.dumps({"z_nonrattler": 6.0, "q6_global": None, "packing": {"path": "x"}}))
    row = _json_scalars(path, "")  # paths and descriptions beside the variables are not read
    assert row["z_nonrattler"] == 6.0 and np.isnan(row["q6_global"])


def test_rcp_refuses_an_n_the_distribution_cannot_be_drawn_at_in_the_dry_run(tmp_path):
    code, err, out = cli("rcp", "bidisperse:ratio=10,small=0.3,by=volume", "--n", 200, "--dry-run",
                         "--workflow", Path(SRC).parent, "-o", tmp_path / "res")
    assert code == 2 and len(err) == 1 and "at N = 200 the large spheres" in err[0] and "use N >= 430" in err[0], err
    assert not (tmp_path / "res").exists()


def test_rcp_refuses_a_file_as_its_results_folder(tmp_path):
    (tmp_path / "afile").write_text("mine")
    code, err, _ = cli("rcp", "gaussian:delta=0.1", "-o", tmp_path / "afile", "--dry-run", "--workflow",
                       Path(SRC).parent)
    assert code == 2 and len(err) == 1 and err[0].startswith("spherejam rcp: error: -o/--results="), err
    assert (tmp_path / "afile").read_text() == "mine"


@pytest.mark.parametrize("content, message", [
    (b"", "an empty file"),
    (b"n: [\n", "not valid YAML"),
    (b"- 1\n- 2\n", "this file holds a list"),
    (b"\xff\xfe\x00n: 1\n", "not a UTF-8 text file"),
    (b"n: 200\nreplicas: 1\nn: 300\n", "key 'n' is given twice"),
])
def test_rcp_template_and_cost_read_config_files_alike(tmp_path, content, message):
    template = tmp_path / "t.yaml"
    template.write_bytes(content)
    code, err, _ = cli("rcp", "gaussian:delta=0.1", "--template", template, "--dry-run", "--workflow",
                       Path(SRC).parent, "-o", tmp_path / "res")
    assert code == 2 and len(err) == 1 and "--template=" in err[0] and message in err[0], err
    if content:  # an empty file is a valid (empty) config for `cost`, which merges several
        code, err, _ = cli("cost", template)
        assert code == 2 and len(err) == 1 and message in err[0], err


def test_a_tiny_box_seed_fits_its_largest_sphere(tmp_path):
    """N = 2 at 1:10: the large sphere met its own image ("overlap between spheres 1 and 1", exit 1)."""
    out = tmp_path / "s.h5"
    assert cli("seed", "--n", 2, "--psd", "bidisperse:ratio=10,small=0.5,by=number", "--seed", 0, "-o", out)[0] == 0
    packing = read_packing(out)
    assert packing.check(1e-10).ok and packing.diameters.max() <= packing.box * (1 + 1e-12)
    assert packing.diameters.max() / packing.diameters.min() == pytest.approx(10.0)


_SIGNAL_DURING_WRITE = """
import os, signal, sys
import xarray as xr
from spherejam.cli import main
real = xr.Dataset.to_netcdf
def write_then_signal(self, path, *args, **kwargs):
    real(self, path, *args, **kwargs)  # the temporary file is complete; the rename is next
    if {swallow}:
        try:
            os.kill(os.getpid(), signal.{sig})
        except BaseException:  # a library that swallows what the handler raised
            pass
    else:
        os.kill(os.getpid(), signal.{sig})
xr.Dataset.to_netcdf = write_then_signal
sys.exit(main(sys.argv[1:]))
"""


@pytest.mark.parametrize("sig", ["SIGTERM", "SIGINT"])
@pytest.mark.parametrize("swallow", [False, True])
def test_a_signal_during_a_write_leaves_no_output_and_no_temporary(tmp_path, sig, swallow):
    script = tmp_path / "run.py"
    script.write_text(_SIGNAL_DURING_WRITE.format(swallow=swallow, sig=sig))
    out = tmp_path / "out" / "merged.nc"
    out.parent.mkdir()
    proc = subprocess.run([sys.executable, str(script), "merge", str(REPRODUCTION / "dataset.nc"), "-o", str(out)],
                          env={**os.environ, "PYTHONPATH": SRC}, capture_output=True, text=True, timeout=300)
    err = proc.stderr.strip().splitlines()
    assert proc.returncode == 128 + getattr(signal, sig), proc.stderr
    assert err == [f"spherejam merge: stopped by {sig}; no output written (an existing one is kept)"], err
    assert os.listdir(out.parent) == []  # neither the output nor its temporary .merged.nc.XXXXXXXX.tmp.nc
