"""Structure in a container: sphere-wall contacts, rattlers with walls that are never rattlers, the container's
isostatic count, layers at the wall, and `spherejam analyze` on a container packing."""

import json
import math

import numpy as np
import pytest

from spherejam.analysis import contacts, layers, structure
from spherejam.cli import main
from spherejam.core.container import Container
from spherejam.core.packing import Packing
from spherejam.core.packing_io import write_packing
from spherejam.core.rattlers import rattler_mask
from spherejam.core.seeding import poisson_packing
from spherejam.engines.lubachevsky_stillinger import run_ls


def square_layer(m=3, top=False):
    """m x m touching unit spheres on the wall z = 0 of a periodic slab of side m (each touches 4 spheres and the
    wall); ``top`` adds one sphere in a hollow of the layer, touching the 4 below it and the wall z = h."""
    g = np.arange(m) + 0.5
    pos = [(x, y, 0.5) for x in g for y in g]
    h = 4.0
    if top:
        h = 0.5 + math.sqrt(0.5) + 0.5
        pos.append((1.0, 1.0, 0.5 + math.sqrt(0.5)))
    c = Container((float(m), float(m), h), (True, True, False), (False, False, True), spec=f"slab:height={h!r}")
    return Packing(np.array(pos), np.ones(len(pos)), math.nan, container=c)


def naive_rattlers(n, i, j, k, fixed):
    alive = np.ones(n, bool)
    while True:
        keep = alive[i] & alive[j]
        deg = np.bincount(i[keep], minlength=n) + np.bincount(j[keep], minlength=n) + fixed
        drop = alive & (deg < k)
        if not drop.any():
            return ~alive
        alive &= ~drop


@pytest.mark.parametrize("seed", range(6))
def test_k_core_with_fixed_contacts_equals_recursive_removal(seed):
    rng = np.random.default_rng(seed)
    n = int(rng.integers(5, 200))
    m = int(rng.integers(0, 3 * n))
    i, j = rng.integers(0, n, m), rng.integers(0, n, m)
    pairs = np.unique(np.sort(np.c_[i[i != j], j[i != j]], axis=1), axis=0)
    fixed = rng.integers(0, 3, n)
    got = rattler_mask(n, pairs[:, 0], pairs[:, 1], 4, fixed)
    assert np.array_equal(got, naive_rattlers(n, pairs[:, 0], pairs[:, 1], 4, fixed))
    assert got.sum() <= rattler_mask(n, pairs[:, 0], pairs[:, 1], 4).sum()


def test_wall_contacts_count_and_keep_spheres_out_of_the_rattlers():
    p = square_layer()
    out = contacts.analyze_contacts(p, contact_tolerance=1e-9)
    assert np.array_equal(out.wall_i, np.arange(9)) and np.all(out.wall == 4)  # wall 4: the plane z = 0
    assert np.array_equal(out.contacts_per_particle, np.full(9, 5))
    c = out.coordination
    assert c.n_contacts == 18 + 9 and c.z_mean == 5.0
    # with 5 contacts needed, each sphere keeps its place only through the wall
    assert not contacts.analyze_contacts(p, contact_tolerance=1e-9, min_contacts=5).rattler.any()
    assert rattler_mask(9, out.pair_i, out.pair_j, 5).all()
    # the container's isostatic count: 3 N' - 2 (two periodic translations) + 1
    assert c.isostatic_contacts == p.container.isostatic_contacts(9) == 3 * 9 - 2 + 1
    assert c.isostatic_excess == 27 - 26


def test_a_sphere_touching_the_top_wall_and_four_below():
    p = square_layer(top=True)
    out = contacts.analyze_contacts(p, contact_tolerance=1e-9)
    top = p.n - 1
    assert out.contacts_per_particle[top] == 5  # 4 spheres and the wall z = h
    assert set(out.wall[out.wall_i == top].tolist()) == {5}
    # moved off the top wall by 1e-6 of a radius it loses that contact (and presses on the four below)
    q = p.replace(positions=p.positions - np.r_[np.zeros((p.n - 1, 3)), [[0, 0, 1e-6]]])
    moved = contacts.analyze_contacts(q, contact_tolerance=1e-9)
    assert moved.contacts_per_particle[top] == 4 and top not in moved.wall_i


