"""Porosity profiles and the core phi: exact intersection volumes, hand results for one sphere and a wall layer,
integration back to phi in every container, periodic images along a periodic axis."""

import math

import numpy as np
import pytest
from scipy import integrate

from spherejam.analysis import profiles
from spherejam.core.container import Container
from spherejam.core.errors import InputError
from spherejam.core.packing import Packing
from spherejam.core.seeding import poisson_packing


def slab(lx, ly, h):
    return Container((lx, ly, h), (True, True, False), (False, False, True), spec=f"slab:height={h!r}")


def cylinder(radius, length, capped=False):
    d = 2.0 * radius
    return Container((d, d, length), (False, False, not capped), (False, False, capped), curved="cylinder",
                     radius=radius, spec="cylinder")


def sphere_container(radius):
    d = 2.0 * radius
    return Container((d, d, d), (False,) * 3, (False,) * 3, curved="sphere", radius=radius, spec="sphere")


def cap(r, h):
    """Volume of a spherical cap of height h of a sphere of radius r."""
    return math.pi * h * h * (3 * r - h) / 3.0


# --- intersection volumes -----------------------------------------------------------------------------------------


@pytest.mark.parametrize("rho", [0.05, 0.3, 0.499999, 0.5, 0.8])
def test_coaxial_sphere_cylinder_is_the_closed_form(rho):
    r = 0.5
    exact = 4.0 / 3.0 * math.pi * (r**3 - max(r * r - rho * rho, 0.0) ** 1.5)
    assert abs(profiles.sphere_cylinder_volume(r, 0.0, rho) - exact) < 1e-12 * r**3


@pytest.mark.filterwarnings("ignore::scipy.integrate.IntegrationWarning")  # quad's own round-off, near 1e-15
@pytest.mark.parametrize("delta, rho", [(0.3, 0.5), (2.0, 1.8), (3.3, 3.5), (0.5, 0.5), (0.1, 0.45), (0.9, 0.5)])
def test_offset_sphere_cylinder_matches_adaptive_quadrature(delta, rho):
    r = 0.5
    got = profiles.sphere_cylinder_volume(r, delta, rho)
    kinks = sorted(s * math.sqrt(r * r - v * v) for v in (abs(rho - delta), rho + delta) if v < r for s in (-1, 1))
    ref, _ = integrate.quad(lambda t: profiles.lens_area(math.sqrt(max(r * r - t * t, 0.0)), rho, delta), -r, r,
                            points=kinks or None, epsabs=1e-15, epsrel=1e-14, limit=500)
    assert abs(got - ref) < 1e-12
    assert abs(got - profiles.sphere_cylinder_volume(r, delta, rho, points=64)) < 1e-12
    assert 0.0 < got < 4.0 / 3.0 * math.pi * r**3


def test_lens_area_limits():
    assert profiles.lens_area(0.3, 1.0, 0.2) == pytest.approx(math.pi * 0.09, rel=1e-15)  # inside
    assert profiles.lens_area(0.3, 1.0, 1.31) == 0.0
    # a disc centred on the circle of a much larger disc: about half inside
    assert profiles.lens_area(1e-3, 1e3, 1e3) == pytest.approx(0.5 * math.pi * 1e-6, rel=1e-5)


def test_sphere_box_corners_and_slabs():
    r, v = 0.5, 4.0 / 3.0 * math.pi * 0.125
    for lo, share in (([-1, -1, -1], 1.0), ([0, -1, -1], 0.5), ([0, 0, -1], 0.25), ([0, 0, 0], 0.125)):
        assert abs(profiles.sphere_box_volume([0, 0, 0], r, lo, [1, 1, 1]) - share * v) < 1e-14
    inf = math.inf
    got = profiles.sphere_box_volume([0, 0, 0], r, [-inf, -inf, 0.2], [inf, inf, 1.0])
    assert abs(got - cap(r, 0.3)) < 1e-14
    c, lo, hi = np.array([0.1, -0.2, 0.15]), np.array([-0.3, -0.5, -0.2]), np.array([0.25, 0.1, 0.4])
    got = profiles.sphere_box_volume(c, r, lo, hi)
    assert abs(got - profiles.sphere_box_volume(c, r, lo, hi, points=64)) < 1e-12
    ref, _ = integrate.quad(
        lambda z: profiles.disc_rectangle_area(math.sqrt(max(r * r - (z - c[2]) ** 2, 0.0)), lo[0] - c[0],
                                               hi[0] - c[0], lo[1] - c[1], hi[1] - c[1]),
        lo[2], hi[2], epsabs=1e-15, epsrel=1e-13, limit=1000)
    assert abs(got - ref) < 1e-11


