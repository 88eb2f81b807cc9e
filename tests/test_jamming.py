"""spherejam.jam(): the one call composes seeding, generation, MLS and CALiPPSO reproducibly, and checks its input
(the worked example with certification is docs/python.md, run by tests/test_python_docs.py)."""

import numpy as np
import pytest

import spherejam
from spherejam.core.errors import InputError

QUICK_MLS = {"final_rate": 1e-1}


def test_same_seed_same_packing_other_seed_another():
    a = spherejam.jam(n=40, psd="gaussian:delta=0.2", protocol="fb", rate=0.01, closest=QUICK_MLS, seed=5)
    b = spherejam.jam(n=40, psd="gaussian:delta=0.2", protocol="fb", rate=0.01, closest=QUICK_MLS, seed=5)
    c = spherejam.jam(n=40, psd="gaussian:delta=0.2", protocol="fb", rate=0.01, closest=QUICK_MLS, seed=6)
    np.testing.assert_array_equal(a.packing.positions, b.packing.positions)
    assert a.phi_J == b.phi_J and a.phi_J != c.phi_J
    assert a.packing.check().ok  # no overlap beyond the file tolerance
    assert a.phi < a.phi_J  # MLS compresses the FB output further
    assert a.pressure >= 1e12 * 0.1 and a.packing.metadata["algorithm"] == "mls"
    assert len(set(a.provenance["seeds"].values())) == 3  # independent streams for seeding, generation, MLS


def test_fb_without_closest_has_no_pressure_and_box_sets_the_side():
    r = spherejam.jam(n=30, protocol="fb", rate=0.01, closest=False, seed=2, box=7.5)
    assert r.phi_J is None and r.pressure is None and r.certificate is None and r.stop_reason == "converged"
    assert r.packing.box == 7.5 and r.provenance["box"] == 7.5
    assert r.runs["generation"].packing is r.packing
    df = r.to_pandas()
    assert list(df.columns) == ["x", "y", "z", "diameter"] and len(df) == 30
    assert "phi_J" not in r.to_xarray().attrs  # None is left out of the netCDF attributes


@pytest.mark.parametrize("kwargs, field", [
    ({"protocol": "mls"}, "protocol="),
    ({"seed": -1}, "seed="),
    ({"box": 0.0}, "box="),
    ({"closest": "yes"}, "closest="),
    ({"psd": "nonsense:x=1"}, "nonsense"),
])
def test_bad_argument_is_one_input_error_naming_it(kwargs, field):
    with pytest.raises(InputError, match=field):
        spherejam.jam(n=10, **kwargs)


def test_jam_in_a_container():
    """A column by one call: the packing keeps its container, no sphere crosses the wall, the same seed gives the same
    packing; a container with a box is refused in one line; ``certify`` certifies in the container (its wall contacts
    counted, isostatic by the shape's own count: docs/containers.md §5)."""
    import numpy as np
    import pytest

    from spherejam import jam
    from spherejam.core.errors import InputError

    a = jam(200, "lognormal:sigma=0.3", container="cylinder:diameter=5", closest={"final_rate": 1e-1}, seed=4)
    b = jam(200, "lognormal:sigma=0.3", container="cylinder:diameter=5", closest={"final_rate": 1e-1}, seed=4)
    c = a.packing.container
    assert c.curved == "cylinder" and a.provenance["container"] == c.spec and np.array_equal(a.packing.positions,
                                                                                              b.packing.positions)
    assert c.wall_penetration(a.packing.positions, a.packing.diameters)[0] <= 1e-10 and a.packing.check().ok
    assert 0.45 < a.phi_J < 0.64
    with pytest.raises(InputError, match="box"):
        jam(200, container="slab:height=4", box=8.0)
    s = jam(40, container="slab:height=4", closest={"final_rate": 1e-1}, certify=True, seed=3)
    cert = s.certificate
    assert cert.completed and cert.isostatic and s.packing.container.spec == "slab:height=4.0"
    assert cert.n_contacts == 3 * cert.n_stable - 2 + 1 and len(cert.wall_contacts) > 0
    assert s.to_pandas()["contacts"].sum() == 2 * len(cert.pairs) + len(cert.wall_contacts)
