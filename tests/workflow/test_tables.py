"""Tables 2-4 and the figures from a synthetic dataset with known answers."""

import json

import numpy as np
import pytest
import xarray as xr

from spherejam.workflow import figures
from spherejam.workflow.fits import design_matrix
from spherejam.workflow.tables import compute_tables, write_tables

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
    assert len(paths) == 11 and all(p.stat().st_size > 0 for p in paths)
    assert "\\begin{tabular}" in (tmp_path / "table2.tex").read_text()
    assert "± " in (tmp_path / "table2.md").read_text()


@pytest.mark.parametrize("name", sorted(figures.FIGURES))
def test_every_figure_draws(tmp_path, name):
    out = figures.save_figure(figures.draw(name, synthetic_dataset()), tmp_path / name)
    assert [p.suffix for p in out] == [".png", ".pdf"] and all(p.stat().st_size > 1000 for p in out)


def _with_config(ds, **sections):
    cfg = json.loads(ds.attrs["config"])
    for key, value in sections.items():
        cfg[key] = {**cfg.get(key, {}), **value}
    ds.attrs["config"] = json.dumps(cfg)
    return ds


def test_fit_with_too_few_points_is_not_estimable(tmp_path):
    ds = _with_config(synthetic_dataset(), fits={"ls_initial": 6, "min_points": 8})
    t2 = compute_tables(ds)["table2"].set_index("curve")
    row = t2.loc["LS, initial"]
    assert not row.estimable and np.isnan(row.phi_gcp) and row.n_points == 6
    assert row.status.startswith("not estimable (n = 6")
    assert np.isfinite(row.phi_gcp_fit)  # the fit itself is kept for inspection, not reported
    assert t2.loc["FB, initial"].estimable  # 10 points
    write_tables(ds, tmp_path)
    assert "not estimable (n = 6" in (tmp_path / "table2.md").read_text()
    assert "not estimable (n = 6" in (tmp_path / "table2.tex").read_text()


def test_fit_with_a_wide_interval_is_not_estimable():
    ds = synthetic_dataset()
    rng = np.random.default_rng(0)
    ds["phi"] = ("packing", ds.phi.values + rng.normal(0, 0.02, ds.sizes["packing"]))
    t2 = compute_tables(_with_config(ds, fits={"max_half_width": 0.005}))["table2"].set_index("curve")
    row = t2.loc["LS, initial"]
    assert row.half_width_fit > 0.005 and not row.estimable and "half-width" in row.status
    relaxed = compute_tables(_with_config(ds, fits={"max_half_width": None}))["table2"].set_index("curve")
    assert relaxed.loc["LS, initial"].estimable


def test_paper_columns_and_gcp_below_rcp_flag(tmp_path):
    ds = synthetic_dataset()
    # push the fast phi_J of sigma = 0.3 above the GCP: too little data would look like this
    fast = (ds.sigma.values == 0.3) & (ds.inverse_rate.values < 5) & (ds.protocol.values == "ls")
    phi_j = ds.phi_J.values.copy()
    phi_j[fast] = 0.69
    ds["phi_J"] = ("packing", phi_j)
    t = compute_tables(ds)
    t4 = t["table4"].set_index("sigma")
    assert t4.loc[0.3, "gcp_below_rcp"] and not t4.loc[0.0, "gcp_below_rcp"]
    assert t4.loc[0.3, "phi_RCP_paper"] == 0.6676 and t4.loc[0.3, "phi_GCP_paper_derived"]
    assert t4.loc[0.3, "phi_RCP_minus_paper"] == pytest.approx(t4.loc[0.3, "phi_RCP"] - 0.6676)
    t2 = t["table2"].set_index("curve")
    assert t2.loc["LS, initial", "paper_phi_gcp"] == 0.6777
    assert t2.loc["LS, initial", "minus_paper"] == pytest.approx(t2.loc["LS, initial", "phi_gcp"] - 0.6777)
    ratio = t2.loc["LS, initial", "minus_paper_in_half_widths"]
    assert ratio == pytest.approx(t2.loc["LS, initial", "minus_paper"] / t2.loc["LS, initial", "half_width"])
    assert t2.gcp_below_rcp.all()
    write_tables(ds, tmp_path)
    comparison = (tmp_path / "comparison.md").read_text()
    assert "Flagged (φ_GCP < φ_RCP" in comparison and "Table 4 σ = 0.3" in comparison
    assert "φ_GCP < φ_RCP" in (tmp_path / "table4.md").read_text()
    for name in ("table2", "table3", "table4"):
        assert "paper" in (tmp_path / f"{name}.md").read_text() and "paper" in (tmp_path / f"{name}.tex").read_text()


