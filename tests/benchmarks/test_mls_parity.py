"""``benchmarks/mls_parity.py`` and its parts (``benchmarks/parity/``): the C++ input it writes, the log it parses,
how it cuts a search's history into MLS stages and decides why the search stopped, its tests, its locks."""

import importlib
import json
import math
import os
import sys
from pathlib import Path

import numpy as np
import pytest

from spherejam.core.seeding import poisson_packing
from spherejam.formats import packing_generation as pg

# the script imports its parts as the package `parity` from its own folder, as when it is run
_BENCHMARKS = str(Path(__file__).resolve().parents[2] / "benchmarks")
if _BENCHMARKS not in sys.path:
    sys.path.insert(0, _BENCHMARKS)
mp = importlib.import_module("mls_parity")
cpp = importlib.import_module("parity.cpp")
ours = importlib.import_module("parity.ours")
stages = importlib.import_module("parity.stages")
significance = importlib.import_module("parity.significance")
locks = importlib.import_module("parity.locks")


def test_cpp_input_has_our_nominal_diameters_and_the_mls_rates(tmp_path):
    start = poisson_packing(40, 0.3, seed=3)
    phi_nominal = cpp.write_cpp_input(start, tmp_path, seed=7, initial_rate=1e-2, factor=2.0, final_rate=1e-4)
    assert not (tmp_path / pg.NFO).exists()  # the code skips a folder that holds a packing.nfo
    data = np.fromfile(tmp_path / pg.XYZD, dtype="<f8").reshape(-1, 4)
    np.testing.assert_array_equal(data[:, :3], start.positions)
    np.testing.assert_allclose(data[:, 3], start.diameters / start.diameters.mean(), rtol=1e-15)
    assert data[:, 3].mean() == pytest.approx(1.0, rel=1e-14)
    # phi = phi_nominal * r^3 with r = the scale of the actual diameters over the nominal ones
    r = start.diameters.mean()
    assert phi_nominal * r**3 == pytest.approx(start.phi, rel=1e-12)
    conf = (tmp_path / pg.CONF).read_text().splitlines()
    # the code scans these lines in this order (fscanf), so the order is part of the format
    keys = [line.split(":")[0] for line in conf]
    assert keys == ["Particles count", "Packing size", "Generation start", "Seed", "Steps to write", "Boundaries mode",
                    "Contraction rate", "Generation mode", "Final contraction rate",
                    "Contraction rate decrease factor"]
    values = dict(line.split(": ", 1) for line in conf)
    assert values["Generation start"] == "0" and values["Seed"] == "7"
    assert float(values["Packing size"].split()[0]) == start.box  # full precision
    assert (float(values["Contraction rate"]), float(values["Final contraction rate"]),
            float(values["Contraction rate decrease factor"])) == (1e-2, 1e-4, 2.0)
    # our own reader of the format takes the file set (diameters as stored, i.e. nominal)
    back = pg.read(tmp_path, tolerance=None)
    np.testing.assert_array_equal(back.positions, start.positions)


def test_parse_cpp_log_reads_only_parity_lines():
    text = ("Time: 0.19, reduced pressure: 94.7, actual temperature: 0.25\n"
            "PARITY collisions 8601 rate 0.01 ratio 1.0005 pressure 94.7 time 0.19 cpu 0.1\n"
            "Suppress growth\n"
            "PARITY collisions 8700 rate 0 ratio 1.0005 pressure 9.9e11 time 1e-11 cpu 0.2\n")
    cols = cpp.parse_cpp_log(text, phi_nominal=0.6)
    assert cols["collisions"] == [8601, 8700]
    assert cols["rate"] == [0.01, 0.0]
    assert cols["pressure"] == [94.7, 9.9e11]
    assert cols["phi"] == pytest.approx([0.6 * 1.0005**3] * 2, rel=1e-15)
    assert cpp.parse_cpp_log("Time: 1, reduced pressure: 2\n", 0.6)["phi"] == []


def _history(rates, pressures):
    return {"rate": rates, "pressure": pressures, "phi": [0.6 + 1e-4 * k for k in range(len(rates))]}


