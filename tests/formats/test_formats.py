"""Other codes' formats (spherejam.formats): round trips, a hand-written packing-generation file set, bad files."""

from __future__ import annotations

import math
import struct

import numpy as np
import pytest

from spherejam import formats
from spherejam.cli import main
from spherejam.core.packing import Packing
from spherejam.core.packing_io import read_packing, write_packing
from spherejam.core.seeding import poisson_packing


@pytest.fixture(scope="module")
def touching():
    """A polydisperse 3D packing whose closest pair touches (the hardest case for a lossy format)."""
    return poisson_packing(300, 0.2, seed=7)


def test_packing_generation_round_trip_is_exact(touching, tmp_path):
    written = formats.write(touching, tmp_path / "pg", "packing-generation")
    assert sorted(p.name for p in written) == ["generation.conf", "packing.nfo", "packing.xyzd"]
    back = formats.read(tmp_path / "pg" / "packing.xyzd")
    assert np.array_equal(back.positions, touching.positions)  # bitwise
    np.testing.assert_allclose(back.diameters, touching.diameters, rtol=1e-15, atol=0)
    assert back.box == touching.box
    assert back.metadata["source"]["scale"] == 1.0
    # the binary layout is the documented one: x y z d per sphere, little-endian float64, nothing else
    raw = (tmp_path / "pg" / "packing.xyzd").read_bytes()
    assert len(raw) == 32 * touching.n
    assert struct.unpack_from("<4d", raw, 32 * 5) == (*touching.positions[5], touching.diameters[5])


def _hand_written_set(folder, rng, n=200, box=9.0, scale_fraction=0.9):
    """A packing-generation file set written from the documented layout, as the C++ code leaves it after a run:
    centres final, diameters as at the start (relative sizes), final size in the porosities of packing.nfo."""
    positions = rng.uniform(0.0, box, size=(n, 3))
    stored = np.exp(rng.normal(0.0, 0.15, size=n))
    stored /= stored.mean()
    h_min = Packing(positions, stored, box).closest_pair()[2]
    scale = scale_fraction * h_min  # final diameters: no pair overlaps
    theoretical = 1.0 - float(np.sum(math.pi / 6.0 * stored**3)) / box**3
    final = 1.0 - scale**3 * (1.0 - theoretical)
    folder.mkdir()
    with open(folder / "packing.xyzd", "wb") as fh:
        for (x, y, z), d in zip(positions, stored):
            fh.write(struct.pack("<dddd", x, y, z, d))
    (folder / "generation.conf").write_text(
        f"Particles count: {n}\nPacking size: {box:.15g} {box:.15g} {box:.15g}\nGeneration start: 0\nSeed: 341\n"
        "Steps to write: 1000\nBoundaries mode: 1\nContraction rate: 1.328910e-005\n"
        "1. boundaries mode: 1 - bulk; 2 - ellipse (inscribed in XYZ box, Z is length of an ellipse); 3 - rectangle\n"
    )
    (folder / "packing.nfo").write_text(
        f"N: {n}\n Dimensions: {box:.15g} {box:.15g} {box:.15g}\n Theoretical Porosity: {theoretical:.15g}\n"
        f"Final Porosity: {final:.15g} (Tolerance: 1.000100)\nTotal Simulation Time: 122178.17\n"
        "Total Iterations: 39333\nRuns count: 1\n"
    )
    return positions, stored * scale, final


def test_hand_written_packing_generation_set_gets_final_diameters(tmp_path, rng, capsys):
    positions, final_diameters, final_porosity = _hand_written_set(tmp_path / "run", rng)
    out = tmp_path / "imported.h5"
    assert main(["import", str(tmp_path / "run"), "-o", str(out)]) == 0
    p = read_packing(out)
    assert np.array_equal(p.positions, positions)
    # the porosities carry 15 significant digits, so the recovered scale is good to ~1e-15
    np.testing.assert_allclose(p.diameters, final_diameters, rtol=1e-13, atol=0)
    assert p.phi == pytest.approx(1.0 - final_porosity, rel=1e-13)
    assert p.metadata["source"]["format"] == "packing-generation"
    assert str(out) in capsys.readouterr().out


def _one_line_error(capsys, argv, out, needles):
    code = main(argv)
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2
    assert len(err) == 1, err
    for needle in needles:
        assert needle in err[0], err[0]
    assert not out.exists() and not list(out.parent.glob(f".{out.name}*"))


