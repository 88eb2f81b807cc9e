"""Issue 23: every command checks its outputs before any work, never overwrites an input, and fails in one line.

Commands run in-process through ``spherejam.cli.main``; the checks come before any engine runs, so these tests
take milliseconds. Unwritable places are made as root can feel them too (CI runs as root, which ignores a folder's
mode bits): a path below a regular file. The one read-only-folder test skips when the user can write there anyway.
"""

import contextlib
import hashlib
import io
import json
import os
import stat
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from spherejam.cli import main
from spherejam.core.errors import InputError
from spherejam.core.output_paths import check_output_dir, check_outputs, figure_stem


def cli(*args):
    """(exit code, stderr lines) of ``spherejam ARGS``, run in-process."""
    err = io.StringIO()
    with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
        code = main([str(a) for a in args])
    return code, err.getvalue().strip().splitlines()


def digest(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    """A packing (a Poisson packing is overlap-free at its tiny density), a manifest-like JSON and a netCDF."""
    import xarray as xr

    d = tmp_path_factory.mktemp("files")
    assert main(["seed", "--n", "30", "--seed", "3", "-o", str(d / "p.h5")]) == 0
    assert main(["export", str(d / "p.h5"), "--format", "lammps", "-o", str(d / "p.data")]) == 0
    (d / "abs.json").write_text(json.dumps({"config": {}, "config_hash": "x"}))
    ds = xr.Dataset({"phi": ("packing", np.array([0.6]))}, attrs={"config": "{}"})
    ds.to_netcdf(d / "ds.nc", engine="h5netcdf")
    (d / "regular").write_text("a file, not a folder\n")
    return d


SAME_PATH = [  # (argv with IN for the input and OUT for the output; the argument the error must name)
    (["export", "IN", "-o", "IN"], "-o/--output"),
    (["export", "IN", "--format", "gsd", "-o", "IN"], "-o/--output"),
    (["render", "IN", "-o", "IN"], "-o/--output"),
    (["ls", "IN", "--rate", "0.1", "-o", "IN"], "-o/--output"),
    (["mls", "IN", "-o", "IN"], "-o/--output"),
    (["fb", "IN", "--rate", "0.01", "-o", "IN"], "-o/--output"),
    (["calippso", "IN", "-o", "IN"], "-o/--output"),
    (["calippso", "IN", "-o", "OUT", "--summary", "IN"], "--summary"),
    (["analyze", "IN", "-o", "IN"], "-o/--output"),
    (["ls", "IN", "--rate", "0.1", "-o", "OUT", "--checkpoint", "IN"], "--checkpoint"),
]


@pytest.mark.parametrize("argv, name", SAME_PATH)
@pytest.mark.parametrize("alias", ["same", "relative", "symlink", "hardlink"])
def test_an_input_is_never_overwritten(files, tmp_path, argv, name, alias):
    src = files / "p.h5"
    target = {"same": src, "relative": Path(os.path.relpath(src)), "symlink": tmp_path / "link.h5",
              "hardlink": tmp_path / "hard.h5"}[alias]
    if alias == "symlink":
        target.symlink_to(src)
    elif alias == "hardlink":
        os.link(src, target)
    before = digest(src)
    args = [str(src) if a == "IN" and i == 1 else str(target) if a == "IN" else str(tmp_path / "o.h5")
            if a == "OUT" else a for i, a in enumerate(argv)]
    code, err = cli(*args)
    assert code == 2 and len(err) == 1, err
    assert name in err[0] and "refusing to overwrite" in err[0]
    assert digest(src) == before and not (tmp_path / "o.h5").exists()


def test_dataset_and_browse_refuse_their_input(files):
    for argv, path in ((["dataset", files / "abs.json", "-o", files / "abs.json"], files / "abs.json"),
                       (["browse", files / "ds.nc", "--csv", files / "ds.nc"], files / "ds.nc")):
        before = digest(path)
        code, err = cli(*argv)
        assert code == 2 and len(err) == 1 and "refusing to overwrite" in err[0], err
        assert digest(path) == before


BAD_OUTPUTS = {  # an output that cannot be written, and why the message says so
    "under a file": ("regular/out.h5", "is not a directory"),
    "a directory": (".", "directory"),
    "trailing slash": ("newdir/", "directory"),
    "empty": ("", "empty path"),
}

WRITERS = [  # every command that writes, with OUT in the place of the bad path
    ["seed", "--n", "10", "-o", "OUT"],
    ["ls", "IN", "--rate", "0.1", "-o", "OUT"],
    ["mls", "IN", "-o", "OUT"],
    ["fb", "IN", "--rate", "0.01", "-o", "OUT"],
    ["calippso", "IN", "-o", "OUT"],
    ["calippso", "IN", "-o", "ok.h5", "--summary", "OUT"],
    ["calippso", "IN", "-o", "OUT", "--summary", "s.json"],
    ["analyze", "IN", "-o", "OUT"],
    ["export", "IN", "-o", "OUT"],
    ["export", "IN", "--format", "lammps", "-o", "OUT"],
    ["export", "IN", "--format", "packing-generation", "-o", "OUT"],
    ["import", "DATA", "-o", "OUT"],
    ["render", "IN", "-o", "OUT"],
    ["browse", "NC", "--packing", "ls/sigma0/rate1/r0", "--plot", "-o", "OUT"],
    ["ls", "IN", "--rate", "0.1", "-o", "ok.h5", "--checkpoint", "OUT"],
    ["fb", "IN", "--rate", "0.01", "-o", "ok.h5", "--checkpoint", "OUT"],
    ["manifest", "--config-json", "{}", "-o", "OUT"],
    ["dataset", "JSON", "-o", "OUT"],
    ["browse", "NC", "--csv", "OUT"],
    ["browse", "NC", "--figure", "fig2", "-o", "OUT"],
    ["figure", "fig2", "NC", "-o", "OUT"],
    ["tables", "NC", "--outdir", "OUT"],
]


def _folder_wanted(argv, bad):
    """--outdir, a figure's -o and packing-generation's -o take a folder (tested apart)."""
    folder = bad in ("a directory", "trailing slash")
    return folder and (argv[0] == "tables" or (argv[0] in ("figure", "browse") and "-o" in argv)
                       or "packing-generation" in argv)


@pytest.mark.parametrize("argv, bad", [(a, b) for a in WRITERS for b in BAD_OUTPUTS if not _folder_wanted(a, b)],
                         ids=lambda x: x if isinstance(x, str) else " ".join(x[:1] + [y for y in x if y[:1] == "-"]))
def test_outputs_are_checked_before_any_work(files, tmp_path, monkeypatch, argv, bad):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "regular").write_text("x")
    out, why = BAD_OUTPUTS[bad]
    subst = {"IN": files / "p.h5", "JSON": files / "abs.json", "NC": files / "ds.nc", "DATA": files / "p.data",
             "OUT": out}
    code, err = cli(*[subst.get(a, a) for a in argv])
    assert code == 2 and len(err) == 1, err
    option = argv[argv.index("OUT") - 1]
    assert option.lstrip("-") in err[0] and why in err[0], err[0]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["regular"]  # nothing written, not even the summary


