"""Walls in the event-driven engine: the wall events, the pressure at a wall, and LS/MLS in every container shape
checked by brute force (docs/containers.md §2-§3)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from spherejam.core.container import Container
from spherejam.core.seeding import poisson_packing
from spherejam.engines.closest_jamming import find_closest_jamming
from spherejam.engines.event_driven import LSEngine
from spherejam.engines.kernels import event_driven as ed
from spherejam.engines.lubachevsky_stillinger import maxwell_velocities, run_ls


def _first_contact(gap, t_max=40.0, steps=400_001):
    """The first time on a fine grid where the gap function is <= 0 (inf if none): the brute-force reference."""
    ts = np.linspace(0.0, t_max, steps)
    g = gap(ts)
    hit = np.flatnonzero(g <= 0.0)
    return ts[hit[0]] if len(hit) else math.inf


def test_plane_delay_is_the_first_time_the_gap_closes(rng):
    for _ in range(300):
        gap0, v, a = rng.uniform(0, 3), rng.normal(), rng.uniform(0, 0.5) * rng.integers(2)
        want = _first_contact(lambda t, gap0=gap0, v=v, a=a: gap0 + (v - a) * t)
        got = ed.plane_delay(gap0, v - a)
        assert (got > 40.0 and math.isinf(want)) or got == pytest.approx(want, abs=2e-4)
    assert ed.plane_delay(0.0, -1.0) == 0.0 and ed.plane_delay(-1e-17, 0.5) == math.inf


@pytest.mark.parametrize("touching", [False, True])
def test_concave_delay_is_the_first_contact_with_a_cylinder_or_sphere(rng, touching):
    """Including a sphere that touches the wall and moves inwards: it meets the wall again across the container
    (a convex pair never does; the engine once lost such events)."""
    for trial in range(300):
        reach = 4.0
        u = rng.normal(size=3)
        w = rng.normal(size=3) * rng.uniform(0.1, 2.0)
        if trial % 2:  # a cylinder: components across its axis only
            u[2], w[2] = 0.0, 0.0
        u /= np.linalg.norm(u)
        p = u * (reach if touching else reach * rng.uniform(0.0, 1.0))
        a = rng.uniform(0.0, 0.6) * (trial % 3 != 0)
        want = _first_contact(lambda t, p=p, w=w, a=a, reach=reach: reach - a * t
                              - np.linalg.norm(p + np.outer(t, w), axis=1))
        got = ed.concave_delay(*p, *w, reach, a)
        if touching and np.dot(p, w) + a * np.linalg.norm(p) > 0:
            assert got <= 1e-12  # leaving outwards in the frame of its surface: it collides now
            continue
        if touching:
            # the grid reference sees contact at t = 0; the event is the next one, across the container
            want = _first_contact(lambda t, p=p, w=w, a=a, reach=reach: reach - a * t
                                  - np.linalg.norm(p + np.outer(t, w), axis=1) + 1e-9 * (t < 1e-3))
            assert got > 0
        assert (got > 40.0 and math.isinf(want)) or got == pytest.approx(want, abs=3e-4, rel=1e-3)


_SHAPES = {
    "cylinder": Container((6.0, 6.0, 5.0), (False, False, True), (False, False, False), curved="cylinder", radius=3.0),
    "capped cylinder along x": Container((5.0, 6.0, 6.0), (False,) * 3, (True, False, False), curved="cylinder",
                                         radius=3.0, axis=0),
    "slab": Container((5.0, 5.0, 4.0), (True, True, False), (False, False, True)),
    "box": Container((5.0, 6.0, 7.0), (False,) * 3, (True,) * 3),
    "sphere": Container((6.0, 6.0, 6.0), (False,) * 3, (False,) * 3, curved="sphere", radius=3.0),
}


@pytest.mark.parametrize("shape", list(_SHAPES))
def test_a_wall_beyond_reach_is_never_met_before_the_skin_event(rng, shape):
    """walls_beyond, which lets the prediction skip the wall event of a sphere far from every wall, is the exact
    distance test (against Container.wall_distance); and whenever it skips, the sphere (within skin/2 = h of its
    reference centre, its radius growing up to r_max) meets no wall before it leaves its skin sphere or outgrows
    r_max."""
    c = _SHAPES[shape]
    lengths, walls = np.asarray(c.lengths, dtype=float), c.wall_array()
    skipped = 0
    for _ in range(3000):
        ref = rng.uniform(0.0, 1.0, 3) * lengths
        h, r0, a = rng.uniform(0.05, 0.3), rng.uniform(0.1, 0.6), rng.uniform(0.0, 0.05)
        r_max = r0 + a * rng.uniform(0.0, 5.0)
        beyond = ed.walls_beyond(*ref, h + r_max, lengths, walls)
        assert beyond == (c.wall_distance(ref[None, :])[0] > h + r_max)
        if not beyond:
            continue
        skipped += 1
        u = rng.normal(size=3)
        x = ref + u / np.linalg.norm(u) * h * rng.uniform(0.0, 1.0) ** (1 / 3)
        v = rng.normal(size=3)
        tau_wall, _ = ed.wall_event(*x, *v, r0, a, lengths, walls)
        tau_skin = ed.skin_exit_delay(*(x - ref), *v, h)
        assert tau_wall > tau_skin or r0 + a * tau_wall > r_max, (ref, x, v, r0, a, r_max, tau_wall, tau_skin)
    assert skipped > 100


def test_a_sphere_bounces_elastically_inside_a_spherical_container():
    """Two spheres at gamma = 0 in a sphere of radius 3: the kinetic energy at the end of every window (before the
    thermostat) is the initial one, the spheres never leave, and they bounce off the wall many times."""
    c = Container((6.0,) * 3, (False,) * 3, (False,) * 3, "sphere", 3.0, spec="sphere:diameter=6")
    v = np.array([[0.7, -0.3, 0.2], [0.0, 0.1, 0.0]])
    temperature = float(np.sum(v * v)) / 6.0  # E = (3/2) N T with N = 2
    engine = LSEngine.start(np.array([[3.0, 3.0, 3.0], [3.0, 4.5, 3.0]]), np.ones(2), c, 0.5, v, 0.0, temperature)
    bounces = 0
    for _ in range(20):
        stats = engine.window(50)
        bounces += stats.wall_collisions
        assert stats.temperature == pytest.approx(temperature, rel=1e-12)  # measured before the thermostat
        r = np.linalg.norm(engine.positions - c.centre, axis=1)
        assert np.all(r <= 3.0 - 0.25 + 1e-12)
    assert bounces > 20


def _brute_force_check(packing):
    """Worst relative pair overlap over the images along periodic axes and worst relative wall penetration, with no
    cell list (O(N^2))."""
    c = packing.container
    x, d = packing.positions, packing.diameters
    i, j = np.triu_indices(packing.n, 1)
    worst = -math.inf
    ranges = [(-1, 0, 1) if per else (0,) for per in c.periodic]
    for a in ranges[0]:
        for b in ranges[1]:
            for e in ranges[2]:
                shift = np.array([a, b, e]) * np.asarray(c.lengths)
                r = np.linalg.norm(x[j] + shift - x[i], axis=1)
                worst = max(worst, float(np.max(1.0 - r / (0.5 * (d[i] + d[j])))))
    r = 0.5 * d
    dist = np.full(packing.n, np.inf)
    for k in range(3):
        if c.planes[k]:
            dist = np.minimum(dist, np.minimum(x[:, k], c.lengths[k] - x[:, k]))
    if c.curved is not None:
        q = x - c.centre
        if c.curved == "cylinder":
            q[:, c.axis] = 0.0
        dist = np.minimum(dist, c.radius - np.linalg.norm(q, axis=1))
    return worst, float(np.max((r - dist) / r))


SHAPES = ["slab:height=5", "box:x=6,y=5", "cylinder:diameter=5", "cylinder:diameter=4,capped=yes",
          "sphere:diameter=7", "periodic:x=4,y=6"]


@pytest.mark.slow
@pytest.mark.parametrize("spec", SHAPES)
@pytest.mark.parametrize("sigma", [0.0, 0.3])
def test_ls_and_mls_in_every_container_keep_spheres_apart_and_inside(spec, sigma):
    n = None if spec.startswith("sphere") else 150
    start = poisson_packing(n, sigma=sigma, seed=11, container=spec)
    ls = run_ls(start, 0.5, seed=1, progress_interval=1e9)
    assert ls.stats.stop_reason == "p_max"
    for result in (ls, find_closest_jamming(ls.packing, initial_rate=1.0, final_rate=0.1, seed=2,
                                            progress_interval=1e9)):
        q = result.packing
        assert q.container == start.container
        overlap, penetration = _brute_force_check(q)
        assert overlap <= 1e-10 and penetration <= 1e-10
        assert 0.45 < q.phi < 0.66  # a container's walls loosen the packing: below the bulk's ~0.64
    assert result.stats.stop_reason in ("final_rate", "equilibrated")
    assert result.packing.metadata["reduced_pressure"] > 1e11


@pytest.mark.slow
def test_the_pressure_on_a_flat_wall_obeys_the_contact_theorem():
    """A hard-sphere fluid between two walls at phi ~ 0.3: the momentum the walls take per area and time equals
    k_B T times the density of centres at contact (the contact theorem), and both equal the normal pressure of the
    collision virial with its wall term, P_zz = p_zz N k_B T / V (the tangential ones differ near the walls, so the
    mean of the three, the ``pressure`` MLS uses, lies a little below)."""
    n, temperature = 600, 0.2
    start = poisson_packing(n, seed=7, container="slab:height=14")
    fluid = run_ls(start, 0.2, target_phi=0.3, seed=3, progress_interval=1e9).packing
    c = fluid.container
    rng = np.random.default_rng(5)
    engine = LSEngine.start(fluid.positions, np.ones(n), c, fluid.mean_diameter,
                            maxwell_velocities(n, temperature, rng), 0.0, temperature)
    area, volume, radius = c.lengths[0] * c.lengths[1], float(np.prod(c.lengths)), 0.5 * fluid.mean_diameter
    for _ in range(20):  # equilibrate
        engine.window(20 * n)
    wall, virial, contact = [], [], []
    edges = radius + np.linspace(0.0, 0.25, 6) * fluid.mean_diameter  # bins of 0.05 d from contact
    for _ in range(150):
        stats = engine.window(20 * n)
        wall.append(stats.wall_impulse / (2.0 * area * stats.duration))
        virial.append(stats.pressure_axes[2] * n * temperature / volume)
        z = engine.positions[:, 2]
        h = np.histogram(np.minimum(z, c.lengths[2] - z), edges)[0] / (2.0 * area * np.diff(edges))
        contact.append(h)
    wall, virial = np.array(wall), np.array(virial)
    profile = np.mean(contact, axis=0)
    centres = 0.5 * (edges[1:] + edges[:-1])
    rho_contact = np.polyval(np.polyfit(centres - radius, profile, 2), 0.0)
    se = lambda a: np.std(a, ddof=1) / math.sqrt(len(a))  # noqa: E731 (windows of 20 N events: nearly independent)
    assert abs(wall.mean() - virial.mean()) < 3 * math.hypot(se(wall), se(virial)) + 0.005 * virial.mean()
    assert temperature * rho_contact == pytest.approx(wall.mean(), rel=0.06)
    assert wall.mean() > 2.0 * n * temperature / volume  # denser than an ideal gas: the test has something to see
