"""The flat analysis record (analysis/structure.py) and `spherejam analyze`."""

import math

import pytest

from spherejam.analysis import structure
from spherejam.analysis.bond_order import steinhardt
from spherejam.analysis.pore_size import pore_size_entropy
from spherejam.analysis.voronoi import voronoi_volumes
from spherejam.core.errors import InputError
from spherejam.core.seeding import poisson_packing


def test_analyze_returns_every_variable(fcc):
    p = fcc(3)
    p.metadata["reduced_pressure"] = 1e12
    out = structure.analyze(p, pore_samples=10_000)
    assert list(out) == list(structure.VARIABLES)
    assert out["z_nonrattler"] == 12.0 and out["q6_local"] == steinhardt(p)[1]
    assert out["crystalline_fraction"] == 1.0
    assert all(isinstance(v, float) for v in out.values())
    assert all(len(v) == 2 and v[1] == "1" for v in structure.VARIABLES.values())
    q = poisson_packing(200, 0.1, 1, dim=4)
    out4 = structure.analyze(q, pore_samples=10_000)
    assert math.isnan(out4["q6_global"]) and math.isnan(out4["voronoi_entropy"])
    assert math.isnan(out4["crystalline_fraction"])
    assert math.isfinite(out4["pore_size_entropy"])
    with pytest.raises(InputError, match="d=4"):
        voronoi_volumes(q)
    with pytest.raises(InputError, match="pore_samples"):
        pore_size_entropy(p, samples=0)


def test_cli_analyze_writes_the_variables(tmp_path, capsys, fcc):
    import json

    from spherejam.cli import main
    from spherejam.core.packing_io import write_packing

    path = tmp_path / "fcc.h5"
    write_packing(path, fcc(3))
    out = tmp_path / "s.json"
    assert main(["analyze", str(path), "--json", "--pore-samples", "1000", "-o", str(out), "--scan"]) == 0
    record = json.loads(out.read_text())
    assert json.loads(capsys.readouterr().out) == record
    assert set(structure.VARIABLES) <= set(record) and record["z_nonrattler"] == 12.0
    assert record["pore_size_entropy"] is None  # -inf (no large pore) is not JSON
    assert all(z == 12.0 for z in record["tolerance_scan"]["z_nonrattler"])
    assert main(["analyze", str(path), "--contact-tolerance", "2"]) == 2