def test_tables_outdir_that_is_a_file(files, tmp_path):
    code, err = cli("tables", files / "ds.nc", "--outdir", files / "regular")
    assert code == 2 and "--outdir" in err[0] and "not a directory" in err[0]


def test_read_only_folder(files, tmp_path):
    ro = tmp_path / "ro"
    ro.mkdir()
    ro.chmod(stat.S_IRUSR | stat.S_IXUSR)
    try:
        if os.access(ro, os.W_OK):
            pytest.skip("running as root: a read-only folder is writable (the path-below-a-file cases cover it)")
        code, err = cli("seed", "--n", "10", "-o", ro / "x.h5")
        assert code == 2 and "-o/--output" in err[0] and "not writable" in err[0]
        code, err = cli("analyze", files / "p.h5", "-o", ro / "sub" / "a.json")
        assert code == 2 and "not writable" in err[0]
    finally:
        ro.chmod(stat.S_IRWXU)


def test_helper_names_argument_and_path(tmp_path):
    (tmp_path / "a.h5").write_text("x")
    with pytest.raises(InputError, match=r"^--out='.*a\.h5': is the same file as the input \(src "):
        check_outputs({"--out": tmp_path / "a.h5"}, inputs={"src": tmp_path / "a.h5"})
    with pytest.raises(InputError, match="is also given as -o"):
        check_outputs({"-o": tmp_path / "b.h5", "--summary": tmp_path / "b.h5"})
    assert check_outputs({"-o": tmp_path / "new" / "deeper" / "b.h5", "--x": None}) == {
        "-o": (tmp_path / "new" / "deeper" / "b.h5").resolve()}
    assert not (tmp_path / "new").exists()  # checking creates nothing
    with pytest.raises(InputError, match="table2.csv"):
        check_output_dir("--outdir", tmp_path, inputs={"dataset": tmp_path / "table2.csv"}, files=("table2.csv",))


def test_figure_folder_gets_the_figure_name(tmp_path):
    (tmp_path / "figs").mkdir()
    assert figure_stem(tmp_path / "figs", "fig2") == tmp_path / "figs" / "fig2"
    assert figure_stem(f"{tmp_path}/new/", "fig5") == tmp_path / "new" / "fig5"
    assert figure_stem(tmp_path / "fig2", "fig2") == tmp_path / "fig2"


@pytest.mark.parametrize("umask", [0o022, 0o077, 0o002])
def test_outputs_honour_the_umask(files, tmp_path, umask):
    old = os.umask(umask)
    try:
        assert cli("seed", "--n", "10", "-o", tmp_path / "p.h5")[0] == 0
        assert cli("export", tmp_path / "p.h5", "-o", tmp_path / "p.xyz")[0] == 0
    finally:
        os.umask(old)
    for name in ("p.h5", "p.xyz"):
        assert stat.S_IMODE((tmp_path / name).stat().st_mode) == 0o666 & ~umask


