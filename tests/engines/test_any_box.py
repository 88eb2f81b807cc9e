"""Any box, any size ratio: LS, MLS and FB where pairs meet through several periodic images (N = 2 ... 200,
sigma up to 0.5, bidisperse 1:10), checked by a brute-force overlap test over all images (tests/packings.py, no cell
list), and the small-N physics (the N = 2 BCC crystal, the hard-sphere equation of state at N = 32)."""

import itertools
import math

import numpy as np
import pytest

from spherejam.analysis.contacts import analyze_contacts, near_pairs
from spherejam.analysis.voronoi import voronoi_volumes
from spherejam.core.neighbours import pair_images
from spherejam.core.packing import Packing
from spherejam.core.seeding import poisson_packing
from spherejam.engines.closest_jamming import find_closest_jamming
from spherejam.engines.event_driven import LSEngine
from spherejam.engines.force_biased import run_fb
from spherejam.engines.lubachevsky_stillinger import maxwell_velocities, run_ls

from packings import worst_overlap_all_images

QUIET = {"progress_interval": 1e9}


def image_pairs_brute_force(packing: Packing, scale: float):
    x, d, box = packing.positions, packing.diameters, packing.box
    reach = int(math.ceil(scale * d.max() / box)) + 1
    out = []
    for i, j in itertools.combinations(range(packing.n), 2):
        for n in itertools.product(range(-reach, reach + 1), repeat=3):
            v = x[j] + box * np.array(n) - x[i]
            if np.linalg.norm(v) < scale * 0.5 * (d[i] + d[j]):
                out.append((i, j, round(float(np.linalg.norm(v)), 9)))
    return sorted(out)


def test_brute_force_check_sees_a_sphere_and_its_own_image():
    p = Packing([[0.5, 0.5, 0.5], [1.5, 1.5, 1.5]], [2.2, 0.1], 2.0)  # sphere 0 is wider than the box
    assert worst_overlap_all_images(p) == pytest.approx(1.0 - 2.0 / 2.2)
    report = p.check()
    assert not report.ok and report.pair == (0, 0)


@pytest.mark.parametrize("n, sigma", [(2, 0.0), (5, 0.5), (12, 0.3)])
def test_pair_images_lists_every_image(n, sigma):
    p = poisson_packing(n, sigma, seed=3)
    p = p.replace(diameters=p.diameters * (0.8 * p.box / p.diameters.max()))  # largest sphere 0.8 L
    i, j, d = pair_images(p.positions, p.diameters, p.box, 1.3)
    mine = sorted((int(a), int(b), round(float(np.linalg.norm(v)), 9)) for a, b, v in zip(i, j, d))
    assert mine == image_pairs_brute_force(p, 1.3)
    assert len(mine) > len(set((a, b) for a, b, _ in mine))  # some pair is within reach through several images


CASES = [(n, sigma) for n in (2, 10, 50, 100, 200) for sigma in (0.0, 0.3, 0.5)]


def _ended_by_self_contact(result) -> bool:
    """The run stopped because its largest sphere grew as wide as the box (it touches its own images: nothing can
    grow any more; at N = 2 and sigma = 0.5 that comes before jamming)."""
    out = result.packing
    if result.stats.stop_reason != "self_contact":
        return False
    assert out.diameters.max() == pytest.approx(out.box, rel=1e-12)
    return True


@pytest.mark.parametrize("n, sigma", CASES)
def test_ls_any_box(n, sigma):
    result = run_ls(poisson_packing(n, sigma, seed=n), 0.1, seed=1, **QUIET)
    out = result.packing
    assert worst_overlap_all_images(out) <= 1e-10
    p = out.metadata["reduced_pressure"]
    assert math.isfinite(p) and p > 0
    assert _ended_by_self_contact(result) or (result.stats.stop_reason == "p_max" and p >= 1e12)
    assert np.all(np.isfinite(result.history["pressure"])) and np.all(result.history["pressure"] > 0)


@pytest.mark.parametrize("n, sigma", CASES)
def test_mls_any_box_ends_jammed(n, sigma):
    """A short ladder (10 ... 1e-2) at every N; the paper's full one at N <= 10 (below)."""
    result = find_closest_jamming(poisson_packing(n, sigma, seed=n), final_rate=1e-2, seed=2, **QUIET)
    _check_jammed(result)


