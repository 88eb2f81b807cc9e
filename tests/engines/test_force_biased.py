"""The force-biased (FB) generator: physics of the forces, the run's guarantees, checkpoints and bad input."""

import math

import numpy as np
import pytest

from spherejam.cli import main
from spherejam.core import neighbours
from spherejam.core.errors import InputError, PackingFileError
from spherejam.core.packing import Packing
from spherejam.core.packing_io import read_packing, write_packing
from spherejam.core.seeding import poisson_packing
from spherejam.engines import force_biased as fb
from spherejam.engines.kernels import force_biased as kernels


def _same_run(a, b):
    """Bitwise-equal packings and histories (wall-clock columns aside)."""
    assert np.array_equal(a.packing.positions, b.packing.positions)
    assert np.array_equal(a.packing.diameters, b.packing.diameters)
    for key in a.history:
        if key != "wall_time":
            assert np.array_equal(a.history[key], b.history[key]), key


def _cube(box, dim=3):
    """The kernels' frame arrays (lengths, half, periodic) of the periodic cube of side ``box``."""
    frame = neighbours.Frame.of(box, dim)
    return frame.lengths, frame.half, frame.periodic


def test_nominal_density_rule_is_the_papers_line():
    assert fb.nominal_density_for_rate(1e-3) == pytest.approx(0.6, abs=1e-14)
    assert fb.nominal_density_for_rate(1e-7) == pytest.approx(0.7, abs=1e-14)
    assert fb.nominal_density_for_rate(1e-5) == pytest.approx(0.65, abs=1e-14)
    assert fb.nominal_density_for_rate(1e-1) == pytest.approx(0.55, abs=1e-14)  # extrapolated
    with pytest.raises(InputError, match="outside"):
        fb.nominal_density_for_rate(1e-30)  # the line passes phi = 1


def test_forces_match_brute_force_bezrukov(rng):
    n, box, rho_out = 60, 4.0, 1.05
    pos = rng.random((n, 3)) * box
    dia = rng.uniform(0.6, 1.4, n)
    ms = neighbours.cells_per_axis(box, rho_out * dia.max() + 0.3, n, 3)
    start, nbr = kernels.build_verlet(pos, dia, *_cube(box), rho_out, 0.3, ms, 64 * n)
    forces = np.empty_like(pos)
    h = kernels.forces(pos, dia, *_cube(box), rho_out, start, nbr, forces, np.empty(3), False)
    expected = np.zeros_like(pos)
    hmin = np.inf
    for i in range(n):
        for j in range(n):
            if i == j:
                continue
            d = pos[i] - pos[j]
            d -= box * np.round(d / box)
            r = np.linalg.norm(d)
            dij = 0.5 * (dia[i] + dia[j])
            hmin = min(hmin, r / dij)
            if r < rho_out * dij:
                expected[i] += dia[i] * dia[j] * (1 - r**2 / (rho_out * dij) ** 2) * d / r
    np.testing.assert_allclose(forces, expected, rtol=1e-12, atol=1e-12)
    assert h == pytest.approx(hmin, rel=1e-14)
    assert np.abs(forces.sum(axis=0)).max() < 1e-10  # Newton's third law


@pytest.mark.parametrize("box", [3.0, 12.0])  # small box: stencils wrap and need the minimum-image fold
def test_verlet_list_matches_brute_force(rng, box):
    n = 150
    pos = rng.random((n, 3)) * box
    dia = np.exp(rng.normal(0.0, 0.5, n))  # wide size ratio: large spheres scan wider stencils
    dia *= (0.5 * box**3 / n / (np.pi / 6 * np.mean(dia**3))) ** (1 / 3)
    rho_out, skin = 1.06, 0.2
    ms = neighbours.cells_per_axis(box, rho_out * np.quantile(dia, 0.5) + skin, n, 3)
    start, nbr = kernels.build_verlet(pos, dia, *_cube(box), rho_out, skin, ms, 4)  # tiny capacity: must overflow
    assert len(start) == 0
    start, nbr = kernels.build_verlet(pos, dia, *_cube(box), rho_out, skin, ms, 64 * n)
    got = {(i, int(j)) for i in range(n) for j in nbr[start[i]:start[i + 1]]}
    bi, bj, _ = neighbours.brute_force_pairs(pos, dia * rho_out, box, 1.0)  # within rho_out D_ij ...
    inner = set(zip(bi.tolist(), bj.tolist()))
    d = pos[:, None, :] - pos[None, :, :]
    d -= box * np.round(d / box)
    r = np.sqrt((d**2).sum(-1))
    cut = rho_out * 0.5 * (dia[:, None] + dia[None, :]) + skin
    expected = {(i, j) for i in range(n) for j in range(i + 1, n) if r[i, j] < cut[i, j]}
    assert got == expected and inner <= got
    for i in range(n):
        row = nbr[start[i]:start[i + 1]]
        assert np.all(np.diff(row) > 0) and np.all(row > i)


