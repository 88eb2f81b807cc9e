"""CALiPPSO in a box smaller than two cutoffs (issue 35): one LP row per periodic image within the cutoff, row keys
that tell a pair's images apart, and small-box packings certified (isostatic, balanced, no overlap by a brute-force
check over all images), where the old rule (cutoff <= L/2) refused them."""

from __future__ import annotations

import collections
import itertools
import math

import numpy as np
import pytest

from spherejam.calippso.constraints import cutoff_rows, pair_keys, pair_vectors, pairs_in_cutoff
from spherejam.calippso.run import run_calippso
from spherejam.calippso.schedule import cutoff_and_bound
from spherejam.core.packing import Packing
from spherejam.core.seeding import poisson_packing
from spherejam.engines.closest_jamming import find_closest_jamming
from spherejam.engines.lubachevsky_stillinger import run_ls

from packings import worst_overlap_all_images


def brute_force_rows(x, box, cutoff):
    """Every (i, j, r_i - r_j - n L) with i < j and |r_i - r_j - n L| < cutoff, over all images n."""
    reach = int(math.ceil(cutoff / box)) + 1
    out = []
    for i, j in itertools.combinations(range(len(x)), 2):
        for n in itertools.product(range(-reach, reach + 1), repeat=x.shape[1]):
            r = x[i] - x[j] - box * np.array(n)
            if np.linalg.norm(r) < cutoff:
                out.append((i, j, *np.round(r, 9)))
    return sorted(out)


@pytest.mark.parametrize("box, cutoff", [(1.5, 1.4), (2.0, 1.2), (3.0, 1.45)])
def test_cutoff_rows_list_every_image_of_every_pair(box, cutoff):
    x = np.random.default_rng(7).random((12, 3)) * box
    pi, pj, rij = cutoff_rows(x, box, cutoff)
    mine = sorted((int(i), int(j), *np.round(r, 9)) for i, j, r in zip(pi, pj, rij))
    assert mine == brute_force_rows(x, box, cutoff)
    several = len(set(zip(pi.tolist(), pj.tolist()))) < len(pi)  # some pair has several rows
    assert several == (cutoff > box / 2)
    keys = pair_keys(pi, pj, len(x))
    assert np.unique(keys).size == keys.size
    # the closest row of a pair keeps the key i N + j; the others rank by distance
    r = np.linalg.norm(rij, axis=1)
    for k in np.flatnonzero(keys >= len(x) ** 2):
        first = np.flatnonzero(keys == pi[k] * len(x) + pj[k])[0]
        assert r[first] <= r[k]


def test_cutoff_rows_in_a_large_box_are_the_minimum_image_pairs_bit_for_bit():
    x = np.random.default_rng(3).random((400, 3)) * 6.0
    pi, pj, rij = cutoff_rows(x, 6.0, 1.4)
    i, j, _ = pairs_in_cutoff(x, 6.0, 1.4)
    assert np.array_equal(pi, i) and np.array_equal(pj, j)
    assert np.array_equal(rij, pair_vectors(x, 6.0, i, j))
    assert np.array_equal(pair_keys(pi, pj, 400), i * 400 + j)


def test_pair_keys_of_a_subset_are_the_full_lists_keys():
    pi = np.array([0, 0, 0, 1, 0, 1])
    pj = np.array([1, 2, 1, 2, 1, 2])
    keys = pair_keys(pi, pj, 3)
    assert keys.tolist() == [1, 2, 1 + 9, 5, 1 + 18, 5 + 9]


@pytest.mark.parametrize("dim", [2, 3])
def test_cutoff_stays_within_the_box_and_the_largest_sphere_narrower_than_it(dim):
    """Down to a box barely wider than the largest sphere: l <= L, and sqrt(Gamma_max) D_max < L (a sphere never
    reaches its own image, which has no row)."""
    radius = 0.5
    for box in (1.0 + 1e-9, 1.01, 1.2, 1.6, 2.0, 2.5):
        for sg in (1.0, 1.0001, 1.01, 1.5):
            ell, sb, gmax, _ = cutoff_and_bound(sg, radius, 2.0, dim, box)
            assert 0 < sb and ell <= box and gmax > 1.0
            assert ell - 2 * math.sqrt(dim) * sb >= 2 * radius * math.sqrt(gmax) - 1e-12
            assert 2 * radius * math.sqrt(gmax) < box


def _ls(n, sigma, seed, p_max):
    return run_ls(poisson_packing(n, sigma, seed=seed), 0.1, p_max=p_max, seed=2, progress_interval=1e9).packing


def _mls(n, sigma, seed):
    return find_closest_jamming(poisson_packing(n, sigma, seed=seed), final_rate=1e-2, seed=2,
                                progress_interval=1e9).packing


