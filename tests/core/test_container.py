"""The container model: specs, sizing from N, geometry, refusals (docs/containers.md §1)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from spherejam.core import container as containers
from spherejam.core.container import Container, build, parse
from spherejam.core.errors import InputError
from spherejam.core.packing import Packing
from spherejam.core.packing_io import read_packing, write_packing
from spherejam.core.seeding import poisson_packing


@pytest.mark.parametrize("spec, shape, lengths, capped", [
    ("periodic", "periodic", {}, False),
    ("periodic:x=10,z=40", "periodic", {"x": 10.0, "z": 40.0}, False),
    ("slab:height=8", "slab", {"height": 8.0}, False),
    ("box:x=5,y=6,z=7", "box", {"x": 5.0, "y": 6.0, "z": 7.0}, False),
    ("cylinder:diameter=10", "cylinder", {"diameter": 10.0}, False),
    ("cylinder:diameter=10,length=20,capped=yes", "cylinder", {"diameter": 10.0, "length": 20.0}, True),
    (" Sphere : diameter = 12 ", "sphere", {"diameter": 12.0}, False),
])
def test_specs_parse_and_print_back_the_same(spec, shape, lengths, capped):
    s = parse(spec)
    assert (s.shape, s.lengths, s.capped) == (shape, lengths, capped)
    assert parse(s.text) == s


def test_a_recorded_spec_reproduces_its_floats():
    s = parse("cylinder:diameter=7.123456789012345")
    assert parse(s.text).lengths["diameter"] == 7.123456789012345


@pytest.mark.parametrize("spec, fragment", [
    ("tube:diameter=3", "unknown shape 'tube'"),
    ("cylinder", "cylinder.diameter missing"),
    ("cylinder:length=4", "cylinder.diameter missing"),
    ("slab:height=-1", "slab.height='-1': must be a finite number > 0"),
    ("slab:height=nan", "must be a finite number > 0"),
    ("slab:height=abc", "slab.height='abc': must be a number"),
    ("sphere:diameter=5,diameter=6", "given twice"),
    ("box:w=3", "unknown parameter 'w'"),
    ("cylinder:diameter=5,capped=maybe", "must be yes or no"),
    ("slab:8", "must be NAME=VALUE"),
    ("", "must be a container spec"),
])
def test_bad_specs_are_refused_in_one_line_naming_the_field(spec, fragment):
    with pytest.raises(InputError) as err:
        parse(spec)
    message = str(err.value)
    assert message.startswith("container=") and fragment in message and "\n" not in message


def test_free_lengths_are_solved_from_n_and_the_density_estimate():
    nominal = np.ones(1000)
    volume = 1000 * math.pi / 6
    for spec in ("slab:height=6", "cylinder:diameter=8", "box:x=9,y=9", "periodic:x=8"):
        c = build(spec, 1000, nominal)
        assert c.volume == pytest.approx(volume / containers.PHI_ESTIMATE, rel=1e-12)
    c = build("cylinder:diameter=8", 1000, nominal)
    assert c.radius == 4.0 and c.periodic == (False, False, True) and c.curved == "cylinder"
    assert build("cylinder:diameter=8,capped=yes", 1000, nominal).planes == (False, False, True)
    slab = build("slab:height=6", 1000, nominal)
    assert slab.lengths[2] == 6.0 and slab.lengths[0] == slab.lengths[1] and slab.periodic == (True, True, False)


def test_a_spec_that_gives_every_length_fixes_n():
    n = containers.number_for("sphere:diameter=10", math.pi / 6)
    assert n == round(containers.PHI_ESTIMATE * 1000)  # (4/3 pi 5^3) / (pi/6) = 1000 mean spheres
    p = poisson_packing(None, seed=3, container="sphere:diameter=10")
    assert p.n == n and p.container.curved == "sphere"
    with pytest.raises(InputError, match="holds about 620"):
        poisson_packing(100, seed=3, container="sphere:diameter=10")


@pytest.mark.parametrize("spec, n, fragment", [
    ("cylinder:diameter=0.8", 200, "diameter=0.8 mean diameters cannot hold a sphere"),
    ("slab:height=1.5", 200, "cannot hold a sphere"),  # a sphere of the sample is 1.5+ mean diameters wide
    ("cylinder:diameter=40", 20, "periodic length along z"),  # 20 spheres make a disc thinner than a sphere
])
def test_a_container_too_small_for_its_spheres_is_refused_up_front(spec, n, fragment):
    with pytest.raises(InputError) as err:
        poisson_packing(n, sigma=0.3, seed=1, container=spec)
    assert fragment in str(err.value) and "\n" not in str(err.value)


def test_walls_and_distances_of_each_shape():
    c = Container((4.0, 4.0, 10.0), (False, False, True), (False, False, False), "cylinder", 2.0, 2, "cylinder:x")
    x = np.array([[2.0, 2.0, 3.0], [3.5, 2.0, 9.9], [2.0, 0.5, 0.1]])
    np.testing.assert_allclose(c.wall_distance(x), [2.0, 0.5, 0.5])
    assert c.volume == pytest.approx(math.pi * 4 * 10) and c.wall_area() == pytest.approx(2 * math.pi * 2 * 10)
    capped = Container((4.0, 4.0, 10.0), (False, False, False), (False, False, True), "cylinder", 2.0, 2, "c")
    np.testing.assert_allclose(capped.wall_distance(x), [2.0, 0.1, 0.1])
    assert capped.wall_area() == pytest.approx(2 * math.pi * 2 * 10 + 2 * math.pi * 4)
    ball = Container((6.0,) * 3, (False,) * 3, (False,) * 3, "sphere", 3.0, 2, "sphere:x")
    np.testing.assert_allclose(ball.wall_distance([[3.0, 3.0, 3.0], [3.0, 3.0, 5.5]]), [3.0, 0.5])
    slab = Container((5.0, 5.0, 3.0), (True, True, False), (False, False, True), spec="slab:x")
    np.testing.assert_allclose(slab.wall_distance([[0.0, 4.9, 1.0], [2.0, 2.0, 2.9]]), [1.0, 0.1])
    worst, i = slab.wall_penetration(np.array([[1.0, 1.0, 1.0], [1.0, 1.0, 0.4]]), np.array([1.0, 1.0]))
    assert i == 1 and worst == pytest.approx(0.2)  # radius 0.5, centre 0.4 from the wall


def test_packings_in_containers_check_walls_and_round_trip(tmp_path):
    p = poisson_packing(300, sigma=0.3, seed=5, container="cylinder:diameter=6,capped=yes")
    assert p.container.contains(p.positions).all()
    worst, _ = p.container.wall_penetration(p.positions, p.diameters)
    assert p.check().ok and worst <= 1e-12  # seeded: the closest pair or a sphere at a wall just touches
    assert worst >= -1e-12 or p.min_gap() == pytest.approx(0.0, abs=1e-12)
    write_packing(tmp_path / "p.h5", p)
    q = read_packing(tmp_path / "p.h5")
    assert q.container == p.container and np.array_equal(q.positions, p.positions)
    assert q.phi == pytest.approx(p.phi, rel=1e-15) and math.isnan(q.box)
    with pytest.raises(InputError, match="handles only a periodic cube"):
        q.require_cube("g(r)")
    # a sphere pushed into a wall is an overlap with it, reported as the pair (i, -1)
    x = p.positions.copy()
    x[0] = [p.container.centre[0], p.container.centre[1], 0.45 * p.diameters[0]]  # 10 % of its radius in the cap
    report = Packing(x, p.diameters, math.nan, {}, p.container).check()
    assert not report.ok and report.pair == (0, -1) and report.worst_overlap == pytest.approx(0.1)
    assert "wall" in str(report)


def test_a_centre_outside_the_walls_is_refused():
    c = build("sphere:diameter=10", None, np.ones(620))
    with pytest.raises(InputError, match="lies outside container"):
        Packing(np.array([[5.0, 5.0, 5.0], [0.2, 0.2, 0.2]]), np.array([0.1, 0.1]), math.nan, {}, c)


def test_the_periodic_cube_is_the_packing_of_old():
    p = poisson_packing(100, seed=1)
    assert p.container.is_periodic_cube and p.container.side == p.box and p.frame == p.box
    q = poisson_packing(100, seed=1, container="periodic")
    assert np.array_equal(p.positions, q.positions) and np.array_equal(p.diameters, q.diameters)


@pytest.mark.parametrize("spec, zero_modes", [
    ("periodic", 3), ("periodic:x=5", 3), ("slab:height=5", 2), ("box:x=5", 0), ("cylinder:diameter=5", 2),
    ("cylinder:diameter=5,capped=yes", 1), ("sphere:diameter=8", 3),
])
def test_the_isostatic_count_of_each_shape(spec, zero_modes):
    """d N - (zero modes) + 1: the translations along periodic axes, the rotation about a cylinder's axis, the three
    rotations in a sphere; d (N - 1) + 1 in a periodic box (docs/containers.md §4)."""
    n = None if spec.startswith("sphere") else 300
    c = poisson_packing(n, seed=1, container=spec).container
    assert c.zero_modes == zero_modes
    assert c.isostatic_contacts(100) == 3 * 100 - zero_modes + 1
    if spec == "periodic":
        assert c.isostatic_contacts(100) == 3 * (100 - 1) + 1


@pytest.mark.parametrize("spec", ["box:x=20,y=20", "cylinder:diameter=20,capped=yes"])
def test_a_walled_length_left_to_n_that_cannot_hold_a_sphere_is_refused(spec):
    """20 spheres in a 20 x 20 box leave z = 0.04 diameters: refused up front, not packed as a film."""
    with pytest.raises(InputError, match="walled length along z"):
        poisson_packing(20, seed=1, container=spec)