BAD_INPUT = [  # the tracebacks and endless runs, now one line and exit 2
    (["seed", "--n", "100000000000", "-o", "x.h5"], "--n"),
    (["seed", "--n", "10", "--seed", "18446744073709551616", "-o", "x.h5"], "--seed"),
    (["ls", "IN", "--rate", "0.1", "--events-per-particle", "1000000000000000000000", "-o", "x.h5"],
     "--events-per-particle"),
    (["mls", "IN", "--decrease-factor", "1e300", "-o", "x.h5"], "--decrease-factor"),
    (["browse", "NC", "--plot"], "--plot"),  # --plot needs --packing
    (["browse", "NC", "--figure", "fig2", "--packing", "ls/sigma0/rate1/r0"], "--figure"),
    (["render", "IN", "-o", "x.png", "--size", "100000"], "--size"),
    (["import", "DATA", "--box", "-1", "-o", "x.h5"], "--box"),
    (["mls", "IN", "--initial-rate", "1", "--final-rate", "5", "-o", "x.h5"], "--final-rate"),
    (["mls", "IN", "--final-rate", "1e-7", "--decrease-factor", "50", "-o", "x.h5"], "--decrease-factor"),
    (["analyze", "IN", "--pore-samples", "1000000000000000"], "--pore-samples"),
    (["check", "IN", "--tolerance", "-1"], "--tolerance"),
    (["ls", "IN", "--rate", "1e-300", "-o", "x.h5"], "--rate"),
    (["ls", "IN", "--rate", "0", "-o", "x.h5"], "--rate"),
    (["fb", "IN", "--rate", "1e-300", "-o", "x.h5"], "--rate"),
    (["ls", "IN", "--rate", "0.1", "--max-wall-time", "0", "-o", "x.h5"], "--max-wall-time"),
    (["fb", "IN", "--rate", "0.1", "--max-wall-time", "0", "-o", "x.h5"], "--max-wall-time"),
    (["ls", "IN", "--rate", "0.1", "--checkpoint-interval", "-1", "-o", "x.h5"], "--checkpoint-interval"),
    (["fb", "IN", "--rate", "0.1", "--progress-interval", "-1", "-o", "x.h5"], "--progress-interval"),
    (["manifest", "--config-json", "[1, 2]", "-o", "m.json"], "--config-json"),
    (["manifest", "--config-json", '{"n": -5, "seed": 1, "sigmas": [0], "ls": {"rates": [0.1]}, '
      '"fb": {"rates": [0.01]}}', "-o", "m.json"], "n=-5"),
    (["figure", "nofig", "NC", "-o", "f"], "nofig"),
]


@pytest.mark.parametrize("argv, needle", BAD_INPUT)
def test_bad_input_is_one_line_and_exit_2(files, tmp_path, monkeypatch, argv, needle):
    monkeypatch.chdir(tmp_path)
    code, err = cli(*[{"IN": files / "p.h5", "NC": files / "ds.nc", "DATA": files / "p.data"}.get(a, a) for a in argv])
    assert code == 2 and len(err) == 1 and needle in err[0], err
    assert list(tmp_path.iterdir()) == []


def test_intervals_zero_and_wall_time_agree_between_ls_and_fb():
    from spherejam.cli import build_parser

    parser = build_parser()
    for cmd in (["ls", "p.h5", "--rate", "0.1"], ["fb", "p.h5", "--rate", "0.1"]):
        args = parser.parse_args([*cmd, "-o", "x.h5", "--checkpoint-interval", "0", "--progress-interval", "0"])
        assert args.checkpoint_interval == 0 and args.progress_interval == 0


@pytest.mark.parametrize("content", ["{}", "[]", '{"provenance": {}}', '{"config": [1], "config_hash": "x"}',
                                     '{"config": {"n": 10}, "config_hash": "x"}', "NC"])
def test_dataset_on_a_foreign_manifest(files, tmp_path, content):
    path = files / "ds.nc" if content == "NC" else tmp_path / "m.json"
    if content != "NC":
        path.write_text(content)
    code, err = cli("dataset", path, "-o", tmp_path / "out.nc")
    assert code == 2 and len(err) == 1 and str(path.name) in err[0], err
    assert not (tmp_path / "out.nc").exists()


@pytest.mark.parametrize("argv", [["tables", "NC", "--outdir", "OUT"], ["figure", "fig2", "NC", "-o", "OUT/f"],
                                  ["browse", "NC"]])
def test_dataset_without_protocol_variable(files, tmp_path, argv):
    code, err = cli(*[{"NC": files / "ds.nc", "OUT": tmp_path / "t", "OUT/f": tmp_path / "f"}.get(a, a)
                      for a in argv])
    assert code == 2 and len(err) == 1 and "protocol" in err[0], err


def test_closed_pipe_exits_quietly(files):
    """``spherejam info … | head -1``: the reader leaves before the output; no BrokenPipeError traceback."""
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(sys.path)}
    proc = subprocess.Popen([sys.executable, "-m", "spherejam.cli", "info", "--json", str(files / "p.h5")],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, env=env)
    proc.stdout.close()  # before the interpreter has even started: every write hits a closed pipe
    err = proc.stderr.read().decode()
    assert proc.wait(timeout=60) == 141 and err == "", err
