"""The shared cell list (geometry, both binnings) and the searches built on it against brute force: periodic
wrapping, boxes with fewer than 3 cells per side, polydisperse and d != 3 cases, and the event-driven engine's lists."""

import itertools

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from spherejam.core import neighbours
from spherejam.core.packing import Packing
from spherejam.engines.kernels import event_driven as ed


def _as_set(i, j):
    return set(zip(i.tolist(), j.tolist()))


@settings(max_examples=60, deadline=None)
@given(
    n=st.integers(2, 120),
    dim=st.integers(2, 4),
    ratio=st.floats(1.0, 10.0),
    scale=st.floats(0.2, 3.0),
    seed=st.integers(0, 2**31),
)
def test_pairs_within_matches_brute_force(n, dim, ratio, scale, seed):
    rng = np.random.default_rng(seed)
    box = float(rng.uniform(3.0, 12.0))
    pos = rng.random((n, dim)) * box
    dia = rng.uniform(1.0 / ratio, 1.0, n)
    ci, cj, cr = neighbours.pairs_within(pos, dia, box, scale)
    bi, bj, br = neighbours.brute_force_pairs(pos, dia, box, scale)
    assert _as_set(ci, cj) == _as_set(bi, bj)
    order = np.lexsort((bj, bi))
    np.testing.assert_allclose(cr, br[order], rtol=1e-14)


def test_closest_pair_matches_brute_force(rng):
    for dim in (2, 3, 5):
        pos = rng.random((300, dim)) * 7.0
        dia = rng.uniform(0.1, 1.0, 300)
        i, j, h = neighbours.closest_pair(pos, dia, 7.0)
        bi, bj, br = neighbours.brute_force_pairs(pos, dia, 7.0, scale=1e9)
        hb = br / (0.5 * (dia[bi] + dia[bj]))
        k = np.argmin(hb)
        assert (i, j) == (bi[k], bj[k])
        assert h == hb[k]


def test_pairs_across_periodic_boundary():
    pos = np.array([[0.05, 5.0, 5.0], [9.97, 5.0, 5.0], [5.0, 5.0, 5.0]])
    i, j, r = neighbours.pairs_within(pos, np.ones(3), 10.0, 1.0)
    assert _as_set(i, j) == {(0, 1)}
    assert np.isclose(r[0], 0.08)


def test_check_finds_worst_overlap():
    pos = np.array([[1.0, 1.0, 1.0], [1.999, 1.0, 1.0], [5.0, 5.0, 5.0], [6.0 - 1e-12, 5.0, 5.0]])
    p = Packing(pos, np.ones(4), 10.0)
    rep = p.check(1e-10)
    assert not rep.ok and rep.n_overlaps == 1 and rep.pair == (0, 1)
    assert np.isclose(rep.worst_overlap, 1e-3)
    ok = Packing(pos[2:], np.ones(2), 10.0).check(1e-10)
    assert ok.ok and ok.n_overlaps == 0 and 0 < ok.worst_overlap < 1e-10


def _reference_cells(points, box, m):
    """Cell coordinates and index of each point: the cell of its image in [0, L)."""
    coords = np.floor(np.mod(points, box) / box * m).astype(np.int64) % m
    return coords, coords @ (m ** np.arange(points.shape[1]))


def _in_cell(x, c, box, m):
    """Whether some periodic image of coordinate x lies in cell coordinate c (faces included, to round-off)."""
    side = box / m
    images = x + box * np.arange(-3, 4)
    return bool(np.any((images >= c * side - 1e-12 * box) & (images <= (c + 1) * side + 1e-12 * box)))


@pytest.mark.parametrize("dim", [1, 2, 3, 5])
def test_cells_per_side_never_gives_cells_smaller_than_asked(rng, dim):
    for _ in range(200):
        box, side, n = rng.uniform(0.5, 50.0), rng.uniform(0.01, 10.0), int(rng.integers(2, 5000))
        m = neighbours.cells_per_side(box, side, dim, n)
        assert m == 1 or 3 <= m <= np.ceil((2.0 * n) ** (1.0 / dim))
        if m > 1:
            assert box / m >= side
        elif box // side >= 3:  # a single cell only when the cap (tiny N) forbids 3 per side
            assert np.ceil((2.0 * n) ** (1.0 / dim)) < 3
    assert neighbours.cells_per_side(10.0, 3.4, 3, 1000) == 1  # 2 cells would fit: the 3x3x3 stencil needs 3
    assert neighbours.cells_per_side(9.0, 3.0, 3, 1000) == 3
    assert neighbours.cells_per_side(9.0, 3.0 * (1 + 1e-15), 3, 1000) == 1  # exact floor: 3 cells would be too small
    assert neighbours.cells_per_side(10.0, 0.0, 3, 1000) == 1


