"""CALiPPSO in a container (docs/containers.md §5): the sphere-wall rows (exact for a plane, with the chord margin for a
cylinder or a sphere), the gauge pins of the zero modes, and small packings certified in every shape, checked against
the shape's own isostatic count by brute force (forces summed here, wall gaps measured here)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from spherejam.calippso.constraints import constraint_rows, cutoff_rows
from spherejam.calippso.run import run_calippso
from spherejam.calippso.walls import LPWalls, concave_margin
from spherejam.core.container import Container
from spherejam.core.seeding import poisson_packing
from spherejam.engines.lubachevsky_stillinger import run_ls

#: spec, N (None: fixed by the spec), and the zero modes of the shape, written out here (docs/containers.md §4)
SHAPES = {
    "periodic box": ("periodic:x=4,y=4,z=7", 60, 3),
    "slab": ("slab:height=4", 40, 2),
    "box": ("box:x=4,y=4,z=4", None, 0),
    "cylinder": ("cylinder:diameter=4", 40, 2),
    "capped cylinder": ("cylinder:diameter=4,length=4,capped=yes", None, 1),
    "sphere": ("sphere:diameter=5", None, 3),
}


def _slab(h=3.0):
    return Container((4.0, 4.0, h), (True, True, False), (False, False, True), spec="slab")


def _curved(kind, radius=2.0):
    length = 2 * radius
    if kind == "cylinder":
        return Container((length, length, 6.0), (False, False, True), (False,) * 3, "cylinder", radius, 2,
                         spec="cylinder")
    return Container((length,) * 3, (False,) * 3, (False,) * 3, "sphere", radius, spec="sphere")


def test_a_plane_row_is_the_mirror_image_row():
    """A sphere (r = 0.5) at height h = 0.6 over the plane z = 0 and at 0.62 below z = 3: rows h^2 - 2h n.s, exactly
    the pair row of its mirror image (r_iw = h n, sigma = r), and the exact gap (h + n.s)^2 >= Gamma r^2 holds for
    every step the row admits."""
    walls = LPWalls.of(_slab(), 1.0, 2)
    x = np.array([[1.0, 1.0, 0.6], [3.0, 3.0, 2.38]])
    dia = np.array([1.0, 1.0])
    pi, pj, rij, sigma2 = walls.rows(x, dia, 1.1, 0.05)
    assert pi.tolist() == [0, 1] and pj.tolist() == [2, 3]  # wall nodes after the spheres: z = 0, then z = 3
    np.testing.assert_allclose(rij, [[0, 0, 0.6], [0, 0, -0.62]], atol=1e-15)
    np.testing.assert_allclose(sigma2, [0.25, 0.25])
    start, index, value, rhs = constraint_rows(rij, sigma2, pi, pj, walls.nodes)
    row0 = dict(zip(index[start[0]:start[1]].tolist(), value[start[0]:start[1]].tolist()))
    assert row0[2] == pytest.approx(-1.2) and row0[0] == 0 and row0[1] == 0  # -2h on s_z of sphere 0
    assert row0[walls.nodes * 3] == pytest.approx(0.25) and rhs[0] == pytest.approx(0.36)  # r^2 Gamma <= h^2
    # beyond sqrt(Gamma_max) r + sqrt(d) s_bound = 0.637 from both walls: no row (no step can reach them)
    assert walls.rows(np.array([[1.0, 1.0, 0.64], [1.0, 1.0, 2.36]]), np.array([1.0, 1.0]), 1.1, 0.05)[0].size == 0
    rng = np.random.default_rng(3)
    admitted = 0
    for _ in range(2000):
        s, gamma = rng.uniform(-0.05, 0.05, 3), rng.uniform(1.0, 1.1 ** 2)
        if rij[0] @ rij[0] + 2 * rij[0] @ s >= gamma * sigma2[0]:
            admitted += 1
            assert 0.6 + s[2] >= math.sqrt(gamma) * 0.5
    assert admitted > 100


@pytest.mark.parametrize("kind", ["cylinder", "sphere"])
def test_no_step_a_curved_wall_row_admits_crosses_the_wall(kind):
    """Spheres touching the inside of a cylinder or a sphere (R = 2, r = 0.5): every step within the s bound that the
    row admits keeps the centre within R - sqrt(Gamma) r, searched at the worst place (the row's boundary, moved
    the whole bound along the wall). Without the margin the same search finds steps through the wall."""
    container = _curved(kind)
    walls = LPWalls.of(container, 1.0, 1)
    s_bound, sqrt_gmax = 0.02, 1.05
    rng = np.random.default_rng(5)
    found_without = 0
    for trial in range(300):
        u = rng.normal(size=3)
        if kind == "cylinder":
            u[2] = 0.0
        u /= np.linalg.norm(u)
        x = container.centre + (2.0 - 0.5) * u
        x[2] = 3.0 if kind == "cylinder" else x[2]
        for margin in (True, False):
            pi, pj, rij, sigma2 = walls.rows(x[None, :], np.array([1.0]), sqrt_gmax, s_bound, margin)
            assert pi.size == 1 and pj[0] == 1
            n_in = rij[0] / np.linalg.norm(rij[0])
            np.testing.assert_allclose(n_in, -u, atol=1e-12)  # towards the axis or the centre
            expected = concave_margin(2.0, 0.5, sqrt_gmax, s_bound, walls.across) if margin else 0.0
            assert np.linalg.norm(rij[0]) == pytest.approx(0.5 - expected, abs=1e-15)
            for _ in range(20):
                gamma = rng.uniform(1.0, sqrt_gmax ** 2)
                # the largest inward-free step the row admits: along -n_in as far as the row allows, and the whole
                # bound along the wall (the chord error grows with it)
                t = rng.choice([-1.0, 1.0], size=3) * s_bound
                t -= (t @ n_in) * n_in
                c = rij[0]
                # row: |c|^2 + 2 c.(t + a n_in) >= gamma r^2  ->  the smallest a
                a = (gamma * sigma2[0] - c @ c - 2 * c @ t) / (2 * c @ n_in)
                s = t + a * n_in
                if np.max(np.abs(s)) > s_bound:
                    continue
                p = x + s - container.centre
                if kind == "cylinder":
                    p[2] = 0.0
                gap = 2.0 - np.linalg.norm(p) - math.sqrt(gamma) * 0.5
                if margin:
                    assert gap >= -1e-15, (trial, gap)
                else:
                    found_without += gap < -1e-9
    assert found_without > 0  # the plain tangent row is not conservative: the margin is needed


@pytest.mark.parametrize("kind", ["cylinder", "sphere"])
def test_the_gauge_pins_fix_exactly_the_zero_modes(kind, rng):
    """The zero modes (translations along periodic axes, rotations about the cylinder's axis or the sphere's centre)
    leave every pair and wall row unchanged, and the pinned components form a nonsingular matrix of them: the pins
    remove those modes and nothing else."""
    container = _curved(kind)
    walls = LPWalls.of(container, 1.0, 30)
    p = rng.normal(size=(30, 3))
    if kind == "cylinder":
        p[:, 2] = 0.0
    radius = rng.uniform(0.0, 1.5, 30)
    radius[:6] = 1.5  # touching the wall
    p *= (radius / np.linalg.norm(p, axis=1))[:, None]
    x = container.centre + p
    if kind == "cylinder":
        x[:, 2] = rng.uniform(0, 6.0, 30)
    dia = np.full(30, 1.0)
    modes = walls.zero_modes(x)
    assert modes.shape[0] == container.zero_modes == (2 if kind == "cylinder" else 3)
    pins = walls.gauge(x, 0)
    assert pins.zero_modes == modes.shape[0]
    gauge = modes.reshape(modes.shape[0], -1)[:, pins.gauge]
    assert abs(np.linalg.det(gauge)) > 1e-3
    from spherejam.core.neighbours import Frame

    pi, pj, rij = cutoff_rows(x, Frame.of(container), np.full(30, 2.0))
    wi, wj, wr, _ = walls.rows(x, dia, 1.1, 0.01, margin=False)
    pi, pj, rij = np.concatenate([pi, wi]), np.concatenate([pj, wj]), np.concatenate([rij, wr])
    assert wi.size > 0
    for mode in modes:
        s = np.vstack([mode, np.zeros((walls.count, 3))])
        np.testing.assert_allclose(np.einsum("ij,ij->i", rij, s[pi] - s[pj]), 0.0, atol=1e-12)


@pytest.fixture(scope="module")
def certified():
    out = {}
    for name, (spec, n, _) in SHAPES.items():
        start = poisson_packing(n, sigma=0.3 if name == "periodic box" else 0.0, seed=5, container=spec)
        ls = run_ls(start, 1e-2, p_max=1e5, seed=1, progress_interval=1e9).packing
        out[name] = (ls, run_calippso(ls, progress_interval=1e9, max_iterations=200))
    return out


@pytest.mark.parametrize("name", list(SHAPES))
def test_small_packings_are_certified_in_every_shape(certified, name):
    """LS outputs (p = 1e5) in each shape: converged as strictly as in bulk, isostatic by the shape's count, the
    forces (sphere-sphere and sphere-wall) balanced on every stable sphere to 1e-10 when summed here, every wall
    contact a real contact, no overlap and no penetration beyond 1e-10 of a radius."""
    spec, _, zero_modes = SHAPES[name]
    ls, r = certified[name]
    c = r.packing.container
    assert c.spec == ls.container.spec and c.lengths == ls.container.lengths  # the packing keeps its container
    assert r.completed, r.stop_reason
    assert abs(r.history["sqrt_inflation_minus_1"][-1]) <= 1e-12
    assert r.history["max_displacement"][-1] <= 1e-9
    # isostatic by the shape's own count: contacts = 3 N_s - z + 1, z written out above
    assert r.isostatic and r.n_contacts == 3 * r.n_stable - zero_modes + 1 == c.isostatic_contacts(r.n_stable)
    assert r.n_contacts == len(r.pairs) + len(r.wall_contacts)
    assert (len(r.wall_contacts) > 0) == c.has_walls
    # force balance, summed here: forces are f n, n from j to i (pairs) and from the wall to the sphere
    net = np.zeros((r.packing.n, 3))
    np.add.at(net, r.pairs[:, 0], r.forces[:, None] * r.contact_vectors)
    np.add.at(net, r.pairs[:, 1], -r.forces[:, None] * r.contact_vectors)
    np.add.at(net, r.wall_contacts, r.wall_forces[:, None] * r.wall_vectors)
    assert np.max(np.linalg.norm(net[~r.rattlers], axis=1)) <= 1e-10
    assert r.force_balance_residual <= 1e-10
    assert np.all(r.forces > 0) and np.all(r.wall_forces > 0)
    # every wall contact touches its wall, and its force points away from it
    x, rad = r.packing.positions, 0.5 * r.packing.diameters
    gaps = c.wall_distance(x[r.wall_contacts]) / rad[r.wall_contacts] - 1.0
    assert np.all(np.abs(gaps) <= 1e-9), gaps
    # no overlap, no penetration: brute force over all pairs (minimum image along periodic axes only)
    d = x[:, None, :] - x[None, :, :]
    for k in range(3):
        if c.periodic[k]:
            d[..., k] -= c.lengths[k] * np.round(d[..., k] / c.lengths[k])
    dist = np.linalg.norm(d, axis=2) + np.eye(len(x)) * 1e9
    sigma = rad[:, None] + rad[None, :]
    assert np.max(1.0 - dist / sigma) <= 1e-10
    assert np.max((rad - c.wall_distance(x)) / rad) <= 1e-10


def test_the_cli_certifies_in_a_container_and_keeps_it(certified, tmp_path, capsys):
    """`spherejam calippso` on a packing in a capped cylinder: the output keeps the container, the summary's isostatic
    excess is against the shape's own count, and the file's contact group holds the wall contacts."""
    import json

    import h5py

    from spherejam.cli import main
    from spherejam.core.packing_io import read_packing, write_packing

    ls, _ = certified["capped cylinder"]
    src, out = tmp_path / "in.h5", tmp_path / "out.h5"
    write_packing(src, ls)
    assert main(["calippso", str(src), "-o", str(out), "--json"]) == 0
    summary = json.loads(capsys.readouterr().out)
    assert summary["is_isostatic"] == 1.0 and summary["isostatic_excess"] == 0.0
    jammed = read_packing(out)
    assert jammed.container.to_dict() == ls.container.to_dict()
    assert jammed.container.wall_penetration(jammed.positions, jammed.diameters)[0] <= 1e-10
    with h5py.File(out) as f:
        walls = f["contacts/walls"][()]
        assert len(f["contacts/wall_contacts"]) == len(walls) > 0 and set(walls) <= {0, 1, 2}  # caps, then the tube


def test_a_container_run_resumes_from_its_checkpoint_on_the_same_path(certified, tmp_path):
    """The sphere container's run stopped after 3 LPs and resumed takes the uninterrupted run's path, bit for bit: the
    gauge pins and the step bound that follows the previous step (docs/containers.md §5) come back from the
    checkpoint; a checkpoint of the same spheres in another container is not taken for it."""
    ls, ref = certified["sphere"]
    assert ref.iterations > 3
    ckpt = tmp_path / "c.h5"
    part = run_calippso(ls, max_iterations=3, checkpoint=ckpt, checkpoint_interval=0, progress_interval=1e9)
    assert part.stop_reason == "max_iterations" and ckpt.exists()
    done = run_calippso(ls, checkpoint=ckpt, progress_interval=1e9, max_iterations=200)
    assert done.completed and done.iterations == ref.iterations
    np.testing.assert_array_equal(done.packing.positions, ref.packing.positions)
    np.testing.assert_array_equal(done.wall_forces, ref.wall_forces)
    for key in ("sqrt_inflation_minus_1", "s_bound", "n_contacts", "phi"):
        np.testing.assert_array_equal(done.history[key], ref.history[key], err_msg=key)
    from spherejam.core.errors import PackingFileError

    run_calippso(ls, max_iterations=1, checkpoint=ckpt, checkpoint_interval=0, progress_interval=1e9)
    import dataclasses

    # the same spheres, the same frame, a sphere wall 1 % wider
    bigger = ls.replace(container=dataclasses.replace(ls.container, radius=1.01 * ls.container.radius))
    with pytest.raises(PackingFileError, match="different input or parameters"):
        run_calippso(bigger, checkpoint=ckpt, progress_interval=1e9)


def _states(r):
    """(states of self-stress, floppy modes) of the certified network, by the rank of its rigidity matrix built here:
    one row per contact among non-rattlers (+u on its sphere, -u on its partner; a wall row only +u), 3 columns per
    non-rattler."""
    stable = np.flatnonzero(~r.rattlers)
    col = np.full(r.packing.n, -1)
    col[stable] = np.arange(stable.size)
    rows = np.zeros((len(r.pairs) + len(r.wall_contacts), 3 * stable.size))
    for k, ((i, j), u) in enumerate(zip(r.pairs, r.contact_vectors)):
        rows[k, 3 * col[i]:3 * col[i] + 3] += u
        rows[k, 3 * col[j]:3 * col[j] + 3] -= u
    for k, (i, u) in enumerate(zip(r.wall_contacts, r.wall_vectors), start=len(r.pairs)):
        rows[k, 3 * col[i]:3 * col[i] + 3] = u
    sv = np.linalg.svd(rows, compute_uv=False)
    rank = int(np.sum(sv > 1e-9 * sv[0]))
    return rows.shape[0] - rank, rows.shape[1] - rank


@pytest.mark.parametrize("name", list(SHAPES))
def test_a_certified_network_has_one_state_of_self_stress_and_only_the_zero_modes(certified, name):
    """The count of docs/containers.md §4 as ranks: the certified contact network has exactly one state of self-stress
    (the pressure) and no floppy mode but the shape's zero modes and the partial rattlers' free directions."""
    _, r = certified[name]
    assert _states(r) == (1, SHAPES[name][2] + r.free_directions)


def _layer(above_gap, pin_above):
    """The LP rows of a wall-layer sphere 0 (r = 0.5, centre at z = r) loaded on three in-plane contacts at 120
    degrees to spheres 1-3 (pinned), touching the wall z = 0 (node 5) at zero force, sphere 4 straight above it at
    relative gap ``above_gap`` (zero force), pinned or not."""
    from spherejam.calippso.constraints import Pins

    angles = np.deg2rad([0.0, 120.0, 240.0])
    plane = np.c_[np.cos(angles), np.sin(angles), np.zeros(3)]
    rij = np.r_[-plane, [[0.0, 0.0, -(1.0 + above_gap)]], [[0.0, 0.0, 0.5]]]
    pi, pj = np.zeros(5, dtype=np.int64), np.array([1, 2, 3, 4, 5])
    sigma2 = np.array([1.0, 1.0, 1.0, 1.0, 0.25])
    duals = np.array([1.0, 1.0, 1.0, 0.0, 0.0])  # balanced: the three directions sum to 0
    pinned = [1, 2, 3, 5] + ([4] if pin_above else [])
    pins = Pins(np.sort(np.concatenate([np.arange(3 * k, 3 * k + 3) for k in pinned])), 5, 3)
    return rij, sigma2, pi, pj, duals, pins


def test_a_wall_layer_sphere_loaded_in_its_plane_escapes_unless_a_touching_row_holds_it():
    """docs/containers.md §5: sphere 0 is unheld (its loaded contacts span the plane only) and its free direction is
    away from the wall; the escape motion lifts it (and only in z: its loaded rows keep their length); a sphere
    touching it from above makes way if it can move, and holds it (no escape) if it cannot."""
    from spherejam.calippso.network import escape_motion, unheld_spheres

    rij, sigma2, pi, pj, duals, pins = _layer(0.1, pin_above=True)
    idx, free = unheld_spheres(rij, sigma2, pi, pj, duals, 6, 3, 1e-10, 5)
    assert idx.tolist() == [0] and np.allclose(free, [[0.0, 0.0, 1.0]])
    v = escape_motion(rij, sigma2, pi, pj, duals, 6, 3, 1e-10, pins, 1e-3)
    np.testing.assert_allclose(v[0], [0.0, 0.0, 1.0], atol=1e-12)
    assert not np.any(v[[1, 2, 3, 5]])  # pinned
    rij, sigma2, pi, pj, duals, pins = _layer(0.0, pin_above=False)  # sphere 4 touches, free to go up
    v = escape_motion(rij, sigma2, pi, pj, duals, 6, 3, 1e-10, pins, 1e-3)
    assert v[0, 2] == pytest.approx(1.0) and v[4, 2] >= v[0, 2] - 1e-12
    rij, sigma2, pi, pj, duals, pins = _layer(0.0, pin_above=True)  # sphere 4 touches and cannot move
    assert escape_motion(rij, sigma2, pi, pj, duals, 6, 3, 1e-10, pins, 1e-3) is None


def test_a_monodisperse_box_is_certified_after_its_wall_layer_escapes(monkeypatch):
    """An MLS output (N = 150, monodisperse, closed box) whose LPs converge with a wall-layer sphere loaded only in
    its plane (docs/containers.md §5): without the escape the run stops there; with it phi grows (that state was not
    jammed) and the result is certified, with one state of self-stress by rank."""
    import spherejam.calippso.run as run_module
    from spherejam.engines.closest_jamming import find_closest_jamming

    start = poisson_packing(150, psd="lognormal:sigma=0", container="box:x=4.018,y=6.278", seed=2)
    mls = find_closest_jamming(start, initial_rate=10.0, decrease_factor=2.0, final_rate=1e-2, seed=3,
                               progress_interval=1e9).packing
    r = run_calippso(mls, progress_interval=1e9)
    c = r.packing.container
    assert r.completed and r.counters["escapes"] >= 1
    assert r.isostatic and r.n_contacts == 3 * r.n_stable + 1 - r.free_directions == c.isostatic_contacts(
        r.n_stable, r.free_directions)
    assert r.force_balance_residual <= 1e-10 and r.packing.check(1e-10).ok
    assert c.wall_penetration(r.packing.positions, r.packing.diameters)[0] <= 1e-10
    assert _states(r) == (1, r.free_directions)
    # where the LPs first converge, the count holds with the unheld sphere's free direction taken off it, but the
    # packing is not jammed: the escape lets phi grow
    monkeypatch.setattr(run_module, "_escape", lambda run, cfg: False)
    stuck = run_calippso(mls, progress_interval=1e9)
    assert stuck.completed and stuck.free_directions >= 1
    assert r.packing.phi > stuck.packing.phi * (1.0 + 1e-8)  # measured: 3.2e-8 (a 1e-9 gain ends the escapes)
