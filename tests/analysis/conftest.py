"""Packings the analysis tests share."""

import numpy as np
import pytest

from spherejam.core.packing import Packing


def _fcc(m: int) -> Packing:
    """m^3 conventional FCC cells of side 1, touching spheres of diameter 1/sqrt 2."""
    basis = np.array([[0, 0, 0], [0.5, 0.5, 0], [0.5, 0, 0.5], [0, 0.5, 0.5]])
    cells = np.array(np.meshgrid(*[np.arange(m)] * 3, indexing="ij")).reshape(3, -1).T
    pos = (cells[:, None, :] + basis[None]).reshape(-1, 3) + 0.1
    return Packing(pos, np.full(len(pos), np.sqrt(0.5)), float(m))


@pytest.fixture
def fcc():
    """``fcc(m)``: m^3 conventional FCC cells of side 1, touching spheres of diameter 1/sqrt 2."""
    return _fcc
