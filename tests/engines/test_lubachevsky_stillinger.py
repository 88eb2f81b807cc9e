"""Lubachevsky–Stillinger engine: kinematics, conservation laws, equation of state, jamming, determinism, resume."""

import math

import numpy as np
import pytest

from packings import Killed, kill_at
from spherejam.core.errors import InputError
from spherejam.core.packing import Packing
from spherejam.core.seeding import poisson_packing
from spherejam.engines.event_driven import LSEngine
from spherejam.engines.kernels import event_driven as ed
from spherejam.engines.lubachevsky_stillinger import maxwell_velocities, run_ls

T = 0.2


def _engine_for(packing, gamma, seed=0):
    nominal = packing.diameters / packing.diameters.mean()
    rho = float(np.min(_pair_ratios(packing.positions, nominal, packing.box)))
    v = maxwell_velocities(packing.n, T, np.random.default_rng(seed))
    return LSEngine.start(packing.positions, nominal, packing.box, rho, v, gamma, T)


def _pair_ratios(pos, nominal, box):
    d = pos[:, None, :] - pos[None, :, :]
    d -= box * np.round(d / box)
    r = np.sqrt((d * d).sum(-1))
    s = 0.5 * (nominal[:, None] + nominal[None, :])
    iu = np.triu_indices(len(pos), 1)
    return (r / s)[iu]


# --- two-body kinematics -----------------------------------------------------------------------------------------


def test_collision_delay_matches_the_contact_equation(rng):
    """The returned root solves |r + u tau| = sig (rho + gamma tau), and the pair is apart before it."""
    hits = 0
    samples = np.linspace(0.0, 50.0, 20001)
    for _ in range(1500):
        r = rng.normal(size=3) * 2.0
        u = rng.normal(size=3)
        sig, rho, gamma = rng.uniform(0.5, 2.0), rng.uniform(0.1, 0.5), rng.choice([0.0, 0.01, 0.3, 3.0])
        if np.dot(r, r) <= (sig * rho) ** 2:
            continue
        tau = ed.collision_delay(*r, *u, sig, rho, gamma)

        def gap(s, r=r, u=u, sig=sig, rho=rho, gamma=gamma):
            s = np.atleast_1d(s)
            return np.linalg.norm(r + u * s[:, None], axis=1) - sig * (rho + gamma * s)

        if math.isinf(tau):
            assert np.all(gap(samples) > 0)
            continue
        hits += 1
        assert abs(gap(tau)[0]) < 1e-9 * (1 + tau)
        assert np.all(gap(np.linspace(0.0, tau, 200)[:-1]) > -1e-12)
    assert hits > 200


def test_two_body_head_on_collision_with_growth():
    """Head-on pair: contact at tau = (d0 - rho0 sig)/(2 v + gamma sig); each bounces out at v + gamma sig / 2 * 2."""
    v, gamma, rho0, d0, box = 0.3, 0.05, 1.0, 3.0, 40.0
    pos = np.array([[10.0, 10.0, 10.0], [10.0 + d0, 10.0, 10.0]])
    vel = np.array([[v, 0.0, 0.0], [-v, 0.0, 0.0]])
    e = LSEngine.start(pos, np.ones(2), box, rho0, vel, gamma, T)
    stats = e.window(1, count_collisions=True)
    tau = (d0 - rho0) / (2 * v + gamma)
    assert stats.collisions == 1
    assert stats.duration == pytest.approx(tau, rel=1e-12)
    assert e.rho0 == pytest.approx(rho0 + gamma * tau, rel=1e-14)
    # contact: centre distance equals the grown diameter
    dist = e.positions[1, 0] - e.positions[0, 0]
    assert dist == pytest.approx(e.rho0, rel=1e-12)
    # w' - g = -(w - g): each sphere leaves with speed v + gamma (along the line of centres), before the thermostat
    e_before = 2 * 0.5 * (v + gamma) ** 2
    assert stats.temperature == pytest.approx(2 * e_before / 6, rel=1e-12)
    vel_after = e.velocities
    assert vel_after[0, 0] < 0 < vel_after[1, 0]
    assert np.allclose(vel_after[:, 1:], 0.0)
    assert vel_after[0, 0] == pytest.approx(-vel_after[1, 0], rel=1e-14)
    # virial: X = (v1.n - v2.n) |r| with pre-collision velocities
    x = 2 * v * (rho0 + gamma * tau)
    assert stats.pressure == pytest.approx(1 + x / (2 * e_before * tau), rel=1e-12)


