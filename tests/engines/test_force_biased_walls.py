"""The force-biased (FB) engine in containers: the wall force (a sphere's mirror image), the clamp at the walls, the
Verlet list of a container's frame, and whole runs in every shape checked by brute force (docs/algorithms.md §4.6)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from spherejam.core import neighbours
from spherejam.core.container import Container
from spherejam.core.seeding import poisson_packing
from spherejam.engines import force_biased as fb
from spherejam.engines.kernels import force_biased as kernels

SLAB = Container((8.0, 8.0, 6.0), (True, True, False), (False, False, True), spec="slab:height=6")
CYLINDER = Container((6.0, 6.0, 8.0), (False, False, True), (False,) * 3, "cylinder", 3.0, spec="cylinder:diameter=6")
SPHERE = Container((6.0,) * 3, (False,) * 3, (False,) * 3, "sphere", 3.0, spec="sphere:diameter=6")


def _frame(container):
    frame = neighbours.Frame.of(container)
    return frame.lengths, frame.half, frame.periodic


def _mirror_pair_force(x, mirror, d, rho_out):
    """The FB pair force on a sphere at x from a sphere of the same diameter d at ``mirror``, computed by the pair
    kernel in a periodic cube far larger than the pair."""
    box = 100.0
    pos = np.array([x, mirror]) + box / 2 - np.asarray(x)  # the pair in the middle of the cube
    dia = np.array([d, d])
    lengths, half, periodic = _frame(Container.cube(box))
    ms = neighbours.cells_per_axis(box, rho_out * d + 0.1, 2, 3)
    start, nbr = kernels.build_verlet(pos, dia, lengths, half, periodic, rho_out, 0.1, ms, 16)
    out = np.zeros((2, 3))
    kernels.forces(pos, dia, lengths, half, periodic, rho_out, start, nbr, out, np.empty(3), False)
    return out[0]


@pytest.mark.parametrize("h", [0.2, 0.45, 0.56, 0.6])  # the last: the outer sphere clears the wall
def test_a_plane_pushes_a_sphere_as_its_mirror_image_does(h):
    """A sphere at height h above the wall z = 0 of a slab: the wall's force is the pair force of its mirror image
    at -h, it points into the slab, and one FB move pushes the sphere off by exactly the step of that force (the
    gap to the mirror grows by twice that: the image moves with the sphere, as a partner in a pair does)."""
    d, rho_out = 1.1, 1.05
    pos = np.array([[3.0, 2.0, h], [6.0, 6.0, 3.0]])  # the second sphere is far from every wall and from the first
    lengths, _, periodic = _frame(SLAB)
    forces = np.zeros((2, 3))
    ratio = kernels.wall_forces(pos, np.array([d, 1.0]), lengths, SLAB.wall_array(), rho_out, forces)
    assert ratio == pytest.approx(2 * h / d, rel=1e-15)  # the wall ratio: the mirror pair's r / D
    want = _mirror_pair_force(pos[0], pos[0] * [1, 1, -1], d, rho_out)
    np.testing.assert_allclose(forces[0], want, rtol=1e-12, atol=1e-13)  # positions rounded by the shift
    touching = 2 * h < rho_out * d
    assert (forces[0, 2] > 0) == touching and forces[0, 0] == forces[0, 1] == 0.0
    np.testing.assert_array_equal(forces[1], 0.0)
    if touching:
        assert forces[0, 2] == pytest.approx(d * d * (1 - (2 * h / (rho_out * d)) ** 2), rel=1e-14)
    drift = np.zeros((2, 3))
    moved = pos.copy()
    kernels.move(moved, np.array([d, 1.0]), lengths, periodic, SLAB.wall_array(), True, ratio, forces, 0.25, drift)
    assert moved[0, 2] - h == pytest.approx(0.25 / d * forces[0, 2], rel=1e-12)
    np.testing.assert_array_equal(drift[0], moved[0] - pos[0])


@pytest.mark.parametrize("container", [CYLINDER, SPHERE], ids=["cylinder", "sphere"])
def test_a_curved_wall_pushes_a_sphere_towards_the_axis_as_its_mirror_image_does(container):
    """A sphere near a cylinder's or a sphere's wall: the force is that of its mirror image across the tangent plane
    at the nearest wall point (at distance 2 h along the radius), along the inward radius; a move pushes it off."""
    d, rho_out, h = 1.0, 1.08, 0.4
    u = np.array([0.6, -0.8, 0.0]) if container is CYLINDER else np.array([0.48, -0.64, 0.6])
    c = container.centre
    x = c + (container.radius - h) * u + (np.array([0, 0, 1.7]) if container is CYLINDER else 0.0)
    pos = np.array([x, c])
    forces = np.zeros((2, 3))
    lengths, _, periodic = _frame(container)
    ratio = kernels.wall_forces(pos, np.array([d, 0.5]), lengths, container.wall_array(), rho_out, forces)
    assert ratio == pytest.approx(2 * h / d, rel=1e-12)
    want = _mirror_pair_force(x, x + 2 * h * u, d, rho_out)
    np.testing.assert_allclose(forces[0], want, rtol=1e-12, atol=1e-14)
    assert np.dot(forces[0], u) < 0 and np.linalg.norm(np.cross(forces[0], u)) < 1e-14  # radial, inwards
    np.testing.assert_array_equal(forces[1], 0.0)  # the second sphere, at the centre, is far from the wall
    moved = pos.copy()
    kernels.move(moved, np.array([d, 0.5]), lengths, periodic, container.wall_array(), True, ratio, forces, 0.25,
                 np.zeros((2, 3)))
    r = np.linalg.norm((moved[0] - c)[:2] if container is CYLINDER else moved[0] - c)
    assert container.radius - r - h == pytest.approx(0.25 / d * np.linalg.norm(forces[0]), rel=1e-12)
    if container is CYLINDER:
        assert moved[0, 2] == x[2]  # no push along the axis


@pytest.mark.parametrize("container", [SLAB, CYLINDER, SPHERE], ids=["slab", "cylinder", "sphere"])
def test_a_move_through_the_wall_is_clamped_at_the_inner_radius(container):
    """A force that would throw a sphere out of the container leaves it at rho_in D_i / 2 from the wall, its drift
    the move it made; along a periodic axis the same move wraps."""
    rho_in, d = 0.3, 1.2
    c = container.centre
    pos = np.array([c + [0.5, -0.2, 0.3], c])
    forces = np.array([[40.0, -70.0, 55.0], [0.0, 0.0, 0.0]])
    drift = np.zeros((2, 3))
    lengths, _, periodic = _frame(container)
    moved = pos.copy()
    kernels.move(moved, np.array([d, 1.0]), lengths, periodic, container.wall_array(), True, rho_in, forces, 1.0,
                 drift)
    assert container.wall_distance(moved[:1])[0] == pytest.approx(0.5 * rho_in * d, rel=1e-12)
    assert np.all(moved >= 0) and np.all(moved < lengths)
    step = forces[0] / d
    for k in range(3):
        if periodic[k]:
            assert moved[0, k] == pytest.approx((pos[0, k] + step[k]) % lengths[k], abs=1e-12)
            assert drift[0, k] == step[k]
        else:
            assert drift[0, k] == moved[0, k] - pos[0, k]
    np.testing.assert_array_equal(moved[1], c)


FRAMES = [
    Container((3.0, 4.5, 7.0), (True,) * 3, (False,) * 3, spec="periodic:x=3.0,y=4.5,z=7.0"),
    Container((9.0, 7.0, 3.5), (True, True, False), (False, False, True), spec="slab:height=3.5"),
    Container((5.0, 8.0, 6.0), (False,) * 3, (True,) * 3, spec="box:x=5.0,y=8.0,z=6.0"),
    Container((6.0, 6.0, 9.0), (False, False, True), (False,) * 3, "cylinder", 3.0, spec="cylinder:diameter=6.0"),
]


@pytest.mark.parametrize("container", FRAMES, ids=lambda c: c.spec.partition(":")[0])
def test_verlet_list_and_forces_in_a_frame_match_brute_force(rng, container):
    """Pairs within rho_out D_ij + skin and their forces, by minimum image along periodic axes only (none across a
    wall), against an O(N^2) search; a wide size ratio makes large spheres scan wide stencils that end at walls."""
    n, rho_out, skin = 120, 1.05, 0.2
    lengths, half, periodic = _frame(container)
    pos = rng.random((n, 3)) * lengths
    dia = np.exp(rng.normal(0.0, 0.4, n))
    dia *= (0.4 * np.prod(lengths) / n / (np.pi / 6 * np.mean(dia**3))) ** (1 / 3)
    ms = neighbours.cells_per_axis(container, rho_out * np.quantile(dia, 0.5) + skin, n)
    start, nbr = kernels.build_verlet(pos, dia, lengths, half, periodic, rho_out, skin, ms, 64 * n)
    got = {(i, int(j)) for i in range(n) for j in nbr[start[i]:start[i + 1]]}
    dx = pos[:, None, :] - pos[None, :, :]
    for k in range(3):
        if periodic[k]:
            dx[..., k] -= lengths[k] * np.round(dx[..., k] / lengths[k])
    r = np.sqrt((dx**2).sum(-1))
    dij = 0.5 * (dia[:, None] + dia[None, :])
    expected = {(i, j) for i in range(n) for j in range(i + 1, n) if r[i, j] < rho_out * dij[i, j] + skin}
    assert got == expected and len(got) > n
    out = np.zeros((n, 3))
    h = kernels.forces(pos, dia, lengths, half, periodic, rho_out, start, nbr, out, np.empty(3), False)
    with np.errstate(divide="ignore", invalid="ignore"):
        f = np.where(r < rho_out * dij, dia[:, None] * dia[None, :] * (1 - (r / (rho_out * dij)) ** 2) / r, 0.0)
    np.fill_diagonal(f, 0.0)
    np.testing.assert_allclose(out, np.einsum("ij,ijk->ik", f, dx), rtol=1e-11, atol=1e-11)
    np.fill_diagonal(r, np.inf)
    assert h == pytest.approx(np.min(r / dij), rel=1e-14)


def _brute_force(packing):
    """Worst relative sphere-sphere overlap (every image along the periodic axes, a sphere's own included) and worst
    wall penetration relative to the radius, from the container's geometry by hand: O(N^2), no cell list."""
    c = packing.container
    x, d = packing.positions, packing.diameters
    lengths = np.asarray(c.lengths)
    i, j = np.triu_indices(packing.n, 0)
    worst = -math.inf
    for image in np.ndindex(3, 3, 3):
        n = np.array(image) - 1
        if np.any(n[~np.asarray(c.periodic)] != 0):
            continue  # no image across a wall
        r = np.linalg.norm(x[j] + n * lengths - x[i], axis=1)
        keep = (i != j) | np.any(n != 0)
        worst = max(worst, float(np.max(1.0 - r[keep] / (0.5 * (d[i] + d[j]))[keep])))
    gaps = []
    for k in range(3):
        if c.planes[k]:
            gaps += [x[:, k], lengths[k] - x[:, k]]
    if c.curved == "cylinder":
        gaps.append(c.radius - np.hypot(x[:, 0] - lengths[0] / 2, x[:, 1] - lengths[1] / 2))
    elif c.curved == "sphere":
        gaps.append(c.radius - np.linalg.norm(x - lengths / 2, axis=1))
    penetration = max(float(np.max(1.0 - g / (0.5 * d))) for g in gaps) if gaps else -math.inf
    return worst, penetration


SHAPES = ["slab:height=4", "box:x=5,y=4,z=6", "cylinder:diameter=5", "cylinder:diameter=4,capped=yes,length=6",
          "sphere:diameter=6"]


@pytest.mark.parametrize("spec", SHAPES)
@pytest.mark.parametrize("sigma", [0.0, 0.3])
def test_fb_in_every_container_keeps_spheres_apart_and_inside(spec, sigma):
    n = 100 if spec.startswith(("slab", "cylinder:diameter=5")) else None  # the others' lengths fix N
    start = poisson_packing(n, sigma, seed=3, container=spec)
    res = fb.run_fb(start, 2e-3, progress_interval=1e9)
    p, c = res.packing, res.stats
    assert c.stop_reason == "converged" and c.extras.rho_outer <= c.extras.rho_inner
    assert p.container == start.container and p.metadata["parameters"]["container"] == start.container.spec
    overlap, penetration = _brute_force(p)
    assert overlap <= 1e-10 and penetration <= 1e-10
    assert max(overlap, penetration) == pytest.approx(0.0, abs=1e-12)  # the closest pair or a sphere-wall touches
    # the nominal diameters fill phi_nominal of the container's volume (not of its frame): phi = phi_nominal rho_in^3
    assert p.phi == pytest.approx(c.phi_final, rel=1e-12) and p.phi == pytest.approx(
        fb.nominal_density_for_rate(2e-3) * c.extras.rho_inner**3, rel=1e-12)
    assert res.history["phi_outer"][0] == pytest.approx(1.2 * fb.nominal_density_for_rate(2e-3), rel=1e-12)
    # a small container's walls loosen the packing well below the bulk's (FB at this rate: ~0.58 in a periodic cube)
    assert 0.40 < p.phi < 0.60


def test_fb_in_a_non_cubic_periodic_box_is_bulk_like():
    start = poisson_packing(None, 0.0, seed=2, container="periodic:x=6,y=7,z=8")
    p = fb.run_fb(start, 2e-3, progress_interval=1e9).packing
    overlap, _ = _brute_force(p)
    assert overlap == pytest.approx(0.0, abs=1e-12)
    assert 0.55 < p.phi < 0.62


def test_checkpoint_resume_in_a_container_matches_uninterrupted_run(tmp_path):
    start = poisson_packing(None, 0.2, seed=4, container="cylinder:diameter=4,length=5")
    full = fb.run_fb(start, 2e-3, progress_interval=1e9)
    ck = tmp_path / "fb.ck.h5"
    part = fb.run_fb(start, 2e-3, max_iterations=30, checkpoint=ck, progress_interval=1e9)
    assert part.stats.steps == 30 and ck.exists()
    resumed = fb.run_fb(start, 2e-3, checkpoint=ck, progress_interval=1e9)
    assert resumed.stats.resumed and resumed.stats.completed
    np.testing.assert_array_equal(full.packing.positions, resumed.packing.positions)
    np.testing.assert_array_equal(full.packing.diameters, resumed.packing.diameters)
