"""`spherejam seed --psd` and `spherejam psd`: outputs, provenance, one-line errors with nothing written."""

import json

import numpy as np
import pytest

from spherejam.cli import main
from spherejam.core.packing_io import read_packing
from spherejam.core.seeding import poisson_packing


def test_seed_psd_records_distribution_and_sample(tmp_path):
    out = tmp_path / "p.h5"
    assert main(["seed", "--n", "300", "--psd", "bidisperse:ratio=1.4,small=0.5,by=number", "--seed", "3",
                 "-o", str(out)]) == 0
    p = read_packing(out)
    sd = p.metadata["size_distribution"]
    assert sd["spec"] == "bidisperse:ratio=1.4,small=0.5,by=number" and sd["family"] == "bidisperse"
    assert sd["sample"]["size_ratio"] == pytest.approx(1.4)
    assert sd["sample"]["delta"] == pytest.approx(p.polydispersity, abs=1e-12)
    assert p.metadata["parameters"]["psd"] == sd["spec"]


def test_sigma_is_shorthand_for_lognormal(tmp_path):
    a, b = tmp_path / "a.h5", tmp_path / "b.h5"
    assert main(["seed", "--n", "200", "--sigma", "0.2", "--seed", "9", "-o", str(a)]) == 0
    assert main(["seed", "--n", "200", "--psd", "lognormal:sigma=0.2", "--seed", "9", "-o", str(b)]) == 0
    pa, pb = read_packing(a), read_packing(b)
    np.testing.assert_array_equal(pa.positions, pb.positions)
    np.testing.assert_array_equal(pa.diameters, pb.diameters)
    ref = poisson_packing(200, 0.2, 9)
    np.testing.assert_array_equal(pa.diameters, ref.diameters)


def test_list_gives_n(tmp_path):
    lst = tmp_path / "d.txt"
    lst.write_text("\n".join(["1.0", "1.2", "0.8"] * 10) + "\n")
    out = tmp_path / "p.h5"
    assert main(["seed", "--psd", f"list:{lst}", "-o", str(out)]) == 0
    p = read_packing(out)
    assert p.n == 30 and p.metadata["size_distribution"]["sha256"]


@pytest.mark.parametrize("args, needle", [
    (["seed", "--n", "50", "--psd", "gaussian:delta=-1"], "gaussian.delta=-1.0"),
    (["seed", "--n", "50", "--psd", "weibull:k=2"], "unknown family 'weibull'"),
    (["seed", "--n", "50", "--psd", "bidisperse:ratio=2,small=0.3"], "bidisperse.by missing"),
    (["seed", "--psd", "gaussian:delta=0.1"], "--n: required"),
    (["seed", "--n", "50", "--sigma", "0.1", "--psd", "gaussian:delta=0.1"], "not allowed with"),
    (["seed", "--n", "50", "--psd", "table:missing.csv"], "not found"),
    (["psd", "uniform:ratio=nan"], "uniform.ratio='nan'"),
])
def test_bad_psd_one_line_exit_2_nothing_written(tmp_path, capsys, args, needle):
    out = tmp_path / "x.h5"
    code = main([*args, *(["-o", str(out)] if args[0] == "seed" else [])])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(err) == 1 and needle in err[0], err
    assert not out.exists() and list(tmp_path.iterdir()) == []


def test_list_n_disagrees(tmp_path, capsys):
    lst = tmp_path / "d.txt"
    lst.write_text("1\n2\n3\n")
    assert main(["seed", "--n", "4", "--psd", f"list:{lst}", "-o", str(tmp_path / "x.h5")]) == 2
    assert "--n=4: list:" in capsys.readouterr().err and not (tmp_path / "x.h5").exists()


def test_psd_command_json(capsys):
    assert main(["psd", "gaussian:delta=0.2", "--n", "500", "--phi-mono", "0.64", "--json"]) == 0
    info = json.loads(capsys.readouterr().out)
    assert info["population"]["delta"] == pytest.approx(0.2, abs=1e-5)
    assert info["sample"]["n"] == 500 and info["sample"]["box_over_dmax"] > 2.5
    models = {m["model"]: m["phi_rcp"] for m in info["models"]}
    assert models["desmond_weeks"] == pytest.approx(0.634 + 0.0658 * 0.2, abs=1e-5)
    assert set(models) == {"farr_groot", "desmond_weeks", "santos"}


def test_psd_command_reports_the_box_and_no_calippso_limit(capsys):
    """A box under two largest diameters is no longer a limit: CALiPPSO has a row per periodic image (issue 35)."""
    assert main(["psd", "bidisperse:ratio=4,small=0.3,by=volume", "--n", "40"]) == 0
    out = capsys.readouterr().out
    box = float(out.split("mean diameters = ")[1].split(" d_max")[0])
    assert box < 2.0 and "CALiPPSO" not in out


def test_box_is_checked_at_the_distributions_jamming_density(capsys):
    """The box is reported at the density the packings jam at, the distribution's Farr-Groot phi_RCP (at least 0.64):
    a 1:4 mixture at N = 200 has L = 2.02 d_max at phi = 0.64, but jams well above it, where its box is smaller."""
    from spherejam.analysis.farr_groot import phi_rcp_distribution
    from spherejam.core.size_distribution import parse

    spec = "bidisperse:ratio=4,small=0.3,by=volume"
    assert main(["psd", spec, "--n", "200", "--json"]) == 0
    sample = json.loads(capsys.readouterr().out)["sample"]
    assert sample["box_at_phi"] == pytest.approx(phi_rcp_distribution(parse(spec))) and sample["box_at_phi"] > 0.7
    assert sample["box_over_dmax"] < 2 < sample["box_over_dmax"] * (sample["box_at_phi"] / 0.64) ** (1 / 3)
    assert main(["psd", "lognormal:sigma=0", "--n", "200", "--json"]) == 0  # never below 0.64
    assert json.loads(capsys.readouterr().out)["sample"]["box_at_phi"] == pytest.approx(0.6435, abs=1e-3)