def test_move_wraps_any_displacement():
    pos = np.array([[0.1, 9.9, 5.0], [5.0, 5.0, 5.0]])
    forces = np.array([[-1234.5, 987.6, 1e6], [0.0, 0.0, -3e-17]])
    drift = np.zeros_like(pos)
    lengths, _, periodic = _cube(10.0)
    kernels.move(pos, np.ones(2), lengths, periodic, np.zeros(9), False, 0.5, forces, 1.0, drift)
    assert np.all(pos >= 0) and np.all(pos < 10.0)
    np.testing.assert_allclose(pos[0], np.mod([0.1 - 1234.5, 9.9 + 987.6, 5.0 + 1e6], 10.0), atol=1e-9)
    np.testing.assert_array_equal(drift, forces)


@pytest.mark.parametrize("sigma", [0.0, 0.3])
def test_finished_packing_is_overlap_free_and_jammed_near_phi_nominal(sigma):
    start = poisson_packing(500, sigma, seed=7)
    res = fb.run_fb(start, 1e-3)
    p = res.packing
    report = p.check(1e-10)
    assert report.ok and report.worst_overlap == pytest.approx(0.0, abs=1e-12)  # closest pair touches
    assert p.closest_pair()[2] == pytest.approx(1.0, abs=1e-12)
    c = res.stats
    assert c.stop_reason == "converged" and c.completed and c.extras.rho_outer <= c.extras.rho_inner
    assert p.phi == pytest.approx(c.phi_final, rel=1e-12)
    assert c.collisions is None and c.phi_initial == pytest.approx(h0 := res.history["phi_inner"][0]) and h0 < 0.1
    assert 0.57 < p.phi < 0.63  # the reference code: 0.599 (N=500 mono), 0.614 (N=1000, sigma=0.3)
    assert 80 < c.steps < 160  # ~ (rho_out0 - rho_final) / (0.3 ... 0.5 gamma)
    np.testing.assert_allclose(p.nominal_diameters, start.nominal_diameters, rtol=1e-12)
    np.testing.assert_array_equal(p.positions % p.box, p.positions)
    assert p.metadata["algorithm"] == "fb" and p.metadata["seed"] == 7
    prm = p.metadata["parameters"]
    assert prm["rate"] == 1e-3 and prm["phi_nominal"] == pytest.approx(0.6) and "paper" in prm["phi_nominal_rule"]
    h = res.history
    assert list(h["iteration"]) == list(range(c.steps + 1))
    assert np.all(np.diff(h["phi_outer"]) <= 0)  # the outer diameter only shrinks
    assert h["phi_outer"][0] == pytest.approx(1.2 * 0.6)
    assert h["max_overlap"][-1] <= 0 < h["max_overlap"][-2]
    assert h["phi_inner"][-1] == pytest.approx(p.phi, rel=1e-12)


def test_lower_rate_gives_higher_density():
    seeds = (1, 2, 3)
    mean = {}
    for rate in (1e-2, 1e-3):
        mean[rate] = np.mean([fb.run_fb(poisson_packing(500, 0.0, seed=s), rate, phi_nominal=0.6).packing.phi
                              for s in seeds])
    mean[3e-4] = np.mean([fb.run_fb(poisson_packing(500, 0.0, seed=s), 3e-4).packing.phi for s in seeds])
    assert mean[1e-2] + 0.05 < mean[1e-3] < mean[3e-4]  # reference code, N=1000: 0.498 and 0.598


def test_deterministic():
    start = poisson_packing(400, 0.2, seed=11)
    _same_run(fb.run_fb(start, 2e-3), fb.run_fb(start, 2e-3))


def test_checkpoint_resume_matches_uninterrupted_run(tmp_path):
    start = poisson_packing(400, 0.1, seed=5)
    full = fb.run_fb(start, 2e-3)
    ck = tmp_path / "fb.ck.h5"
    part = fb.run_fb(start, 2e-3, max_iterations=25, checkpoint=ck)
    assert part.stats.stop_reason == "max_iterations" and not part.stats.completed
    assert part.stats.steps == 25 and ck.exists()
    part.packing.validate()  # an interrupted run still returns an overlap-free packing
    with pytest.raises(PackingFileError, match="different input or parameters"):
        fb.run_fb(start, 1e-3, checkpoint=ck)
    with pytest.raises(PackingFileError, match="different input"):
        fb.run_fb(poisson_packing(400, 0.1, seed=6), 2e-3, checkpoint=ck)
    part2 = fb.run_fb(start, 2e-3, max_iterations=60, checkpoint=ck)  # resume, stop again
    assert part2.stats.steps == 60 and part2.stats.resumed
    resumed = fb.run_fb(start, 2e-3, checkpoint=ck)
    assert resumed.stats.completed and not ck.exists()
    _same_run(full, resumed)
    assert resumed.stats.steps == full.stats.steps


