"""Tables 2-4 and the figures from a synthetic dataset with known answers."""

import json

import numpy as np
import pytest
import xarray as xr

from spherejam import figures
from spherejam.fits import design_matrix
from spherejam.tables import compute_tables, write_tables

GCP = {0.0: 0.65, 0.3: 0.678}
COEF = np.array([0.0, -0.05, 0.3, -1.2])


def synthetic_dataset():
    protocol, sigma, rate, phi, phi_j = [], [], [], [], []
    for p, rates in (("ls", np.geomspace(1e-4, 2.0, 30)), ("fb", np.geomspace(1e-7, 0.1, 30))):
        for s in (0.0, 0.3):
            for g in rates:
                curve = GCP[s] + design_matrix(np.array([g]))[0] @ COEF
                protocol.append(p), sigma.append(s), rate.append(g)
                phi.append(curve - 0.002)
                phi_j.append(curve)
    n = len(rate)
    config = {"n": 100, "sigmas": [0.0, 0.3], "fits": {"ls_initial": 10, "ls_densified": 10, "fb_initial": 10,
              "fb_densified": 10}, "fast": {"ls_max_inverse_rate": 5, "fb_max_inverse_rate": 1000}}
    ds = xr.Dataset(
        {"phi": ("packing", np.array(phi)), "phi_J": ("packing", np.array(phi_j)),
         "z_nonrattler": ("packing", np.full(n, 6.0))},
        coords={"protocol": ("packing", np.array(protocol)), "sigma": ("packing", np.array(sigma)),
                "rate": ("packing", np.array(rate)), "inverse_rate": ("packing", 1 / np.array(rate)),
                "replica": ("packing", np.zeros(n, int))},
        attrs={"config": json.dumps(config)},
    )
    return ds


def test_runs_cut_by_wall_time_are_left_out():
    ds = synthetic_dataset()
    fast_ls = (ds.protocol.values == "ls") & (ds.sigma.values == 0.3) & (ds.inverse_rate.values < 5)
    completed = np.ones(ds.sizes["packing"])
    worst = np.flatnonzero(fast_ls)[np.argmax(ds.phi_J.values[fast_ls])]
    completed[worst] = 0
    ds["mls_completed"] = ("packing", completed)
    t3 = compute_tables(ds)["table3"].set_index("sigma")
    assert t3.loc[0.3, "ls_n_fast"] == fast_ls.sum() - 1
    assert t3.loc[0.3, "ls_phi_max_fast"] < ds.phi_J.values[worst]


def test_tables_recover_known_values(tmp_path):
    ds = synthetic_dataset()
    t = compute_tables(ds)
    t2 = t["table2"]
    assert set(t2.sigma) == {0.3}  # sigma = 0 is not fitted
    dens = t2[t2.variable == "phi_J"].phi_gcp.values
    init = t2[t2.variable == "phi"].phi_gcp.values
    np.testing.assert_allclose(dens, GCP[0.3], atol=1e-9)
    np.testing.assert_allclose(init, GCP[0.3] - 0.002, atol=1e-9)
    t3 = t["table3"].set_index("sigma")
    ls_fast = ds.phi_J.values[(ds.protocol.values == "ls") & (ds.sigma.values == 0.3) & (ds.inverse_rate.values < 5)]
    assert t3.loc[0.3, "ls_phi_min_fast"] == ls_fast.min()
    assert t3.loc[0.3, "ls_phi_max_fast"] == ls_fast.max()
    t4 = t["table4"].set_index("sigma")
    assert t4.loc[0.0, "phi_GCP"] == 0.65
    assert t4.loc[0.3, "phi_GCP"] == pytest.approx(GCP[0.3] - 0.001, abs=1e-9)
    rcp = np.mean([t3.loc[0.3, "ls_phi_max_fast"], t3.loc[0.3, "fb_phi_max_fast"]])
    assert t4.loc[0.3, "phi_RCP"] == pytest.approx(rcp)
    paths = write_tables(ds, tmp_path)
    assert len(paths) == 9 and all(p.stat().st_size > 0 for p in paths)
    assert "\\begin{tabular}" in (tmp_path / "table2.tex").read_text()
    assert "± " in (tmp_path / "table2.md").read_text()


@pytest.mark.parametrize("name", sorted(figures.FIGURES))
def test_every_figure_draws(tmp_path, name):
    out = figures.save_figure(figures.draw(name, synthetic_dataset()), tmp_path / name)
    assert [p.suffix for p in out] == [".png", ".pdf"] and all(p.stat().st_size > 1000 for p in out)