@pytest.mark.parametrize("sigma", [0.0, 0.3, 0.5])
def test_mls_in_a_tiny_box_is_isostatic(sigma):
    """N = 10 (L ~ 2.6 mean diameters: contacts through several images) on the paper's ladder: the non-rattlers
    carry at least the isostatic d (N' - 1) + 1 contacts, images counted (without them the packing looks floppy)."""
    result = find_closest_jamming(poisson_packing(10, sigma, seed=10), seed=2, **QUIET)
    if _check_jammed(result):
        c = analyze_contacts(result.packing).coordination
        assert c.n_nonrattlers >= 2 and c.isostatic_excess >= 0


def _check_jammed(result) -> bool:
    """No overlap, finite positive pressures; True if the search ended jammed, False if by self-contact."""
    out = result.packing
    assert worst_overlap_all_images(out) <= 1e-10
    p = out.metadata["reduced_pressure"]
    assert math.isfinite(p) and p > 0
    pressures = result.history["pressure"]
    assert np.all(np.isfinite(pressures)) and np.all(pressures > 0)
    if _ended_by_self_contact(result):
        return False
    assert result.stats.stop_reason in ("final_rate", "jammed")  # p >= p_max at the last rate, or held at zero rate
    assert p >= 1e12
    return True


@pytest.mark.parametrize("n, sigma", CASES)
def test_fb_any_box(n, sigma):
    result = run_fb(poisson_packing(n, sigma, seed=n), 1e-2, **QUIET)
    out = result.packing
    assert result.stats.stop_reason == "converged"
    assert worst_overlap_all_images(out) <= 1e-10
    assert out.min_gap() < 1e-9  # the closest pair (or image) touches


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_two_spheres_jam_as_bcc(seed):
    """Two equal spheres in a cube jam in the body-centred cubic crystal: phi = pi sqrt(3)/8, and each touches
    eight images of the other (K = 8 > the isostatic 4)."""
    out = find_closest_jamming(poisson_packing(2, 0.0, seed=seed), seed=seed, **QUIET).packing
    assert out.phi == pytest.approx(math.pi * math.sqrt(3) / 8, rel=1e-8)
    i, j, h = near_pairs(out, 1e-8)
    assert len(h) == 8 and np.all(np.abs(h) < 1e-8)
    v = voronoi_volumes(out)
    assert v == pytest.approx([out.box**3 / 2] * 2, rel=1e-9)  # the two truncated-octahedron cells


@pytest.mark.parametrize("seed", [0, 2])
def test_mls_of_a_jammed_two_sphere_crystal_ends_jammed(seed):
    """A fast LS already jams two spheres in the BCC crystal; MLS from there sees windows of collisions that take
    no time (gaps below double resolution). That is an infinite pressure, not a stuck event loop (found by
    benchmarks/stress.py: "40 events took no time")."""
    ls = run_ls(poisson_packing(2, 0.0, seed=seed), 10.0, seed=seed, **QUIET).packing
    assert ls.phi == pytest.approx(math.pi * math.sqrt(3) / 8, rel=1e-8)
    out = find_closest_jamming(ls, initial_rate=10.0, final_rate=1e-2, seed=seed, **QUIET)
    assert out.stats.stop_reason == "jammed"
    assert out.packing.phi == pytest.approx(math.pi * math.sqrt(3) / 8, rel=1e-8)


def test_bidisperse_one_to_ten_runs_at_n_500():
    """30 % small spheres by volume at a size ratio 1:10: one large sphere in 500, nearly as wide as the box."""
    n, ratio = 500, 10.0
    n_large = 1  # 30 % small by volume: n_small / n_large = (0.3 / 0.7) * ratio**3 = 429
    diameters = np.ones(n)
    diameters[:n_large] = ratio
    start = poisson_packing(n, 0.0, seed=7)
    start = start.replace(diameters=diameters * float(start.diameters[0]) * 1e-3)
    start = start.scaled_to_contact()
    small_volume = (start.diameters[n_large:] ** 3).sum() / (start.diameters**3).sum()
    assert 0.25 < small_volume < 0.35  # 499 / 1499 with one large sphere
    result = run_ls(start, 0.1, seed=3, **QUIET)
    out = result.packing
    assert result.stats.stop_reason in ("p_max", "self_contact")
    assert worst_overlap_all_images(out) <= 1e-10
    assert out.diameters.max() > 0.5 * out.box  # the large sphere reaches its neighbours through several images
    assert math.isfinite(out.metadata["reduced_pressure"]) and out.metadata["reduced_pressure"] > 0
    fb = run_fb(start, 1e-2, **QUIET).packing
    assert worst_overlap_all_images(fb) <= 1e-10