def test_stages_and_unjamming():
    p = 1e12
    h = _history([1e-2, 1e-2, 0, 5e-3, 5e-3, 5e-3, 0, 2.5e-3],
                 [1e3, 2 * p, 0.9 * p, 1e4, 1e8, 2 * p, 0.5 * p, 2 * p])
    st = stages.stages(h)
    assert [(s["rate"], s["windows"]) for s in st] == [(1e-2, 2), (0, 1), (5e-3, 3), (0, 1), (2.5e-3, 1)]
    assert st[2]["p_min"] == 1e4 and st[2]["p_end"] == 2 * p
    f = stages.stage_figures({"history": h})
    assert f["compression_windows"] == [2, 3, 1]
    assert f["equilibration_windows"] == [1, 1]
    # the first compression (from the start packing) is not a re-compression; of the two others one unjams
    assert (f["unjammed"], f["recompressions"], f["stalled"]) == (1, 2, 0)


def test_stop_reason_and_cap():
    p = 1e12
    assert ours.stop_reason([1e-2, 0, 7.8125e-5], [2 * p, 0.5 * p, 2 * p], 1e-4) == "final_rate"
    assert ours.stop_reason([7.8125e-5], [0.5 * p], 1e-4) == "final_rate_stalled"
    assert ours.stop_reason([1e-2] + [0] * 50, [2 * p] * 51, 1e-4) == "jammed"
    assert ours.stop_reason([1e-2] + [0] * 49, [2 * p] * 50, 1e-4) == "unfinished"
    # at the cap: a search that met a rule keeps it, any other is capped and has no phi_J
    done = ours.classify({"collisions": 100, "stop": "final_rate", "phi_J": 0.63}, max_collisions=100)
    assert not done["capped"] and done["phi_J"] == 0.63
    cut = ours.classify({"collisions": 101, "stop": "final_rate_stalled", "phi_J": 0.63}, max_collisions=100)
    assert cut["capped"] and cut["stop"] == "capped" and cut["phi_J"] is None


def test_tests_need_enough_pairs():
    assert significance.tests([0.63] * 3, [0.64] * 3).startswith("not estimable (n = 3")
    rng = np.random.default_rng(0)
    a = list(0.63 + 0.002 * rng.standard_normal(12))
    line = significance.tests(a, [x + 0.01 for x in a])  # a clear shift: both tests must see it
    p_values = [float(part.split("p = ")[1].split()[0].rstrip(";")) for part in line.split("; ")[1:]]
    assert all(pv < 0.01 for pv in p_values) and math.isfinite(p_values[0])


def test_censored_comparisons_use_the_cap_as_a_bound():
    def run(phi, capped, collisions, phi_last=None):
        return {"phi_J": None if capped else phi, "capped": capped, "collisions": collisions,
                "history": {"phi": [0.60, phi_last if capped else phi]}}
    pairs = [
        (run(0.630, False, 10), run(0.640, False, 20)),         # both finished: ours lower, cheaper
        (run(0.630, False, 50), run(None, True, 40, 0.635)),    # C++ capped above ours: ours lower (phi_J_C++ >= 0.635)
        (run(0.640, False, 50), run(None, True, 40, 0.635)),    # C++ capped below ours: undecided
        (run(None, True, 90, 0.632), run(0.631, False, 30)),    # ours capped above the C++ phi_J: ours higher
    ]
    assert significance.censored_phi_sign_test(pairs).startswith(
        "ours lower in 2, higher in 1 of 3 decided pairs (1 undecided)")
    # cost: pair 2 and 3 are undecided (the capped C++ stopped below our count), pair 4 ours costlier
    assert significance.censored_sign_test(pairs).startswith(
        "ours needed fewer collisions in 1 of 2 decided pairs (2 undecided)")


