"""The paper's Tables 2-4 as shipped: hand-checked cells against the printed tables, and the derivation rules."""

import math

import pytest

from spherejam.workflow import paper_reference as ref


def test_table2_hand_checked_cells():
    t = ref.table2()
    assert set(t.columns) >= {"sigma", "method", "phi_GCP", "ci_half_width", "source"}
    assert len(t) == 4 * 6 and set(t.method) == set(ref.TABLE2_METHODS)
    cell = t[(t.sigma == 0.3) & (t.method == "LS, initial")].iloc[0]
    assert cell.phi_GCP == 0.6777 and cell.ci_half_width == pytest.approx(4.5487e-4, rel=0, abs=1e-12)
    cell = t[(t.sigma == 0.3) & (t.method == "FB, initial")].iloc[0]
    assert cell.phi_GCP == 0.6790 and cell.ci_half_width == pytest.approx(3.8918e-3, rel=0, abs=1e-12)
    cell = t[(t.sigma == 0.1) & (t.method == "FB, initial")].iloc[0]
    assert cell.phi_GCP == 0.6540
    cell = t[(t.sigma == 0.25) & (t.method == "FB, densified")].iloc[0]
    assert cell.phi_GCP == 0.6725 and cell.ci_half_width == pytest.approx(4.2419e-4, rel=0, abs=1e-12)
    assert "Table 2" in cell.source and "0.25" in cell.source


def test_table3_hand_checked_cells_and_lost_min_row():
    t = ref.table3()
    assert set(t.columns) >= {"sigma", "protocol", "phi_min", "phi_max", "source"}
    assert set(t.protocol) == {"LS", "FB"} and len(t) == 14
    ls = t[t.protocol == "LS"].set_index("sigma")
    fb = t[t.protocol == "FB"].set_index("sigma")
    assert ls.at[0.0, "phi_max"] == 0.6406 and fb.at[0.0, "phi_max"] == 0.6404
    assert ls.at[0.3, "phi_max"] == 0.6675 and fb.at[0.3, "phi_max"] == 0.6676
    assert ls.at[0.05, "phi_max"] == 0.6414 and fb.at[0.05, "phi_max"] == 0.6428
    assert t.phi_min.isna().all()  # the text keeps one phi_min row without saying which protocol
    m = ref.table3_min_unattributed().set_index("sigma")
    assert m.at[0.0, "phi_min"] == 0.6356 and m.at[0.3, "phi_min"] == 0.6593


def test_table4_printed_derived_and_missing_cells():
    t = ref.table4()
    assert t.index.name == "sigma" and list(t.index) == [0.0, 0.05, 0.1, 0.15, 0.2, 0.25, 0.3]
    assert t.at[0.0, "phi_LT"] == 0.6353 and t.at[0.0, "phi_RCP"] == 0.6405 and t.at[0.0, "phi_GCP"] == 0.65
    assert t.at[0.15, "phi_GCP"] == 0.6606 and not t.at[0.15, "phi_GCP_derived"]  # printed, kept as printed
    assert t.at[0.3, "phi_RCP"] == 0.6676 and not t.at[0.3, "phi_RCP_derived"]
    # lost GCP cells: mean of the four Table 2 entries (0.6777, 0.6790, 0.6786, 0.6787) / 4 = 0.6785
    assert t.at[0.3, "phi_GCP"] == pytest.approx(0.6785, abs=1e-12) and t.at[0.3, "phi_GCP_derived"]
    assert t.at[0.05, "phi_GCP"] == pytest.approx(0.652625, abs=1e-12) and t.at[0.05, "phi_GCP_derived"]
    # lost LT cells cannot be derived (one of the two Table 3 minima is lost)
    assert math.isnan(t.at[0.3, "phi_LT"]) and not t.at[0.3, "phi_LT_derived"]
    assert t.phi_GCP_derived.sum() == 4 and not t.phi_LT_derived.any() and not t.phi_RCP_derived.any()


def test_table4_rcp_is_the_rounded_mean_of_the_table3_maxima():
    """The paper's rule, checked on every printed phi_RCP cell (confirms the LS/FB pairing of Table 3)."""
    t3 = ref.table3()
    t4 = ref.table4()
    for sigma, rcp in t4.phi_RCP.items():
        mean = t3[t3.sigma == sigma].phi_max.mean()
        assert abs(mean - rcp) <= 0.5e-4 + 1e-12, sigma


def test_citation():
    assert "Baranau" in ref.CITATION and "3826" in ref.CITATION and "10.1039/c3sm52959b" in ref.CITATION