def test_oblique_collision_conserves_momentum_and_tangential_velocity(rng):
    gamma, box = 0.2, 40.0
    pos = np.array([[10.0, 10.0, 10.0], [12.0, 10.7, 9.8]])
    vel = np.array([[0.4, 0.1, -0.05], [-0.3, -0.2, 0.1]])
    e = LSEngine.start(pos, np.array([1.0, 1.5]), box, 0.9, vel, gamma, T)
    p0 = vel.sum(axis=0)
    # replay the collision time and contact normal independently
    r = pos[1] - pos[0]
    u = vel[1] - vel[0]
    tau = ed.collision_delay(*r, *u, 1.25, 0.9, gamma)
    n = (r + u * tau) / np.linalg.norm(r + u * tau)
    stats = e.window(1, count_collisions=True)
    assert stats.duration == pytest.approx(tau, rel=1e-12)
    scale = math.sqrt(stats.temperature / T)  # undo the thermostat
    v_after = e.velocities * scale
    assert np.allclose(v_after.sum(axis=0), p0, atol=1e-12)
    g = gamma * 1.25
    w_before = np.dot(u, n)
    w_after = np.dot(v_after[1] - v_after[0], n)
    assert w_after - g == pytest.approx(-(w_before - g), rel=1e-12)
    for k in range(2):  # tangential components unchanged
        t_before = vel[k] - np.dot(vel[k], n) * n
        t_after = v_after[k] - np.dot(v_after[k], n) * n
        assert np.allclose(t_before, t_after, atol=1e-12)


# --- many-body physics -------------------------------------------------------------------------------------------


def _fluid(n, phi, seed):
    packing = poisson_packing(n, 0.0, seed=seed)
    return run_ls(packing, 0.1, seed=seed, target_phi=phi, progress_interval=1e9).packing


@pytest.mark.parametrize("speed", [1.0, 1e-3, 1e-100, 1e-162, 1e-200, 1e-300])
def test_skin_exit_delay_solves_the_sphere_equation_at_any_speed(rng, speed):
    """|d + v tau| = h with tau > 0 from inside the skin sphere, down to speeds whose |v|^2 underflows."""
    h = 0.1
    for k in range(200):
        d = np.zeros(3) if k == 0 else rng.uniform(-1, 1, 3) * h / 2  # d = 0: just after a list update
        u = rng.normal(size=3)
        u /= np.linalg.norm(u)
        tau = ed.skin_exit_delay(*d, *(u * speed), h)
        assert 0 < tau < math.inf
        assert np.linalg.norm(d + u * (speed * tau)) == pytest.approx(h, rel=1e-12)


def test_a_rattler_slowed_by_the_thermostat_does_not_stall_the_window():
    """A particle at |v| = 1e-162 (what fast MLS stages leave of a rattler) must not produce zero-time windows."""
    fluid = _fluid(300, 0.35, seed=4)
    e = _engine_for(fluid, 0.0)
    e.state.st[7, 3:6] = np.array([2.6, -0.7, 1.2]) * 1e-162
    stats = e.window(20 * fluid.n)
    assert stats.duration > 0 and math.isfinite(stats.pressure)
    assert stats.collisions > 5 * fluid.n  # a real window, not a loop of skin events


def test_energy_and_momentum_conserved_at_zero_rate():
    fluid = _fluid(300, 0.35, seed=4)
    e = _engine_for(fluid, 0.0)
    for _ in range(5):
        stats = e.window(20 * fluid.n)
        assert stats.collisions > 5 * fluid.n
        # end-of-window temperature is measured before the thermostat: elastic collisions keep it exactly
        assert stats.temperature == pytest.approx(T, rel=1e-11)
        assert np.allclose(e.velocities.sum(axis=0), 0.0, atol=1e-11)
    assert e.rho0 == pytest.approx(_engine_for(fluid, 0.0).rho0, rel=0, abs=0)


def carnahan_starling(phi):
    return (1 + phi + phi**2 - phi**3) / (1 - phi) ** 3


