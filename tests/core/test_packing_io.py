import os

import h5py
import numpy as np
import pytest

from spherejam import PackingFileError
from spherejam.core.packing import Packing
from spherejam.core.packing_io import export_xyz, read_packing, write_packing
from spherejam.core.seeding import poisson_packing


def test_round_trip_is_bitwise(tmp_path):
    p = poisson_packing(300, 0.2, seed=11)
    p.metadata.update(reduced_pressure=123.5, parameters={"sigma": 0.2, "x": [1, 2]}, counters={"collisions": 7})
    hist = {"phi": np.linspace(0, 1, 5), "pressure": np.arange(5.0)}
    write_packing(tmp_path / "a.h5", p, history=hist)
    q, h = read_packing(tmp_path / "a.h5", with_history=True)
    assert q.positions.tobytes() == p.positions.tobytes()
    assert q.diameters.tobytes() == p.diameters.tobytes()
    assert q.box == p.box
    assert q.metadata["parameters"] == {"sigma": 0.2, "x": [1, 2]}
    assert q.metadata["counters"] == {"collisions": 7}
    assert q.metadata["reduced_pressure"] == 123.5 and q.metadata["seed"] == 11
    assert q.metadata["provenance"]["spherejam_version"]
    np.testing.assert_array_equal(h["phi"], hist["phi"])
    with h5py.File(tmp_path / "a.h5") as f:
        assert f.attrs["phi"] == pytest.approx(p.phi)
        assert "git_commit" in f.attrs and "created" in f.attrs


def test_atomic_write_leaves_nothing_on_crash(tmp_path, monkeypatch):
    p = poisson_packing(50, 0.0, seed=1)
    target = tmp_path / "b.h5"

    def boom(*a, **k):
        raise RuntimeError("killed mid-write")

    monkeypatch.setattr("spherejam.core.packing_io.provenance", boom)
    with pytest.raises(RuntimeError):
        write_packing(target, p)
    assert not target.exists()
    assert os.listdir(tmp_path) == []


def test_overlapping_packing_is_never_written(tmp_path):
    pos = np.array([[1.0, 1.0, 1.0], [1.5, 1.0, 1.0]])
    with pytest.raises(Exception, match="overlap"):
        write_packing(tmp_path / "c.h5", Packing(pos, np.ones(2), 5.0))
    assert not (tmp_path / "c.h5").exists()


def test_truncated_and_garbage_files_give_clear_errors(tmp_path):
    p = poisson_packing(200, 0.0, seed=2)
    good = write_packing(tmp_path / "good.h5", p)
    data = good.read_bytes()
    (tmp_path / "trunc.h5").write_bytes(data[: len(data) // 2])
    (tmp_path / "text.h5").write_text("hello")
    for name in ("trunc.h5", "text.h5", "missing.h5"):
        with pytest.raises(PackingFileError, match=name):
            read_packing(tmp_path / name)


def _tamper(path, fn):
    with h5py.File(path, "r+") as f:
        fn(f)


@pytest.mark.parametrize(
    "fn, message",
    [
        (lambda f: f.__delitem__("diameters"), "missing dataset 'diameters'"),
        (lambda f: f.attrs.__setitem__("format", "other"), "not a spherejam packing"),
        (lambda f: f.attrs.__setitem__("box", -1.0), "box"),
        (lambda f: f["positions"].__setitem__((0, 0), np.nan), "NaN"),
        (lambda f: f["positions"].__setitem__((0, 0), 1e9), "outside the box"),
        (lambda f: f["positions"].__setitem__(1, f["positions"][0]), "overlap"),
        (lambda f: f.attrs.__setitem__("parameters", "{not json"), "JSON"),
    ],
)
def test_malformed_files(tmp_path, fn, message):
    path = write_packing(tmp_path / "m.h5", poisson_packing(100, 0.1, seed=5))
    _tamper(path, fn)
    with pytest.raises(PackingFileError, match=message):
        read_packing(path)


def test_export_xyz(tmp_path):
    p = poisson_packing(20, 0.3, seed=9)
    out = export_xyz(p, tmp_path / "p.xyz")
    lines = out.read_text().splitlines()
    assert lines[0] == "20" and "radius:R:1" in lines[1] and 'pbc="T T T"' in lines[1]
    vals = np.array([[float(v) for v in line.split()[1:]] for line in lines[2:]])
    np.testing.assert_array_equal(vals[:, :3], p.positions)
    np.testing.assert_array_equal(vals[:, 3], p.diameters / 2)