@pytest.mark.parametrize("damage, needles", [
    ("truncated", ["packing.xyzd", "whole number of spheres"]),
    ("count", ["packing.xyzd", "Particles count 201"]),
    ("rescaled", ["packing.nfo", "Theoretical Porosity", "rescaled"]),
    ("box", ["packing.nfo", "Dimensions"]),
    ("nfo_n", ["packing.nfo", "N 199"]),
    ("not_bulk", ["generation.conf", "Boundaries mode"]),
    ("overlap", ["packing.xyzd", "FAIL"]),
])
def test_bad_packing_generation_sets_are_refused(tmp_path, rng, capsys, damage, needles):
    folder = tmp_path / "run"
    _hand_written_set(folder, rng, scale_fraction=1.2 if damage == "overlap" else 0.9)
    xyzd, nfo, conf = folder / "packing.xyzd", folder / "packing.nfo", folder / "generation.conf"
    if damage == "truncated":
        xyzd.write_bytes(xyzd.read_bytes()[:-8])
    elif damage == "count":
        conf.write_text(conf.read_text().replace("Particles count: 200", "Particles count: 201"))
    elif damage == "rescaled":  # the user scaled the stored diameters but kept the old nfo
        data = np.fromfile(xyzd, "<f8").reshape(-1, 4)
        data[:, 3] *= 0.95
        data.tofile(xyzd)
    elif damage == "box":
        nfo.write_text(nfo.read_text().replace(" Dimensions: 9 9 9", " Dimensions: 9 9 9.5"))
    elif damage == "nfo_n":
        nfo.write_text(nfo.read_text().replace("N: 200", "N: 199"))
    elif damage == "not_bulk":
        conf.write_text(conf.read_text().replace("Boundaries mode: 1", "Boundaries mode: 3"))
    _one_line_error(capsys, ["import", str(folder), "-o", str(tmp_path / "out.h5")], tmp_path / "out.h5", needles)


def test_calippso_jl_examples_layout(tmp_path):
    """The examples' layout: d, N, one diameter, centres (with trailing spaces); the box is the unit cube."""
    rng = np.random.default_rng(3)
    x = rng.uniform(0, 1, size=(40, 3))
    d = 0.9 * float(Packing(x, np.ones(40), 1.0).closest_pair()[2])
    path = tmp_path / "Centers.dat"
    path.write_text(f"3\n40\n{d!r}\n" + "".join(" ".join(repr(v) for v in row) + " \n" for row in x.tolist()))
    p = formats.read(path)
    assert np.array_equal(p.positions, x) and np.all(p.diameters == d) and p.box == 1.0


@pytest.mark.parametrize("sigma", [0.0, 0.2])
def test_calippso_jl_round_trip(tmp_path, sigma):
    start = poisson_packing(200, sigma, seed=11)
    path = formats.write(start, tmp_path / "p.dat", "calippso-jl")[0]
    lines = path.read_text().splitlines()
    assert lines[:2] == ["3", "200"]
    assert len(lines) == (203 if sigma == 0 else 202)  # a diameter line only when monodisperse
    back = formats.read(path)  # unit box, as the examples
    L = start.box
    assert back.box == 1.0 and back.phi == pytest.approx(start.phi, rel=1e-14)
    np.testing.assert_allclose(back.positions * L, start.positions, rtol=0, atol=4e-16 * L)
    np.testing.assert_allclose(back.diameters * L, start.diameters, rtol=1e-15)
    again = formats.read(path, box=L)  # or at the original scale
    assert again.box == L


def test_gsd_round_trip_and_hoomd_view(tmp_path, touching):
    import gsd.hoomd

    path = formats.write(touching, tmp_path / "p.gsd", "gsd")[0]
    back = formats.read(path)
    assert np.array_equal(back.positions, touching.positions) and np.array_equal(back.diameters, touching.diameters)
    assert back.box == touching.box and back.metadata["source"]["precision"] == "float64"
    with gsd.hoomd.open(path, "r") as traj:  # what HOOMD and OVITO see: one frame, centred float32 box
        assert len(traj) == 1
        frame = traj[0]
        L = touching.box
        np.testing.assert_allclose(frame.configuration.box, [L, L, L, 0, 0, 0], rtol=1e-7)
        np.testing.assert_allclose(frame.particles.position, touching.positions - L / 2, atol=1e-5 * L)
        np.testing.assert_allclose(frame.particles.diameter, touching.diameters, rtol=1e-7)