def test_a_given_start_is_used_for_every_pair(tmp_path):
    """--start FILE: each pair searches from that packing; the pair seed changes only the velocities."""
    from spherejam.core.packing_io import write_packing

    start = poisson_packing(60, 0.0, seed=5)
    write_packing(tmp_path / "start.h5", start)
    mp.main(["--out", str(tmp_path / "out"), "--start", str(tmp_path / "start.h5"), "--codes", "ours",
             "--initial-rate", "1", "--final-rate", "0.1", "--max-collisions-per-particle", "200", "--seeds", "1", "2"])
    (cell,) = (tmp_path / "out").iterdir()
    assert cell.name.startswith("N60-start-")
    results = [json.loads((cell / f"pair-{s:04d}" / "ours.json").read_text()) for s in (1, 2)]
    assert [r["phi_start"] for r in results] == [pytest.approx(start.phi, rel=1e-12)] * 2
    assert results[0]["start_file"] == str(tmp_path / "start.h5")
    assert results[0]["collisions"] != results[1]["collisions"] or results[0]["phi_J"] != results[1]["phi_J"]


def test_a_pair_is_claimed_by_one_live_worker(tmp_path):
    """Two workers on overlapping seeds once corrupted a C++ log; the lock file lets only one of them run a search."""
    lock = tmp_path / "pair-0001" / "cpp.lock"
    assert locks.claim(lock)
    assert not locks.claim(lock)  # held by a live process (this one)
    lock.write_text("999999999")  # a worker that died
    assert locks.claim(lock)
    assert lock.read_text() == str(os.getpid())


def test_power_of_the_paired_t_test():
    # textbook value: one-sample/paired t, effect size 0.5, n = 20, two-sided alpha = 0.05 -> power 0.5645
    assert significance.paired_t_power(20, 1.0, 0.5) == pytest.approx(0.5645, abs=5e-4)
    assert significance.paired_t_power(12, 0.003, 0.0) == pytest.approx(0.05, abs=1e-9)  # no effect: the level
    # against simulation: the rejection rate of the t-test on normal differences with mean delta
    from scipy import stats

    n, sd, delta = 8, 0.002, 0.0015
    d = np.random.default_rng(4).normal(delta, sd, size=(20000, n))
    simulated = float(np.mean(stats.ttest_1samp(d, 0.0, axis=1).pvalue < 0.05))
    assert significance.paired_t_power(n, sd, delta) == pytest.approx(simulated, abs=0.015)
    # the detectable difference is where the power reaches 80 %, and it shrinks like 1/sqrt(n)
    m = significance.detectable_difference(20, 0.0036)
    assert significance.paired_t_power(20, 0.0036, m) == pytest.approx(0.8, abs=1e-6)
    assert significance.detectable_difference(80, 0.0036) == pytest.approx(m / 2, rel=0.05)


def _record(code, phi_j, cpu, collisions=1e8):
    return {"code": code, "phi_J": phi_j, "stop": "final_rate", "capped": False, "cpu_s": cpu,
            "collisions": collisions, "windows": 3, "max_collisions": 10**9, "phi_start": 0.62,
            "history": {"rate": [10.0, 0.0, 5.0], "pressure": [2e12, 5e11, 2e12], "phi": [0.64, 0.64, phi_j]}}


def _write_cell(folder, diffs, rng):
    for k, d in enumerate(diffs, start=1):
        pair = folder / f"pair-{k:04d}"
        pair.mkdir(parents=True)
        phi = 0.66 + 0.003 * rng.standard_normal()
        (pair / "ours.json").write_text(json.dumps(_record("ours", phi + d, 50.0)))
        (pair / "cpp.json").write_text(json.dumps(_record("cpp", phi, 300.0, 1.2e8)))