@pytest.mark.parametrize("make, largest_over_box", [
    (lambda: _ls(40, 0.3, 3, 1e4), 0.69),  # LS stopped at p = 1e4: a dozen LPs, warm starts and active sets
    (lambda: _mls(10, 0.5, 10), 0.67),  # MLS-jammed: one LP
    (lambda: _mls(3, 0.5, 1), 0.79),  # a pair touching through three images; its force LP's active set once crashed
])
def test_small_box_packing_is_certified(make, largest_over_box):
    """Largest sphere wider than L/2 (the old rule refused these: its cutoff must exceed D_max and stay below L/2).
    The certificate: converged, isostatic with contacts through several images counted, forces balanced, no
    overlap over all images."""
    start = make()
    assert start.diameters.max() / start.box > largest_over_box
    result = run_calippso(start, progress_interval=1e9)
    assert result.completed and result.isostatic
    assert result.n_contacts == 3 * (result.n_stable - 1) + 1
    assert result.force_balance_residual <= 1e-10
    per_pair = collections.Counter(map(tuple, result.pairs.tolist()))
    assert max(per_pair.values()) >= 2  # a pair touching through two images is two contacts
    # force balance recomputed from the returned contacts, images apart
    f = result.forces[:, None] * result.contact_vectors
    net = np.zeros_like(start.positions)
    np.add.at(net, result.pairs[:, 0], f)
    np.add.at(net, result.pairs[:, 1], -f)
    assert np.abs(net[~result.rattlers]).max() <= 1e-10
    assert worst_overlap_all_images(result.packing) <= 1e-10
    assert result.packing.phi >= start.phi - 1e-10


# --- issue 49: "converged" only with a force network ------------------------------------------------------------


def _bcc_two() -> Packing:
    x = np.array([[0.0, 0.0, 0.0], [0.5, 0.5, 0.5]]) + 0.1
    return Packing(x, np.full(2, math.sqrt(3) / 2), 1.0, {"algorithm": "test"})


def _spans_the_box() -> Packing:
    """The largest sphere as wide as the box (it touches its own images), two small spheres free."""
    x = np.array([[0.1, 0.1, 0.1], [0.6, 0.6, 0.6], [0.6, 0.6, 0.1]])
    return Packing(x, np.array([0.999999, 0.15, 0.15]), 1.0, {"algorithm": "test"})


def test_a_crystal_s_degenerate_dual_still_gives_its_force_network():
    """FCC and the N = 2 BCC are jammed at once, but the LP's dual at Gamma = 1 is degenerate and the solver's vertex
    carried no force ("converged", 0 contacts, force balance inf). The forces come from the balance LP on the
    touching rows: every contact of the crystal (12 per sphere in FCC; 8 images of the other sphere in BCC, as
    `analyze` counts them), balanced to round-off."""
    from packings import fcc_packing
    from spherejam.calippso.run import run_calippso

    for packing, contacts in ((fcc_packing(3), 108 * 6), (_bcc_two(), 8)):
        result = run_calippso(packing, progress_interval=1e9)
        assert result.completed and result.n_contacts == contacts and result.n_rattlers == 0
        assert result.force_balance_residual < 1e-10
        assert np.all(result.forces > 0.5) and np.all(result.forces < 2.0)  # every contact carries a force


def test_no_certificate_when_the_largest_sphere_touches_its_own_image(tmp_path):
    """The LPs converge (nothing can inflate) but only through a sphere's own image, which has no row: not converged,
    not isostatic, nothing certified, one line saying why; the CLI exits 1; with --require-convergence it is an
    error."""
    from spherejam.calippso.run import run_calippso
    from spherejam.cli import main
    from spherejam.core.errors import SimulationError
    from spherejam.core.packing_io import write_packing

    result = run_calippso(_spans_the_box(), progress_interval=1e9)
    assert result.stop_reason == "no_force_network" and not result.completed and not result.isostatic
    assert result.summary()["converged"] == 0.0 and result.packing.metadata["counters"]["converged"] is False
    with pytest.raises(SimulationError, match="no force network.*touches its own image.*nothing certified"):
        run_calippso(_spans_the_box(), progress_interval=1e9, require_convergence=True)
    write_packing(tmp_path / "in.h5", _spans_the_box())
    assert main(["calippso", str(tmp_path / "in.h5"), "-o", str(tmp_path / "out.h5"), "-q"]) == 1


def test_the_dataset_never_holds_a_converged_row_without_forces():
    from spherejam.workflow.dataset import _no_certificate_without_forces

    old = {"calippso_converged": 1.0, "calippso_is_isostatic": 1.0, "calippso_n_contacts": 0.0,
           "calippso_force_balance_residual": math.inf}
    _no_certificate_without_forces(old)
    assert old["calippso_converged"] == 0.0 and old["calippso_is_isostatic"] == 0.0
    good = {"calippso_converged": 1.0, "calippso_is_isostatic": 1.0, "calippso_n_contacts": 300.0,
            "calippso_force_balance_residual": 1e-13}
    _no_certificate_without_forces(good)
    assert good["calippso_converged"] == 1.0 and good["calippso_is_isostatic"] == 1.0