@pytest.mark.parametrize("m", [1, 3, 4, 7])
def test_binnings_put_every_point_in_its_cell(rng, m):
    box, n, dim = 5.0, 300, 3
    pts = rng.random((n, dim)) * box
    pts[:5] = [[box, 0.0, 1.0], [-1e-17, 2.0, box - 1e-15], [0.0, 0.0, 0.0], [box * (1 + 1e-16), 1.0, -box / 3],
               [2.0 * box + 0.1, -0.1, 0.5]]  # on and beyond the faces: the periodic image's cell
    L, ms = np.full(dim, box), np.full(dim, m, dtype=np.int64)
    want = np.array([neighbours.cell_of(p, L, ms) for p in pts])
    coords = np.empty((n, dim), dtype=np.int64)
    for i in range(n):
        neighbours.unravel_cell(want[i], ms, coords[i])
        assert all(_in_cell(pts[i, k], coords[i, k], box, m) for k in range(dim))
    interior = np.all(np.abs(pts / (box / m) - np.round(pts / (box / m))) > 1e-9, axis=1)
    assert np.array_equal(want[interior], _reference_cells(pts, box, m)[1][interior])
    assert np.array_equal(want, coords @ (m ** np.arange(dim)))
    cell, start, order = neighbours.cell_sort(pts, L, ms)
    assert np.array_equal(cell, want) and start[-1] == n
    head, nxt, prv, linked = neighbours.link_cells(pts, L, ms)
    assert np.array_equal(linked, want)
    for c in range(m**dim):
        members = np.flatnonzero(want == c)  # in index order in both binnings
        assert np.array_equal(order[start[c]:start[c + 1]], members)
        assert np.array_equal(_walk(head, nxt, prv, c), members)
    # moves keep the linked lists consistent (a model: the set of points of each cell)
    model = want.copy()
    for _ in range(500):
        i, c = int(rng.integers(n)), int(rng.integers(m**dim))
        neighbours.move_to_cell(i, c, head, nxt, prv, linked)
        model[i] = c
    assert np.array_equal(linked, model)
    for c in range(m**dim):
        assert sorted(_walk(head, nxt, prv, c)) == np.flatnonzero(model == c).tolist()


def _walk(head, nxt, prv, c):
    out, j, before = [], head[c], -1
    while j >= 0:
        assert prv[j] == before
        out.append(int(j))
        before, j = j, nxt[j]
    return out


@pytest.mark.parametrize("dim", [1, 2, 3])
@pytest.mark.parametrize("m", [1, 2, 3, 4, 5, 8])
@pytest.mark.parametrize("w", [1, 2, 3])
def test_stencil_is_the_periodic_block_of_cells_with_its_image_shifts(rng, dim, m, w):
    box = 6.0
    side = box / m
    shift = np.empty(dim)
    L, ms, periodic = np.full(dim, box), np.full(dim, m, dtype=np.int64), np.ones(dim, dtype=np.bool_)
    for _ in range(5):
        centre = rng.integers(0, m, dim)
        size = neighbours.stencil_size(w, ms)
        cells = [neighbours.stencil_cell(centre, o, w, ms, L, periodic, shift) for o in range(size)]
        if 2 * w + 1 > m:  # wraps onto itself: the whole grid, once, unshifted
            assert cells == list(range(m**dim))
            if m == 1:
                assert neighbours.neighbour_offsets(dim, m).tolist() == [[0] * dim]
            continue
        offsets = [t[::-1] for t in itertools.product(range(-w, w + 1), repeat=dim)]  # first axis fastest
        assert len(cells) == len(offsets) == len(set(cells))  # each cell once
        for o, off in enumerate(offsets):
            cn = neighbours.stencil_cell(centre, o, w, ms, L, periodic, shift)
            unwrapped = centre + np.array(off)
            assert cn == (np.mod(unwrapped, m) @ (m ** np.arange(dim)))
            assert np.array_equal(shift, box * np.floor_divide(unwrapped, m))  # -L, 0 or +L per axis
            # a point of that cell, moved by the shift, lies in the unwrapped cell next to the centre
            cn_coords = np.mod(unwrapped, m)
            point = (cn_coords + rng.random(dim)) * side
            assert np.array_equal(np.floor((point + shift) / side).astype(int), unwrapped)
            if w == 1:  # the offset table describes the same entries in the same order
                assert np.array_equal(neighbours.neighbour_offsets(dim, m)[o], off)