def test_summary_gives_paired_difference_interval_and_power(tmp_path, capsys):
    """Synthetic records with a known shift: the summary's interval is the t-interval of the differences, and too few
    pairs print "not estimable"."""
    from scipy import stats

    report = importlib.import_module("parity.report")
    rng = np.random.default_rng(7)
    diffs = 0.002 + 0.001 * rng.standard_normal(12)
    _write_cell(tmp_path / "out" / "N500-sigma0.3-ls0.5", diffs, rng)
    _write_cell(tmp_path / "out" / "N1000-sigma0.3-ls0.5", diffs[:4], rng)
    report.summarize(tmp_path / "out")
    text = capsys.readouterr().out
    big, small = text.split("## N500")[1], text.split("## N500")[0]
    line = next(x for x in big.splitlines() if x.startswith("- phi_J paired difference"))
    half = stats.t.ppf(0.975, 11) * diffs.std(ddof=1) / np.sqrt(12)
    assert f"ours - C++ = {diffs.mean():+.5f}" in line
    assert f"95 % CI [{diffs.mean() - half:+.5f}, {diffs.mean() + half:+.5f}]" in line
    assert f"Wilcoxon signed-rank p = {stats.wilcoxon(diffs).pvalue:.3g}" in line
    power = significance.paired_t_power(12, diffs.std(ddof=1), 1e-3)
    assert f"power to detect |diff| = 0.001: {power:.2f}" in line and 0.0 < power < 1.0
    assert "- speed ratio per search, C++ CPU / our CPU: median 6" in big
    assert "- phi_J paired difference: not estimable (n = 4" in small
    # the two cells of one protocol pooled: every complete pair of both, the same statistics
    pooled = text.split("## sigma0.3-ls0.5, pooled over N1000-sigma0.3-ls0.5, N500-sigma0.3-ls0.5")[1]
    both = np.concatenate([diffs, diffs[:4]])
    assert f"ours - C++ = {both.mean():+.5f}" in pooled and "(paired t, alpha = 0.05, n = 16)" in pooled


def test_compact_records_summarize_like_the_full_ones(tmp_path, capsys):
    """The committed records drop the per-window history; the summary from them is the same, capped searches too."""
    report = importlib.import_module("parity.report")
    rng = np.random.default_rng(3)
    out = tmp_path / "out" / "N500-sigma0.3-ls0.5"
    _write_cell(out, 0.001 * rng.standard_normal(6), rng)
    late = {"rate": [10.0, 0.0, 1.5e-4, 0.0, 7.6e-5], "pressure": [2e12, 5e11, 1e5, 5e11, 2e12],
            "phi": [0.64, 0.64, 0.65, 0.65, 0.6601]}
    capped = dict(_record("cpp", None, 900.0), capped=True, stop="capped", history=late)
    (out / "pair-0002" / "cpp.json").write_text(json.dumps(capped))
    report.summarize(tmp_path / "out")
    full = capsys.readouterr().out
    mp.main(["--out", str(tmp_path / "out"), "--export-records", str(tmp_path / "rec")])
    rec = json.loads((tmp_path / "rec" / out.name / "pair-0002" / "cpp.json").read_text())
    assert "history" not in rec and rec["phi_end"] == 0.6601 and len(rec["stages"]) == 5
    report.summarize(tmp_path / "rec")
    assert capsys.readouterr().out == full
    # the capped C++ search: phi at the cap bounds phi_J, its cut last stage is left out, its late stage unjammed
    assert "| ≥ 0.66010 | final_rate / capped |" in full and "| 0/1 / 1/1 |" in full
    assert "late stages (gamma <= 0.00032): 1 of 1 unjam" in full


def test_phi_check_finds_the_contact_scale_over_all_pairs():
    """The phi check of docs/mls_parity.md §6: the closest pair over all pairs, through the periodic boundary and
    between unequal spheres, sets the contact scale; a phi from unscaled nominal diameters is flagged."""
    phi_mod = importlib.import_module("mls_parity_phi")
    box = 10.0
    nominal = np.array([1.3, 0.7, 1.0, 1.0])
    # spheres 0 and 1 (D_01 = 1.0) 0.9 apart through the x boundary; 2 and 3 (D_23 = 1.0) 0.95 apart
    pos = np.array([[0.2, 5.0, 5.0], [9.3, 5.0, 5.0], [3.0, 2.0, 2.0], [3.0, 2.95, 2.0]])
    r, i, j = phi_mod.contact_ratio(pos, nominal, box)
    assert r == pytest.approx(0.9, rel=1e-12) and {i, j} == {0, 1}
    scale = 0.9 * 1.7  # actual diameters = 1.7 x nominal in other units: only D_i / mean(D) matters
    d = nominal * scale
    phi_true = float(np.sum(np.pi / 6 * (0.9 * nominal) ** 3) / box**3)
    ok = phi_mod.phi_check(pos, d, box, phi_true)
    assert abs(ok["relative_difference"]) < 1e-12
    bad = phi_mod.phi_check(pos, d, box, float(np.sum(np.pi / 6 * nominal**3) / box**3))
    assert bad["relative_difference"] == pytest.approx(1 / 0.9**3 - 1, rel=1e-9)