def test_gsd_from_hoomd_float32_only(tmp_path):
    """A HOOMD-written frame (float32, centred box, no spherejam chunks) imports at a tolerance it supports."""
    import gsd.hoomd

    start = poisson_packing(100, 0.0, seed=5)
    start = start.replace(diameters=0.999 * start.diameters)  # float32 round-off must not create overlaps
    L = start.box
    frame = gsd.hoomd.Frame()
    frame.particles.N = start.n
    frame.particles.position = (start.positions - L / 2).astype(np.float32)
    frame.particles.diameter = start.diameters.astype(np.float32)
    frame.configuration.box = [L, L, L, 0, 0, 0]
    with gsd.hoomd.open(tmp_path / "h.gsd", "w") as traj:
        traj.append(frame)
        traj.append(frame)
    back = formats.read(tmp_path / "h.gsd", tolerance=1e-6, frame=0)
    assert back.metadata["source"]["precision"] == "float32"
    np.testing.assert_allclose(back.positions, start.positions, atol=1e-5 * L)


def test_lammps_round_trip(tmp_path, touching):
    path = formats.write(touching, tmp_path / "p.data", "lammps")[0]
    text = path.read_text()
    assert "Atoms # sphere" in text and f"{touching.n} atoms" in text
    back = formats.read(path)
    assert np.array_equal(back.positions, touching.positions) and np.array_equal(back.diameters, touching.diameters)


def test_lammps_reader_takes_image_flags_shifted_box_and_shuffled_ids(tmp_path):
    x = np.array([[0.5, 0.5, 0.5], [2.5, 2.5, 2.5], [1.5, 0.2, 3.1]])
    rows = [f"{i} 1 1.0 2.0 {a - 1:.17g} {b - 1:.17g} {c - 1:.17g} 0 0 0" for i, (a, b, c) in zip((3, 1, 2), x)]
    (tmp_path / "in.data").write_text(
        "LAMMPS data file\n\n3 atoms\n1 atom types\n-1.0 3.0 xlo xhi\n-1.0 3.0 ylo yhi\n-1.0 3.0 zlo zhi\n"
        "\nMasses\n\n1 1.0\n\nAtoms # sphere\n\n" + "\n".join(rows) + "\n\nVelocities\n\n1 0 0 0\n"
    )
    p = formats.read(tmp_path / "in.data")
    assert p.box == 4.0
    np.testing.assert_allclose(p.positions, x[[1, 2, 0]], atol=1e-15)


BAD_FILES = {
    "calippso-jl": [
        ("p.dat", "3\n5\n0.1\n0.1 0.2 0.3\n", ["p.dat", "N=5"]),
        ("p.dat", "3\nfour\n0.1\n", ["p.dat", "line 2"]),
        ("p.dat", "3\n2\n0.5\n0.1 0.1 0.1\n0.2 0.1 0.1\n", ["p.dat", "FAIL"]),  # overlap
        ("p.dat", "3\n2\n0.1\n0.1 0.1\n0.5 0.5 0.5\n", ["p.dat", "line 4"]),
        ("p.dat", "3\n2\n0.1\n0.1 0.1 0.1\n0.5 0.5 1.5\n", ["p.dat", "outside the box"]),
    ],
    "lammps": [
        ("p.data", "x\n\n2 atoms\n0 4 xlo xhi\n0 4 ylo yhi\n0 4 zlo zhi\n\nAtoms # atomic\n\n1 1 0 0 0\n",
         ["p.data", "atom style"]),
        ("p.data", "x\n\n3 atoms\n0 4 xlo xhi\n0 4 ylo yhi\n0 4 zlo zhi\n\nAtoms # sphere\n\n1 1 1 1 1 1 1\n"
         "2 1 1 1 2 2 2\n", ["p.data", "holds 2 atoms"]),
        ("p.data", "x container={\"lengths\": [4, 4, 4], \"periodic\": [1, 1, 1], \"planes\": [0, 0, 0]}\n\n2 atoms\n"
         "0 4 xlo xhi\n0 4 ylo yhi\n0 5 zlo zhi\n\nAtoms\n\n1 1 1 1 1 1 1\n2 1 1 1 2 2 2\n",
         ["p.data", "not the frame of container"]),
        ("p.data", "x\n\n2 atoms\n0 4 xlo xhi\n0 4 ylo yhi\n0 4 zlo zhi\n\nAtoms\n\n1 1 1 1 1 1 1\n2 1 1 1 1.5 1 1\n",
         ["p.data", "FAIL"]),
    ],
    "gsd": [
        ("p.gsd", "not a gsd file\n", ["p.gsd", "not a readable GSD file"]),
    ],
}


@pytest.mark.parametrize("fmt, name, text, needles",
                         [(f, *case) for f, cases in BAD_FILES.items() for case in cases])
