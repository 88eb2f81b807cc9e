"""The cutoff and s bound of each iteration (calippso/schedule.py): the guards that keep pairs outside the cutoff
from closing."""

import math

import pytest

from spherejam.calippso.schedule import cutoff_and_bound
from spherejam.core.errors import InputError


@pytest.mark.parametrize("dim", [2, 3, 4, 5])
def test_cutoff_and_bound_guards(dim):
    box = 12.0
    for sg in (1.0, 1.000001, 1.0001, 1.01, 1.3, 2.0):
        for radius in (0.5, 0.7, 1.0):
            ell, sb, gmax, regime = cutoff_and_bound(sg, radius, 2.0, dim, box)
            assert sb > 0 and ell <= box and gmax > 1.0
            # a pair outside the cutoff cannot reach the inflated contact distance
            assert ell - 2 * math.sqrt(dim) * sb >= 2 * radius * math.sqrt(gmax) - 1e-12
            assert regime == (1 if sg - 1 > 5e-4 else 2 if sg - 1 > 1e-5 else 3)
    with pytest.raises(InputError, match="box"):  # a sphere as wide as the box overlaps its own image
        cutoff_and_bound(1.0, 0.5, 2.0, 3, 1.0)