def carnahan_starling(phi):
    return (1 + phi + phi**2 - phi**3) / (1 - phi) ** 3


def _equilibrium_pressures(n, phi, seeds, windows):
    out = []
    for seed in seeds:
        fluid = run_ls(poisson_packing(n, 0.0, seed=seed), 0.1, seed=seed, target_phi=phi, **QUIET).packing
        nominal = fluid.diameters / fluid.diameters.mean()
        v = maxwell_velocities(n, 0.2, np.random.default_rng(seed))
        engine = LSEngine.start(fluid.positions, nominal, fluid.box, fluid.diameters.mean(), v, 0.0,
                                all_images=True)
        for _ in range(5):
            engine.window(20 * n)
        assert engine.state.multi
        out += [engine.window(20 * n).pressure for _ in range(windows)]
    return np.array(out)


def test_small_box_equation_of_state_extrapolates_to_carnahan_starling():
    """Z = PV/(N k_B T) at phi = 0.3, every image predicted, at N = 32 (L = 3.8 D, list cutoffs beyond L/2) and N = 128.

    At fixed density, Z_N = Z (1 + a/N) (finite-size effects are O(1/N); measured a = 0.65-0.79 from N = 32 to 256,
    docs/algorithms.md "Any box, any size ratio"), so N = 32 alone lies ~2 % above Carnahan-Starling. The straight
    line in 1/N through both sizes must meet CS within 3 standard errors plus 0.3 % (CS is within ~0.1 % of
    simulations at phi = 0.3), and the N = 32 excess must be the O(1/N) one: between 0 and 2/N.
    """
    phi = 0.3
    z32 = _equilibrium_pressures(32, phi, range(4), 150)
    z128 = _equilibrium_pressures(128, phi, range(1), 150)
    m32, m128 = z32.mean(), z128.mean()
    s32, s128 = z32.std(ddof=1) / math.sqrt(len(z32)), z128.std(ddof=1) / math.sqrt(len(z128))
    z_inf = (128 * m128 - 32 * m32) / 96
    s_inf = math.hypot(128 / 96 * s128, 32 / 96 * s32)
    cs = carnahan_starling(phi)
    assert s_inf < 0.004 * cs  # the comparison resolves a few tenths of a per cent
    assert abs(z_inf - cs) < 3 * s_inf + 0.003 * cs
    assert 0 < m32 / cs - 1 < 2 / 32


def test_image_collision_skips_only_images_the_caller_would_reject():
    """image_collision with a deadline ``until`` returns what the minimisation over every image returns whenever the
    caller could accept that (t + delay <= until, as the caller rounds it): the same delay and image, to the bit; and
    otherwise nothing the caller could accept. Random pairs in a small box (every image within reach), growing and
    not, at times where t + delay rounds, and with deadlines at t itself (a partner whose event is now)."""
    from spherejam.engines.kernels import event_driven as ed

    rng = np.random.default_rng(4)
    lengths = np.array([3.0, 3.5, 4.0])
    periodic = np.array([True, True, True])
    kept = pruned = 0
    for trial in range(4000):
        if trial % 4 == 0:  # at contact to round-off: delays far below the ulp of t
            r = rng.normal(size=3)
            sig, rho = rng.uniform(0.5, 2.5), 1.0
            r *= sig * rho * (1.0 + 1e-15 * rng.random()) / np.linalg.norm(r)
        else:
            r = (rng.random(3) - 0.5) * lengths
            sig, rho = rng.uniform(0.5, 2.5), rng.uniform(0.8, 1.0)
        u = rng.normal(size=3)
        gamma = rng.choice([0.0, 1e-3, 0.1, 1.0])
        skip = int(rng.integers(-1, 27))
        t = rng.choice([0.0, 1.0, 1e3, 1e6])
        until = t if trial % 3 == 0 else t + rng.exponential(0.3)
        full = ed.image_collision(*r, *u, sig, rho, gamma, lengths, periodic, 10.0, skip, 0.0, np.inf)
        limited = ed.image_collision(*r, *u, sig, rho, gamma, lengths, periodic, 10.0, skip, t, until)
        if t + full[0] <= until:
            assert limited == full
            kept += 1
        else:
            assert not t + limited[0] <= until
            pruned += 1
    assert kept > 300 and pruned > 300  # both cases are exercised