def test_quantile_method_reports_the_alpha_quantile():
    ds = _with_config(synthetic_dataset(), bands={"method": "quantile", "alpha": 0.9})
    t3 = compute_tables(ds)["table3"].set_index("sigma")
    fb = np.sort(ds.phi_J.values[(ds.protocol.values == "fb") & (ds.sigma.values == 0.3)
                                 & (ds.inverse_rate.values < 1000)])
    assert len(fb) == 10
    assert t3.loc[0.3, "fb_phi_high"] == fb[8]  # ceil(0.9 * 10) = 9th value
    assert t3.loc[0.3, "fb_phi_low"] == fb[1]  # floor(0.1 * 10) + 1 = 2nd value
    assert t3.loc[0.3, "fb_phi_max_fast"] == fb[-1]


# --- issue 49: tables say what was taken rather than measured ----------------------------------------------------


def test_the_monodisperse_gcp_is_labelled_as_the_paper_s_with_no_difference():
    t = compute_tables(synthetic_dataset())
    mono = t["table4"].set_index("sigma").loc[0.0]
    assert mono.phi_GCP == 0.65 and mono.phi_GCP_source == "paper"
    assert np.isnan(mono.phi_GCP_minus_paper) and np.isnan(mono.phi_GCP_minus_paper_in_half_widths)
    assert t["table4"].set_index("sigma").loc[0.3, "phi_GCP_source"] == "measured"
    from spherejam.workflow.tables import TAKEN_FROM_PAPER, comparison, formatted

    cells = formatted("table4", t["table4"]).reset_index()
    gcp = cells[cells.quantity == "φ_GCP"].iloc[0]  # the rows run by sigma: sigma = 0 first
    assert gcp.ours == f"0.6500 ({TAKEN_FROM_PAPER})" and gcp["ours − paper"] == "–"
    assert gcp["(ours − paper) / half-width"] == "–"
    row = comparison(t).query("table == 'Table 4' and quantity == 'phi_GCP' and sigma == 0").iloc[0]
    assert row.note == TAKEN_FROM_PAPER and np.isnan(row.ours_minus_paper)


def test_no_slow_series_is_said_and_fast_packings_are_not_fitted():
    """LS with fast compressions only (1/gamma < 5, as the reproduction ladder at N = 500): its Table 2 cells say so
    and fit nothing; FB, with its slow series, is fitted as before."""
    ds = synthetic_dataset()
    keep = ~((ds.protocol.values == "ls") & (ds.inverse_rate.values >= 5))
    ds = ds.isel(packing=np.flatnonzero(keep))
    from spherejam.workflow.tables import NO_SLOW_SERIES, formatted

    t2 = compute_tables(ds)["table2"]
    ls = t2[t2.protocol == "ls"]
    assert len(ls) == 2 and (ls.status == NO_SLOW_SERIES).all() and (ls.n_points == 0).all()
    assert ls.phi_gcp.isna().all() and "c0" not in ls.dropna(axis=1).columns
    fb = t2[t2.protocol == "fb"]
    np.testing.assert_allclose(fb[fb.variable == "phi_J"].phi_gcp.values, GCP[0.3], atol=1e-9)
    cells = formatted("table2", t2)
    assert (cells["φ_GCP (ours)"] == NO_SLOW_SERIES).sum() == 2