def test_bad_files_are_refused_in_one_line(tmp_path, capsys, fmt, name, text, needles):
    (tmp_path / name).write_text(text)
    out = tmp_path / "out.h5"
    _one_line_error(capsys, ["import", str(tmp_path / name), "--format", fmt, "-o", str(out)], out, needles)


def test_gsd_with_overlapping_exact_chunks_is_refused(tmp_path, capsys, touching):
    import gsd.hoomd

    path = formats.write(touching, tmp_path / "p.gsd", "gsd")[0]
    with gsd.hoomd.open(path, "r") as traj:
        frame = traj[0]
    frame.log["spherejam/position"][1] = frame.log["spherejam/position"][0]
    with gsd.hoomd.open(tmp_path / "bad.gsd", "w") as traj:
        traj.append(frame)
    out = tmp_path / "out.h5"
    _one_line_error(capsys, ["import", str(tmp_path / "bad.gsd"), "-o", str(out)], out, ["bad.gsd", "FAIL"])


def test_export_every_format_then_import_through_the_cli(tmp_path, capsys, touching):
    src = tmp_path / "p.h5"
    write_packing(src, touching)
    for fmt in ("packing-generation", "gsd", "lammps", "calippso-jl", "xyz"):
        assert main(["export", str(src), "--format", fmt]) == 0
    assert (tmp_path / "p-packing-generation" / "packing.nfo").exists() and (tmp_path / "p.xyz").exists()
    for name in ("p-packing-generation", "p.gsd", "p.data"):
        out = tmp_path / f"{name}.back.h5"
        assert main(["import", str(tmp_path / name), "-o", str(out)]) == 0
        assert np.array_equal(read_packing(out).positions, touching.positions)
    _one_line_error(capsys, ["import", str(src), "-o", str(tmp_path / "x.h5")], tmp_path / "x.h5", ["already"])
    _one_line_error(capsys, ["import", str(tmp_path / "p.xyz"), "-o", str(tmp_path / "z.h5")], tmp_path / "z.h5",
                    ["p.xyz", "--format"])
    _one_line_error(capsys, ["import", str(tmp_path / "p.data"), "--box", "2", "-o", str(tmp_path / "y.h5")],
                    tmp_path / "y.h5", ["--box"])


def test_containers_go_through_lammps_and_xyz_and_other_formats_refuse_them(tmp_path, capsys):
    """A packing in a container keeps it through a LAMMPS data file (title line; boundary and wall commands as
    comments), extended XYZ gives its frame and pbc flags, and a format that holds only a periodic cube refuses it
    in one line; a non-cubic LAMMPS box without a container is a periodic box with three edge lengths."""
    from spherejam.core.packing_io import read_packing, write_packing
    from spherejam.core.seeding import poisson_packing

    p = poisson_packing(200, sigma=0.3, seed=2, container="cylinder:diameter=6,capped=yes")
    write_packing(tmp_path / "c.h5", p)
    assert main(["export", str(tmp_path / "c.h5"), "--format", "lammps", "-o", str(tmp_path / "c.data")]) == 0
    text = (tmp_path / "c.data").read_text()
    assert "# boundary f f f" in text and "region tube cylinder z" in text and "wall/reflect zlo EDGE zhi EDGE" in text
    assert main(["import", str(tmp_path / "c.data"), "-o", str(tmp_path / "back.h5")]) == 0
    back = read_packing(tmp_path / "back.h5")
    assert back.container == p.container and np.array_equal(back.positions, p.positions)
    assert main(["export", str(tmp_path / "c.h5"), "-o", str(tmp_path / "c.xyz")]) == 0
    header = (tmp_path / "c.xyz").read_text().splitlines()[1]
    assert 'pbc="F F F"' in header and f"{p.container.lengths[2]!r}" in header and "container=cylinder" in header
    capsys.readouterr()
    for fmt in ("gsd", "packing-generation", "calippso-jl"):
        _one_line_error(capsys, ["export", str(tmp_path / "c.h5"), "--format", fmt, "-o", str(tmp_path / f"x-{fmt}")],
                        tmp_path / f"x-{fmt}", ["holds only a periodic cube", "cylinder"])
    (tmp_path / "b.data").write_text("x\n\n2 atoms\n0 4 xlo xhi\n0 4 ylo yhi\n0 5 zlo zhi\n\nAtoms\n\n"
                                     "1 1 1 1 1 1 1\n2 1 1 1 2 2 2\n")
    assert main(["import", str(tmp_path / "b.data"), "-o", str(tmp_path / "b.h5")]) == 0
    box = read_packing(tmp_path / "b.h5").container
    assert box.lengths == (4.0, 4.0, 5.0) and all(box.periodic) and not box.has_walls
