"""The reproduction ladder tracked in the repository (archive/reproduction/): it opens, it is the run it says it is
(N = 250, 500, 1000 at sigma = 0 and 0.3, every packing certified), its archived packings are jammed packings
without overlaps, and `spherejam browse` shows its tables, a packing and a figure without running anything."""

from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[2]
ARCHIVE = ROOT / "archive" / "reproduction"


@pytest.fixture(scope="module")
def archived():
    from spherejam.workflow.dataset import open_dataset

    return open_dataset(ARCHIVE / "dataset.nc")


def test_the_archive_is_the_whole_ladder_every_packing_certified(archived):
    ds = archived
    assert sorted({int(n) for n in ds["n"].values}) == [250, 500, 1000]
    assert sorted({str(d) for d in ds["distribution"].values}) == ["sigma0", "sigma0.3"]
    for n in (250, 500, 1000):
        for sigma in (0.0, 0.3):
            assert ((ds["n"].values == n) & (ds["sigma"].values == sigma)).sum() >= 32, (n, sigma)
    assert bool(ds["calippso_converged"].values.all()) and bool(ds["calippso_is_isostatic"].values.all())
    assert float(np.max(ds["calippso_force_balance_residual"].values)) < 1e-10
    # a jammed phi_J of a monodisperse packing lies below the crystal's and above random loose packing
    mono = ds["sigma"].values == 0.0
    assert 0.60 < float(ds["phi_J"].values[mono].min()) and float(ds["phi_J"].values[mono].max()) < 0.66
    readme = (ARCHIVE / "README.md").read_text()
    assert ds.attrs["config_hash"] in readme and ds.attrs["git_commit"].split(",")[0] in readme


def test_an_archived_packing_is_a_jammed_packing_without_overlaps(archived):
    from spherejam.core.packing_io import read_packing

    key = next(k for k in map(str, archived["key"].values) if k.startswith("n1000/ls/sigma0.3/"))
    packing = read_packing(ARCHIVE / "packings" / key / "jammed.h5")
    assert packing.n == 1000
    i = int(np.flatnonzero(archived["key"].values == key)[0])
    assert packing.phi == pytest.approx(float(archived["phi_J"].values[i]), abs=1e-9)
    # no two spheres overlap beyond round-off, and the contacts the dataset counts are in the file: the pairs
    # closer than the packing's contact tolerance
    from spherejam.core.neighbours import pairs_within

    d = packing.diameters
    i_, j_, r = pairs_within(packing.positions, d, packing.box, 1.01)
    gap = r / (0.5 * (d[i_] + d[j_])) - 1.0
    assert gap.min() > -1e-9
    assert (gap < float(archived["contact_tolerance"].values[i])).sum() == int(archived["n_contacts"].values[i])


def test_browse_shows_the_archive_s_tables_a_packing_and_a_figure(archived, tmp_path, capsys):
    from spherejam.cli import main

    assert main(["browse", str(ARCHIVE / "dataset.nc"), "--tables"]) == 0
    out = capsys.readouterr().out
    assert "10000 (extrapolated)" in out and "∞ (extrapolated)" in out
    key = str(archived["key"].values[0])
    assert main(["browse", str(ARCHIVE / "dataset.nc"), "--packing", key]) == 0
    assert str(ARCHIVE / "packings" / key / "jammed.h5") in capsys.readouterr().out
    assert main(["browse", str(ARCHIVE / "dataset.nc"), "--figure", "scaling", "-o", str(tmp_path / "scaling")]) == 0
    assert (tmp_path / "scaling.png").stat().st_size > 1000