@pytest.mark.parametrize("phi", [0.30, 0.45])
def test_equilibrium_pressure_matches_carnahan_starling(phi):
    n = 1000
    fluid = _fluid(n, phi, seed=11)
    e = _engine_for(fluid, 0.0, seed=2)
    for _ in range(5):  # equilibrate 100 events per particle
        e.window(20 * n)
    pressures = [e.window(20 * n).pressure for _ in range(30)]
    mean = float(np.mean(pressures))
    sem = float(np.std(pressures, ddof=1) / math.sqrt(len(pressures)))
    assert sem < 0.004 * mean  # statistically meaningful at the 2 % level
    assert mean == pytest.approx(carnahan_starling(phi), rel=0.02)


@pytest.mark.parametrize("sigma", [0.0, 0.3])
def test_poisson_start_jams_without_overlap(sigma):
    packing = poisson_packing(1000, sigma, seed=21)
    assert packing.phi < 1e-3
    result = run_ls(packing, 0.1, seed=5, progress_interval=1e9)
    out = result.packing
    assert result.stats.stop_reason == "p_max"
    assert out.metadata["reduced_pressure"] >= 1e12
    assert out.check(1e-10).ok
    assert out.min_gap() > -1e-10
    assert out.min_gap() < 1e-9  # jammed: the closest pair touches
    h = result.history
    assert np.all(np.diff(h["phi"]) >= 0)
    assert h["pressure"][-1] >= 1e12 > h["pressure"][-2]
    assert result.stats.collisions == h["collisions"].sum()
    if sigma == 0.0:
        assert 0.60 <= out.phi <= 0.65
    else:
        assert 0.62 <= out.phi <= 0.70
    assert out.metadata["algorithm"] == "ls"
    assert out.metadata["parameters"]["input_seed"] == 21


def test_extreme_size_ratio_stays_exact():
    """Size ratio > 1:10 from a dilute start: neighbour lists sized by actual diameters miss nothing."""
    packing = poisson_packing(2000, 0.5, seed=5)
    assert packing.diameters.max() / packing.diameters.min() > 10
    result = run_ls(packing, 0.5, seed=1, progress_interval=1e9)
    assert result.packing.check(1e-10).ok
    assert result.stats.stop_reason == "p_max"
    assert result.packing.phi > 0.62


def test_target_phi_and_max_collisions_stop():
    packing = poisson_packing(200, 0.1, seed=8)
    r = run_ls(packing, 0.2, seed=1, target_phi=0.4, progress_interval=1e9)
    assert r.stats.stop_reason == "target_phi"
    assert r.packing.phi == pytest.approx(0.4, rel=1e-9)
    r = run_ls(packing, 0.001, seed=1, max_collisions=5000, progress_interval=1e9)
    assert r.stats.stop_reason == "max_collisions"
    assert r.stats.collisions >= 5000


def test_same_seed_same_result_and_seed_matters():
    packing = poisson_packing(300, 0.2, seed=2)
    a = run_ls(packing, 0.2, seed=9, progress_interval=1e9)
    b = run_ls(packing, 0.2, seed=9, progress_interval=1e9)
    c = run_ls(packing, 0.2, seed=10, progress_interval=1e9)
    assert np.array_equal(a.packing.positions, b.packing.positions)
    assert np.array_equal(a.packing.diameters, b.packing.diameters)
    assert np.array_equal(a.history["pressure"], b.history["pressure"])
    assert not np.array_equal(a.packing.positions, c.packing.positions)


def test_checkpoint_resume_finishes_identically(tmp_path):
    packing = poisson_packing(300, 0.0, seed=3)
    reference = run_ls(packing, 0.05, seed=4, progress_interval=1e9)
    ckpt = tmp_path / "ls.ckpt.h5"

    with pytest.raises(Killed):
        run_ls(packing, 0.05, seed=4, checkpoint=ckpt, checkpoint_interval=0.0, progress_interval=1e9,
               callback=kill_at(6))
    assert ckpt.exists()
    resumed = run_ls(packing, 0.05, seed=4, checkpoint=ckpt, checkpoint_interval=0.0, progress_interval=1e9)
    assert resumed.stats.resumed is True
    assert not ckpt.exists()  # removed after a finished run
    assert resumed.packing.check(1e-10).ok
    assert np.array_equal(resumed.packing.positions, reference.packing.positions)
    assert np.array_equal(resumed.history["phi"], reference.history["phi"])
    assert resumed.stats.collisions == reference.stats.collisions