@pytest.mark.parametrize("box, m_expected", [(2.5, 1), (3.4, 3), (8.0, 7)])
@pytest.mark.parametrize("sigma", [0.0, 0.4])
def test_pairs_within_small_and_large_boxes_polydisperse(rng, box, m_expected, sigma):
    n = 150
    pos = rng.random((n, 3)) * box
    pos[:4] = [[0.0, 0.0, 0.0], [box - 1e-9, box - 1e-9, box - 1e-9], [box * 0.5, 0.0, box - 1e-12], [0.0, 1.0, 0.0]]
    dia = rng.lognormal(0.0, sigma, n) if sigma else np.ones(n)
    dia *= 1.0 / dia.max()  # largest diameter 1: the cutoff sets the cell count
    assert neighbours.cells_per_side(box, 1.1, 3, n) == m_expected
    ci, cj, cr = neighbours.pairs_within(pos, dia, box, 1.1)
    bi, bj, br = neighbours.brute_force_pairs(pos, dia, box, 1.1)
    assert _as_set(ci, cj) == _as_set(bi, bj) and len(ci) == len(bi)
    assert (0, 1) in _as_set(ci, cj)  # across the corner of the box
    order = np.lexsort((bj, bi))
    np.testing.assert_allclose(cr, br[order], rtol=1e-14)


def _one_level(m, nominal):
    """The grid fields of the event-driven state for one level of ``m`` cells per axis."""
    ms = np.broadcast_to(np.asarray(m, dtype=np.int64), (3,)).copy()
    return (ms[None, :], np.array([0, int(np.prod(ms))], dtype=np.int64), np.array([float(nominal.max())]),
            np.zeros(len(nominal), dtype=np.int32))


def _brute_force_lists(refs, nominal, box, rho_list, skin):
    d = refs[None, :, :] - refs[:, None, :]
    d -= box * np.floor(d / box + 0.5)
    r = np.sqrt((d * d).sum(axis=2))
    cut = rho_list * 0.5 * (nominal[:, None] + nominal[None, :]) + skin
    near = r < cut
    np.fill_diagonal(near, False)
    return [set(np.flatnonzero(row).tolist()) for row in near]


@pytest.mark.parametrize("box, n, m_expected", [(2.0, 100, 1), (2.2, 100, 3), (9.0, 200, 8)])
@pytest.mark.parametrize("sigma", [0.0, 0.3])
def test_event_driven_lists_match_brute_force_after_local_updates(rng, box, n, m_expected, sigma):
    """The LS engine's Verlet lists (linked cells, 3x3x3 stencil) from scratch and after per-particle updates."""
    rho_list, skin = 0.5, 0.2
    st = np.zeros((n, 8))
    st[:, 0:3] = rng.random((n, 3)) * box
    st[:, 7] = rng.lognormal(0.0, sigma, n) if sigma else 1.0
    st[:, 7] /= st[:, 7].max()
    m = neighbours.cells_per_side(box, rho_list * st[:, 7].max() + skin, 3, n)
    assert m == m_expected
    frame = neighbours.Frame.of(box, 3)
    L, half, periodic = frame.lengths, frame.half, frame.periodic
    grid = _one_level(m, st[:, 7])
    nbr = np.zeros((n, 64), dtype=np.int32)
    refs, nnb, head, nxt, prv, cellof, max_count = ed.build_lists(st, L, half, periodic, rho_list, skin, *grid, nbr)
    assert max_count <= nbr.shape[1]
    want = _brute_force_lists(refs, st[:, 7], box, rho_list, skin)
    assert [set(nbr[i, :nnb[i]].tolist()) for i in range(n)] == want
    scratch = np.zeros((1, 64), dtype=np.int32)
    for _ in range(300):  # a particle leaves its skin sphere (possibly through a face of the box): local update
        i = int(rng.integers(n))
        st[i, 0:3] += rng.normal(0.0, 0.3, 3)
        assert ed._rebuild_one(st, refs, i, L, half, periodic, *grid, rho_list, skin, nbr, nnb, head, nxt, prv,
                               cellof, scratch,
                               np.empty(3, dtype=np.int64), np.empty(3), np.empty(27, dtype=np.int64))
    assert np.all((refs >= 0.0) & (refs < box))
    assert np.array_equal(cellof, _reference_cells(refs, box, m)[1])
    want = _brute_force_lists(refs, st[:, 7], box, rho_list, skin)
    assert [set(nbr[i, :nnb[i]].tolist()) for i in range(n)] == want


