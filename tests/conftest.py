"""Fixtures of tests in more than one folder (a folder's own fixtures are in its conftest.py)."""

import numpy as np
import pytest


@pytest.fixture
def rng():
    return np.random.default_rng(12345)


# calippso/ and cli/; session-wide so the LS run is made once
@pytest.fixture(scope="session")
def ls_jammed_256():
    """An LS packing compressed to p = 1e12 (jammed at that pressure): CALiPPSO certifies it in a few LPs."""
    from spherejam.core.seeding import poisson_packing
    from spherejam.engines.lubachevsky_stillinger import run_ls

    # rate 1e-3: glassy (phi 0.6487, 12 rattlers); faster LS starts creep, and degenerate LPs let paths diverge
    return run_ls(poisson_packing(256, 0.0, 1), 1e-3, p_max=1e12, seed=1, progress_interval=1e9).packing