def test_checkpoint_saves_the_engine_state_whole_and_older_layouts_resume(tmp_path):
    """A checkpoint holds the engine's EventState minus its work space and its frame (the input's container), under
    the names checkpoints had before the state object; one in the older layouts (no ``multi``; ``m`` cells per side
    instead of ``ms`` per axis, before containers) resumes bitwise identically."""
    from spherejam.core.checkpoint import load_checkpoint, save_checkpoint
    from spherejam.engines.kernels.event_driven import FRAME, WORKSPACE, EventState

    packing = poisson_packing(200, 0.2, seed=5)
    reference = run_ls(packing, 0.05, seed=4, progress_interval=1e9)
    ckpt = tmp_path / "ls.h5"
    cut = run_ls(packing, 0.05, seed=4, checkpoint=ckpt, max_wall_time=1e-9, progress_interval=1e9)
    assert cut.stats.stop_reason == "max_wall_time" and ckpt.exists()
    arrays, attrs = load_checkpoint(ckpt, "ls")
    engine_arrays = {k for k in arrays if k.startswith("engine_")}
    assert engine_arrays == {f"engine_{k}" for k in ("st", "perm", "refs", "nbr", "nnb", "head", "nxt", "prv",
                                                     "cellof", "lvl_ms", "lvl_off", "lvl_dmax", "level")}
    scalars = attrs["engine"]["engine"]  # the stepper's attributes, then the engine's
    assert set(scalars) | {k[len("engine_"):] for k in engine_arrays} == (set(EventState._fields) - set(WORKSPACE)
                                                                         - set(FRAME))
    del scalars["multi"]  # as written before multi-image lists
    scalars["m"] = int(arrays.pop("engine_lvl_ms")[0, 0])  # and before the levelled grid
    for name in ("lvl_off", "lvl_dmax", "level"):
        del arrays[f"engine_{name}"]
    scalars["box"] = packing.box
    save_checkpoint(ckpt, "ls", arrays, attrs)
    resumed = run_ls(packing, 0.05, seed=4, checkpoint=ckpt, progress_interval=1e9)
    assert resumed.stats.resumed and resumed.stats.steps == reference.stats.steps
    assert np.array_equal(resumed.packing.positions, reference.packing.positions)
    assert np.array_equal(resumed.history["pressure"], reference.history["pressure"])



def test_wall_time_stops_keep_the_checkpoint_and_each_call_gets_its_own_budget(tmp_path):
    """max_wall_time counts seconds of the call: a call with a tiny budget still runs one window, keeps the
    checkpoint, and the chain of such calls ends exactly where an uninterrupted run does."""
    packing = poisson_packing(100, 0.0, seed=3)
    reference = run_ls(packing, 0.3, seed=4, progress_interval=1e9)
    ckpt = tmp_path / "ls.h5"
    calls = 0
    while True:
        calls += 1
        r = run_ls(packing, 0.3, seed=4, max_wall_time=1e-9, checkpoint=ckpt, progress_interval=1e9)
        assert r.stats.steps == calls and r.stats.resumed == (calls > 1)
        if r.stats.stop_reason != "max_wall_time":
            break
        assert not r.stats.completed and ckpt.exists()
    assert r.stats.stop_reason == "p_max" and r.stats.completed and not ckpt.exists()
    assert calls == reference.stats.steps > 5
    assert np.array_equal(r.packing.positions, reference.packing.positions)
    assert np.array_equal(r.history["pressure"], reference.history["pressure"])
    assert r.stats.wall_time >= r.history["wall_time"][-1] > r.history["wall_time"][0]  # the whole run's


def test_checkpoint_of_another_run_is_refused(tmp_path):
    from spherejam.core.errors import PackingFileError

    packing = poisson_packing(100, 0.0, seed=3)
    ckpt = tmp_path / "c.h5"

    def stop(window, stats):
        raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        run_ls(packing, 0.05, seed=4, checkpoint=ckpt, checkpoint_interval=0.0, callback=stop)
    with pytest.raises(PackingFileError, match="different"):
        run_ls(packing, 0.07, seed=4, checkpoint=ckpt)