def test_disc_rectangle_area_against_quadrature():
    a, x1, x2, y1, y2 = 0.4, -0.1, 0.3, -0.35, 0.2
    kinks = [math.sqrt(a * a - y * y) * s for y in (y1, y2) for s in (-1, 1)]

    def chord(x):
        s = math.sqrt(max(a * a - x * x, 0.0))
        return max(0.0, min(y2, s) - max(y1, -s))

    ref, _ = integrate.quad(chord, x1, x2, points=[k for k in kinks if x1 < k < x2], epsabs=1e-15, limit=200)
    assert abs(profiles.disc_rectangle_area(a, x1, x2, y1, y2) - ref) < 1e-14
    assert profiles.disc_rectangle_area(a, -1, 1, -1, 1) == pytest.approx(math.pi * a * a, rel=1e-15)
    assert profiles.disc_rectangle_area(a, 0.5, 1, -1, 1) == 0.0


# --- hand results --------------------------------------------------------------------------------------------------


def test_one_sphere_on_a_flat_wall():
    """One sphere of radius r touching the wall z = 0: the bin [0, dz] holds pi (r dz^2 - dz^3 / 3)."""
    r, dz, h = 0.5, 0.1, 6.0
    pos = np.array([[1.0, 1.0, r], [3.0, 3.0, h - r]])  # the second sphere on the far wall, out of the first bins
    p = Packing(pos, np.ones(2), math.nan, container=slab(4.0, 4.0, h))
    prof = profiles.axial_profile(p, bin_width=dz)
    area = 16.0
    assert prof.phi[0] == pytest.approx(math.pi * (r * dz**2 - dz**3 / 3.0) / (area * dz), rel=1e-13)
    assert prof.solid[4] == pytest.approx(cap(r, 0.5) - cap(r, 0.4), rel=1e-13)
    np.testing.assert_allclose(prof.solid[:10].sum(), 4.0 / 3.0 * math.pi * r**3, rtol=1e-14)
    assert prof.porosity[10:-10].min() == 1.0  # nothing in the middle
    folded = profiles.axial_profile(p, bin_width=dz, fold=True)
    assert folded.phi[0] == pytest.approx(2 * math.pi * (r * dz**2 - dz**3 / 3.0) / (2 * area * dz), rel=1e-13)


def test_a_square_layer_on_a_wall():
    """m x m touching unit spheres on the wall of a periodic slab: phi(z) = pi (r^2 - (z - r)^2) per unit area, so
    each bin holds [F(z2) - F(z1)] / dz with F the cap volume; a sphere crossing a periodic face changes nothing."""
    m, r, h = 4, 0.5, 5.0
    g = (np.arange(m) + 0.5)
    xy = np.array([(x, y) for x in g for y in g]) - 0.5  # half the spheres cross the periodic faces x = 0, y = 0
    pos = np.c_[xy, np.full(m * m, r)]
    p = Packing(pos, np.ones(m * m), math.nan, container=slab(float(m), float(m), h))
    prof = profiles.axial_profile(p, bin_width=0.125)
    below = [cap(r, min(max(z, 0.0), 2 * r)) for z in prof.edges[:9]]
    np.testing.assert_allclose(prof.phi[:8], np.diff(below) / 0.125, rtol=1e-13)
    assert np.all(prof.phi[8:] == 0.0)
    assert prof.mean_phi() == pytest.approx(p.phi, rel=1e-14)


def test_one_sphere_on_a_cylinder_axis_and_in_a_sphere():
    r, radius = 0.5, 3.0
    pos = np.array([[radius, radius, 2.0], [radius, radius, 5.0]])  # two spheres on the axis
    p = Packing(pos, np.ones(2), math.nan, container=cylinder(radius, 7.0))
    prof = profiles.radial_profile(p, bin_width=0.1)
    rho = radius - prof.edges  # the annulus [rho_in, rho_out] of each bin
    inside = 2 * 4.0 / 3.0 * math.pi * (r**3 - np.maximum(r * r - rho**2, 0.0) ** 1.5)
    np.testing.assert_allclose(prof.solid, inside[:-1] - inside[1:], rtol=1e-12, atol=1e-15)
    np.testing.assert_allclose(prof.volume, math.pi * (rho[:-1] ** 2 - rho[1:] ** 2) * 7.0, rtol=1e-13)
    assert prof.porosity[0] == 1.0  # the wall bin is empty

    q = Packing(np.array([[radius, radius, radius], [radius, radius + 2.0, radius]]), np.ones(2), math.nan,
                container=sphere_container(radius))
    shells = profiles.radial_profile(q, bin_width=0.1)
    assert shells.phi[-1] == pytest.approx(1.0, rel=1e-13)  # the innermost shell lies inside the central sphere
    assert shells.mean_phi() == pytest.approx(q.phi, rel=1e-13)