def test_already_dense_start_needs_no_iteration():
    dense = fb.run_fb(poisson_packing(300, 0.0, seed=2), 1e-2, phi_nominal=0.6).packing
    res = fb.run_fb(dense, 1e-3, phi_nominal=0.3)  # rho_in = (phi / 0.3)^(1/3) > 1.2^(1/3)
    assert res.stats.steps == 0
    assert res.packing.phi == pytest.approx(dense.phi, rel=1e-12)


def test_other_dimension_needs_explicit_phi_nominal():
    start = poisson_packing(300, 0.0, seed=4, dim=2)
    with pytest.raises(InputError, match="phi_nominal"):
        fb.run_fb(start, 1e-3)
    res = fb.run_fb(start, 1e-3, phi_nominal=0.8)
    assert res.packing.check(1e-10).ok and 0.7 < res.packing.phi < 0.85


def test_history_is_thinned_for_long_runs(monkeypatch):
    monkeypatch.setattr(fb, "MAX_HISTORY_ROWS", 8)
    res = fb.run_fb(poisson_packing(300, 0.0, seed=3), 1e-3)
    it = res.history["iteration"]
    n = res.stats.steps
    stride = res.stats.extras.history_stride
    assert stride >= 8 and len(it) < 2 * 8 + 2
    assert it[-1] == n and np.all(it[:-1] % stride == 0)


@pytest.mark.parametrize(
    "kwargs, field",
    [
        ({"rate": 0.0}, "rate"),
        ({"rate": 1.0}, "rate"),
        ({"rate": -1e-3}, "rate"),
        ({"rate": math.nan}, "rate"),
        ({"rate": "fast"}, "rate"),
        ({"rate": 1e-3, "phi_nominal": 0.0}, "phi_nominal"),
        ({"rate": 1e-3, "phi_nominal": 1.0}, "phi_nominal"),
        ({"rate": 1e-3, "phi_nominal": math.inf}, "phi_nominal"),
        ({"rate": 1e-3, "max_iterations": -1}, "max_iterations"),
        ({"rate": 1e-3, "checkpoint_interval": -1.0}, "checkpoint_interval"),  # 0 = every iteration, as in LS
        ({"rate": 1e-3, "max_wall_time": 0.0}, "max_wall_time"),  # as in LS: a limit of 0 s is no run
    ],
)
def test_bad_input_names_the_field(kwargs, field):
    start = poisson_packing(20, 0.0, seed=0)
    rate = kwargs.pop("rate")
    with pytest.raises(InputError, match=field):
        fb.run_fb(start, rate, **kwargs)


def test_too_few_spheres_or_no_packing():
    with pytest.raises(InputError, match="N=1"):
        Packing(np.zeros((1, 3)), np.ones(1), 5.0)  # a one-sphere Packing cannot even be built
    with pytest.raises(InputError, match="packing"):
        fb.run_fb(np.zeros((10, 3)), 1e-3)


def test_cli_fb(tmp_path, capsys):
    src = tmp_path / "start.h5"
    write_packing(src, poisson_packing(300, 0.0, seed=9))
    out = tmp_path / "fb.h5"
    assert main(["-q", "fb", str(src), "--rate", "1e-3", "-o", str(out)]) == 0
    packing, history = read_packing(out, with_history=True)
    assert packing.metadata["algorithm"] == "fb" and packing.metadata["seed"] == 9
    assert set(history) >= {"phi_inner", "phi_outer", "max_overlap", "wall_time"}
    ck = tmp_path / "ck.h5"
    assert main(["-q", "fb", str(src), "--rate", "1e-3", "-o", str(tmp_path / "b.h5"), "--max-iterations", "5",
                 "--checkpoint", str(ck)]) == 1
    # as calippso --max-iterations: the unfinished packing is written, marked so; the checkpoint is kept to continue
    assert ck.exists() and read_packing(tmp_path / "b.h5").metadata["counters"]["completed"] is False
    assert main(["-q", "fb", str(src), "--rate", "2", "-o", str(tmp_path / "c.h5")]) == 2
    assert "--rate: '2'" in capsys.readouterr().err  # refused by the option's limit (spherejam.core.validation)