@pytest.mark.parametrize("lengths, periodic", [
    ((3.0, 4.5, 7.0), (True, True, True)),  # a periodic box with three edge lengths
    ((6.0, 6.0, 2.5), (True, True, False)),  # a slab: no image across z
    ((5.0, 5.0, 9.0), (False, False, True)),  # a cylinder's frame
    ((4.0, 4.0, 4.0), (False, False, False)),  # a closed box or a sphere's frame
])
def test_pair_search_and_event_lists_in_any_frame_match_brute_force(rng, lengths, periodic):
    """Pairs meet through images along periodic axes only; a stencil stops at a walled end of the frame."""
    n, dim = 300, 3
    L = np.asarray(lengths)
    pos = rng.random((n, dim)) * L
    dia = rng.lognormal(0.0, 0.4, n)
    dia *= 0.9 / dia.max()
    frame = neighbours.Frame(L, periodic)
    d = pos[None, :, :] - pos[:, None, :]
    for k in range(dim):
        if periodic[k]:
            d[:, :, k] -= L[k] * np.floor(d[:, :, k] / L[k] + 0.5)
    r = np.sqrt((d * d).sum(axis=2))
    near = r < 1.1 * 0.5 * (dia[:, None] + dia[None, :])
    want = {(i, j) for i, j in zip(*np.nonzero(np.triu(near, 1)))}
    ci, cj, cr = neighbours.pairs_within(pos, dia, frame, 1.1)
    assert _as_set(ci, cj) == want and len(ci) == len(want)
    np.testing.assert_allclose(cr, r[ci, cj], rtol=1e-14)
    assert neighbours.closest_pair(pos, dia, frame)[2] == pytest.approx(np.min((r / (0.5 * (dia[:, None]
                                                                          + dia[None, :])))[np.triu_indices(n, 1)]))
    # the event-driven engine's lists in the same frame
    rho_list, skin = 0.5, 0.2
    st = np.zeros((n, 8))
    st[:, 0:3] = pos
    st[:, 7] = dia
    ms = neighbours.cells_per_axis(frame, rho_list * dia.max() + skin, n)
    nbr = np.zeros((n, 128), dtype=np.int32)
    refs, nnb, *_ = ed.build_lists(st, frame.lengths, frame.half, frame.periodic, rho_list, skin,
                                   *_one_level(ms, dia), nbr)
    cut = rho_list * 0.5 * (dia[:, None] + dia[None, :]) + skin
    listed = (r < cut) & ~np.eye(n, dtype=bool)
    assert [set(nbr[i, :nnb[i]].tolist()) for i in range(n)] == [set(np.flatnonzero(row)) for row in listed]


def test_a_walled_stencil_stops_at_the_wall():
    ms = np.array([4, 4, 4], dtype=np.int64)
    L = np.full(3, 4.0)
    shift = np.empty(3)
    periodic = np.array([True, True, False])
    corner = np.array([0, 3, 0])
    cells = [neighbours.stencil_cell(corner, o, 1, ms, L, periodic, shift) for o in range(27)]
    assert cells.count(-1) == 9  # the layer below z = 0 is beyond the wall; x and y still wrap
    assert len({c for c in cells if c >= 0}) == 18


def _levelled_state(nominal, box, rng, all_images=False):
    from spherejam.engines.event_driven import LSEngine

    n = len(nominal)
    pos = rng.random((n, 3)) * box
    rho = neighbours.closest_pair(pos, nominal, box)[2]
    v = rng.normal(0.0, 0.4, (n, 3))
    return LSEngine.start(pos, nominal, box, 0.999 * rho, v, 0.0, all_images=all_images)