@pytest.mark.parametrize("spec, n", [("cylinder:diameter=6", 200), ("cylinder:diameter=5,length=6,capped=yes", None),
                                     ("sphere:diameter=7", None), ("slab:height=5", 200), ("box:x=4,y=5,z=6", None)])
def test_profiles_integrate_back_to_phi(spec, n):
    p = poisson_packing(n, sigma=0.3, seed=3, container=spec)
    prof = profiles.profile(p, bin_width=0.037)
    assert prof.mean_phi() == pytest.approx(p.phi, rel=1e-12)
    if p.container.curved != "sphere":
        assert profiles.axial_profile(p, bin_width=0.11).mean_phi() == pytest.approx(p.phi, rel=1e-12)
    assert profiles.core(p, 0.0).phi == pytest.approx(p.phi, rel=1e-12)


def test_periodic_images_along_a_periodic_axis():
    """A sphere crossing the periodic face x = 0: its two pieces land in the first and the last bins."""
    r = 0.5
    pos = np.array([[0.2, 2.0, 2.0], [2.0, 2.0, 0.6]])
    p = Packing(pos, np.ones(2), math.nan, container=slab(4.0, 4.0, 4.0))
    prof = profiles.axial_profile(p, axis=0, bin_width=0.25)
    area = 16.0
    # the piece beyond x = 0 is a cap of height r - 0.2 = 0.3 re-entering at x = 4
    assert prof.solid[-1] == pytest.approx(cap(r, 0.3) - cap(r, 0.05), rel=1e-13)
    assert prof.solid[0] == pytest.approx(cap(r, 0.25 + 0.3) - cap(r, 0.3), rel=1e-13)
    assert prof.mean_phi() == pytest.approx(p.phi, rel=1e-14)
    assert prof.volume[0] == pytest.approx(area * 0.25)


def test_core_by_hand():
    r = 0.5
    # slab of height 12: core from 5 to 7; one sphere straddles z = 5, one lies whole inside, one outside
    pos = np.array([[1.0, 1.0, 5.1], [2.5, 2.5, 6.0], [1.0, 3.0, 1.0]])
    p = Packing(pos, np.ones(3), math.nan, container=slab(4.0, 4.0, 12.0))
    c = profiles.core(p, 5.0)
    assert c.volume == pytest.approx(16.0 * 2.0)
    assert c.solid == pytest.approx(cap(r, 0.6) + 4.0 / 3.0 * math.pi * r**3, rel=1e-13)
    assert c.fraction_of_container == pytest.approx(2.0 / 12.0)
    # cylinder of radius 3, core at 1 d: radius 2; a sphere on the axis counts whole, one touching the wall not
    q = Packing(np.array([[3.0, 3.0, 1.0], [5.5, 3.0, 3.0]]), np.ones(2), math.nan, container=cylinder(3.0, 4.0))
    cq = profiles.core(q, 1.0)
    assert cq.solid == pytest.approx(4.0 / 3.0 * math.pi * r**3, rel=1e-13)
    assert cq.volume == pytest.approx(math.pi * 4.0 * 4.0)
    # the same cylinder capped: core heights 1 ... 3 cut the axis sphere at z = 1 in half
    qc = Packing(q.positions, q.diameters, math.nan, container=cylinder(3.0, 4.0, capped=True))
    assert profiles.core(qc, 1.0).solid == pytest.approx(0.5 * 4.0 / 3.0 * math.pi * r**3, rel=1e-13)
    # a closed box 6^3 with core 2 ... 4: a sphere at a corner of the core region keeps an eighth
    b = Container((6.0, 6.0, 6.0), (False,) * 3, (True,) * 3, spec="box")
    pb = Packing(np.array([[2.0, 2.0, 2.0], [5.0, 5.0, 5.0]]), np.ones(2), math.nan, container=b)
    assert profiles.core(pb, 2.0).solid == pytest.approx(4.0 / 3.0 * math.pi * r**3 / 8, rel=1e-13)
    assert math.isnan(profiles.core(pb, 3.5).phi)


def test_bad_requests_are_refused():
    p = poisson_packing(100, container="slab:height=4", seed=1)
    with pytest.raises(InputError, match="radial profile"):
        profiles.radial_profile(p)
    with pytest.raises(InputError, match="bin_width"):
        profiles.axial_profile(p, bin_width=0.0)
    q = poisson_packing(None, container="sphere:diameter=6", seed=1)
    with pytest.raises(InputError, match="axial profile"):
        profiles.axial_profile(q)