@pytest.mark.parametrize(
    "kwargs, field",
    [
        ({"rate": -0.1}, "rate"),
        ({"rate": float("nan")}, "rate"),
        ({"rate": 0.1, "p_max": 1.0}, "p_max"),
        ({"rate": 0.1, "p_max": 0.5}, "p_max"),
        ({"rate": 0.1, "seed": -1}, "seed"),
        ({"rate": 0.1, "events_per_particle": 0}, "events_per_particle"),
        ({"rate": 0.1, "target_phi": 1.2}, "target_phi"),
        ({"rate": 0.1, "temperature": 0.0}, "temperature"),
        ({"rate": 0.1, "max_collisions": 0}, "max_collisions"),
        ({"rate": 0.0}, "rate"),
    ],
)
def test_bad_parameters_are_rejected(kwargs, field):
    packing = poisson_packing(10, 0.0, seed=1)
    rate = kwargs.pop("rate")
    with pytest.raises(InputError, match=field):
        run_ls(packing, rate, **kwargs)


def test_too_few_spheres_or_wrong_dimension_rejected():
    with pytest.raises(InputError, match="N=1"):
        Packing(np.zeros((1, 3)), np.ones(1), 5.0)
    flat = poisson_packing(20, 0.0, seed=1, dim=2)
    with pytest.raises(InputError, match="dim"):
        run_ls(flat, 0.1)


def test_cli_ls_writes_a_valid_packing(tmp_path, capsys):
    from spherejam.cli import main
    from spherejam.core.packing_io import read_packing, write_packing

    src = tmp_path / "in.h5"
    write_packing(src, poisson_packing(200, 0.1, seed=6))
    out = tmp_path / "out.h5"
    assert main(["ls", str(src), "--rate", "0.3", "-o", str(out), "--seed", "2", "--progress-interval", "1e9"]) == 0
    packing, history = read_packing(out, with_history=True)
    assert packing.metadata["algorithm"] == "ls"
    assert packing.metadata["reduced_pressure"] >= 1e12
    assert "pressure" in history
    assert main(["ls", str(src), "--rate", "-1", "-o", str(out)]) == 2
    assert main(["ls", str(src), "--rate", "0.1", "--p-max", "1", "-o", str(out)]) == 2


def test_window_length_switch_counts_events_or_collisions():
    packing = poisson_packing(200, 0.0, seed=12)
    by_events = run_ls(packing, 0.1, seed=1, progress_interval=1e9)
    by_collisions = run_ls(packing, 0.1, seed=1, count_collisions_only=True, progress_interval=1e9)
    assert np.all(by_events.history["events"] == 20 * 200)
    assert np.all(by_events.history["collisions"] < 20 * 200)
    assert np.all(by_collisions.history["collisions"] == 20 * 200)
    assert np.all(by_collisions.history["events"] > 20 * 200)
    assert by_collisions.packing.metadata["parameters"]["count_collisions_only"] is True


def test_event_heap_stays_ordered_under_random_updates(rng):
    """Indexed heap: after random key changes the root holds the minimum and positions/keys stay consistent."""
    for n in (1, 2, 5, 37, 1000):
        key = rng.exponential(size=n)
        heap, hpos, hkey = np.zeros(n, np.int32), np.zeros(n, np.int32), np.zeros(n)
        ed.heap_build(heap, hpos, hkey, key, n)
        for _ in range(3 * n):
            i = int(rng.integers(n))
            key[i] = key[i] + rng.normal() if rng.random() < 0.5 else float(rng.exponential())
            ed.heap_update(heap, hpos, hkey, i, key[i], n)
        assert np.array_equal(heap[hpos], np.arange(n))
        assert np.array_equal(hkey, key[heap])
        assert hkey[0] == key.min()
        parents = (np.arange(1, n) - 1) // 4  # the heap is 4-ary
        assert np.all(hkey[parents] <= hkey[1:])


def test_engine_keeps_cache_line_alignment_and_input_order():
    """st and neighbour rows start on 64-byte lines; the cell-order renumbering is undone on output."""
    packing = poisson_packing(300, 0.2, seed=8)
    eng = _engine_for(packing, 0.1)
    assert not np.array_equal(eng.state.perm, np.arange(packing.n))  # particles were renumbered
    for _ in range(3):
        eng.window(20 * packing.n)
        s = eng.state
        assert s.st.ctypes.data % 64 == 0 and s.nbr.ctypes.data % 64 == 0 and s.nbr.shape[1] % 16 == 0
    eng.rebuild_lists(0.0)
    assert eng.state.st.ctypes.data % 64 == 0
    nominal = packing.diameters / packing.diameters.mean()
    assert np.array_equal(eng.nominal, nominal)  # distinct diameters identify the particles