@pytest.mark.parametrize("kind, n, box", [
    ("bi10", 3000, 22.0), ("lognormal0.5", 3000, 13.0),
    ("bi10", 300, 11.0),  # a large sphere wider than half the box: its pairs meet through several images
])
def test_levelled_grid_lists_match_brute_force_at_wide_size_ratios(rng, kind, n, box):
    """A size ratio of 10 (bidisperse) and a log-normal of sigma = 0.5 get a grid of several levels; the Verlet lists
    built through it, and after local updates (skin events) through it, are exactly the brute-force lists."""
    from spherejam.engines.event_driven import LEVEL_RATIO
    from spherejam.engines.kernels import event_driven as ed

    if kind == "bi10":
        nominal = np.ones(n)
        nominal[: max(1, n // 430)] = 10.0
    else:
        nominal = rng.lognormal(0.0, 0.47, n)
    nominal /= nominal.mean()
    assert nominal.max() >= LEVEL_RATIO * np.median(nominal)
    engine = _levelled_state(nominal, box, rng)
    s = engine.state
    assert s.lvl_ms.shape[0] >= 2  # the test runs the levelled path

    def check(s):
        d = s.refs[None, :, :] - s.refs[:, None, :]
        d -= box * np.floor(d / box + 0.5)
        r = np.sqrt((d * d).sum(axis=2))
        nom = s.st[:, 7]
        cut = s.rho_list * 0.5 * (nom[:, None] + nom[None, :]) + s.skin
        want = (r < cut) & ~np.eye(len(nom), dtype=bool)
        got = [set(s.nbr[i, :s.nnb[i]].tolist()) for i in range(len(nom))]
        assert got == [set(np.flatnonzero(row).tolist()) for row in want]

    check(s)
    scratch = np.zeros((1, s.nbr.shape[1]), dtype=np.int32)
    movers = np.concatenate([np.argsort(s.st[:, 7])[-3:], rng.integers(0, n, 200)])  # the largest ones too
    for i in movers:
        s.st[i, 0:3] = np.mod(s.st[i, 0:3] + rng.normal(0.0, 0.3, 3), box)
        assert ed._rebuild_one(s.st, s.refs, int(i), s.lengths, s.half, s.periodic, s.lvl_ms, s.lvl_off, s.lvl_dmax,
                               s.level, s.rho_list, s.skin, s.nbr, s.nnb, s.head, s.nxt, s.prv, s.cellof, scratch,
                               np.empty(3, dtype=np.int64), np.empty(3), np.empty(27, dtype=np.int64))
    check(s)
    lv = s.level
    for i in range(n):  # every sphere is linked in its own level's cell
        c = s.cellof[i]
        assert s.lvl_off[lv[i]] <= c < s.lvl_off[lv[i] + 1]


def test_one_level_below_the_level_ratio():
    """sigma = 0.3 and 1:3 mixtures keep the one grid of before (their runs are bitwise those of before)."""
    from spherejam.engines.event_driven import grid_levels

    frame = neighbours.Frame.of(20.0, 3)
    for nominal in (np.exp(np.random.default_rng(1).normal(0, 0.29, 10_000)), np.r_[np.ones(900), 3 * np.ones(100)]):
        level, lvl_ms, lvl_off, _ = grid_levels(nominal / nominal.mean(), 1.0, 0.2, frame)
        assert lvl_ms.shape == (1, 3) and not level.any() and lvl_off[-1] == np.prod(lvl_ms[0])


@pytest.mark.parametrize("periodic", [(True, True, True), (True, True, False), (False, False, True)])
def test_the_event_driven_stencil_is_the_general_one(rng, periodic):
    """The kernel's 3x3x3 stencil, built axis by axis, lists the cells of core.neighbours.stencil_cell in the same
    order (the order of the neighbour lists, hence of a run's arithmetic), walls included."""
    periodic = np.array(periodic)
    shift = np.empty(3)
    cells = np.empty(27, dtype=np.int64)
    for _ in range(200):
        ms = rng.choice([1, 3, 4, 7], 3).astype(np.int64)
        coords = np.array([rng.integers(0, m) for m in ms], dtype=np.int64)
        want = [neighbours.stencil_cell(coords, o, 1, ms, np.ones(3), periodic, shift)
                for o in range(neighbours.stencil_size(1, ms))]
        count = ed._stencil_of(coords, periodic, ms, cells)
        assert cells[:count].tolist() == [c for c in want if c >= 0]