def test_a_sphere_in_a_box_corner_touches_three_walls():
    c = Container((3.0, 3.0, 3.0), (False,) * 3, (True,) * 3, spec="box")
    p = Packing(np.array([[0.5, 0.5, 0.5], [2.0, 2.0, 2.0]]), np.ones(2), math.nan, container=c)
    out = contacts.analyze_contacts(p, contact_tolerance=1e-9)
    assert out.wall_i.tolist() == [0, 0, 0] and out.wall.tolist() == [0, 2, 4]
    assert out.rattler.tolist() == [True, True]  # 3 walls < d + 1 = 4, and the other sphere touches nothing


def test_cylinder_wall_contact_and_zero_modes():
    r = 3.0
    c = Container((6.0, 6.0, 4.0), (False, False, True), (False, False, False), curved="cylinder", radius=r,
                  spec="cylinder")
    p = Packing(np.array([[5.5, 3.0, 1.0], [3.0, 3.0, 3.0]]), np.ones(2), math.nan, container=c)
    wall, h = contacts.wall_gaps(p)
    assert wall.tolist() == [[6], [6]]
    assert h[0, 0] == pytest.approx(0.0, abs=1e-15) and h[1, 0] == pytest.approx(5.0)
    out = contacts.analyze_contacts(p, contact_tolerance=1e-9)
    assert out.wall_i.tolist() == [0]
    assert c.isostatic_contacts(10) == 3 * 10 - 2 + 1  # translation along the axis and rotation about it


def test_layers_at_the_wall():
    p = square_layer(top=True)
    out = contacts.analyze_contacts(p, contact_tolerance=1e-9)
    lay = layers.by_layer(p, out)
    # the layer on z = 0 (centres 0.5 from it) and the top sphere (0.5 from z = h): both in layer 0
    assert lay.n.tolist() == [10]
    assert lay.wall_contacts_mean[0] == 1.0
    slab = Container((4.0, 4.0, 6.0), (True, True, False), (False, False, True), spec="slab:height=6.0")
    q = Packing(np.array([[1.0, 1.0, 0.5], [2.0, 2.0, 1.7], [3.0, 3.0, 2.9]]), np.ones(3), math.nan, container=slab)
    lay = layers.by_layer(q, contacts.analyze_contacts(q, contact_tolerance=1e-9), q6_per_particle=np.r_[0.5, 0.6,
                                                                                                            math.nan])
    assert lay.n.tolist() == [1, 1, 1]
    assert lay.q6_local[:2].tolist() == [0.5, 0.6] and math.isnan(lay.q6_local[2])  # not estimable
    assert lay.as_dict()["q6_local"][2] is None


def test_analyze_a_container_packing(tmp_path, capsys):
    p = run_ls(poisson_packing(200, sigma=0.3, seed=4, container="cylinder:diameter=5"), 0.1, p_max=1e6, seed=4,
               progress_interval=1e9).packing
    path = tmp_path / "cyl.h5"
    write_packing(path, p)
    container = {}
    out = structure.analyze(p, pore_samples=1000, container=container)
    assert list(out) == list(structure.VARIABLES)
    assert math.isnan(out["voronoi_k"]) and math.isnan(out["pore_size_entropy"])
    assert math.isfinite(out["q6_local"]) and math.isfinite(out["crystalline_fraction"])
    assert set(structure.unavailable(p)) == {"voronoi", "pore_size_entropy"}
    assert container["profile"]["kind"] == "radial" and container["core"]["phi"] is None  # D/d = 5: no core at 5 d
    assert container["profile"]["porosity"][0] > 0.9 and min(container["profile"]["porosity"][:20]) < 0.5
    assert container["wall_contacts"] == int(np.count_nonzero(contacts.wall_gaps(p)[1] < out["contact_tolerance"]))
    assert main(["analyze", str(path), "--json"]) == 0
    record = json.loads(capsys.readouterr().out)
    assert record["not_available"]["voronoi"].startswith("not available in a container (n/a:")
    assert record["container"]["achieved"]["diameter"] == pytest.approx(2 * p.container.radius / p.mean_diameter)
    assert main(["analyze", str(path)]) == 0
    assert "core phi (5 d from every wall" in capsys.readouterr().out


def test_tolerance_scan_counts_the_walls():
    scan = contacts.tolerance_scan(square_layer(), np.array([1e-9, 1e-6, 1e-3]))
    assert scan["z_mean"].tolist() == [5.0, 5.0, 5.0]
    assert scan["isostatic_contacts"].tolist() == [26, 26, 26]
