"""An edit's fast path (``cells.propagated`` and the passes it runs) against the plain references."""

from __future__ import annotations

import numba
import numpy as np
import pytest

from fmr_editor.engine import cells as cells_module
from fmr_editor.engine.cells import Cells, largest_part, propagated, propagated_reference
from fmr_editor.engine.fmm import level_kernels, orders, passes
from fmr_editor.engine.fmm.lattice import (
    Lattice,
    cell_order,
    changed_runs,
    changed_runs_reference,
    coarser_multipoles,
    cut_into_cells,
    downward_pass,
    sort_into_cells,
)
from fmr_editor.engine.fmm.passes import HUGE_PAGE, downward_onto, huge_pages_empty, huge_pages_zeros, level_sources
from fmr_editor.engine.fmm.sparse_downward import delta_local
from fmr_editor.engine.geometry.segments import Segments
from fmr_editor.engine.kernels.fastmath import INV_TWO_PI

SIDE = 256.0
WIDTH = 16
FIELDS = ("p", "q", "jump", "mean", "on_border", "flux", "origin")


def random_segments(rng, count: int, spread: float = 0.2) -> Segments:
    """Short segments around the canvas centre with random E, C and colours (not cut at cells)."""
    centre = rng.normal(SIDE / 2, spread * SIDE, (count, 2)).clip(1.0, SIDE - 1.0)
    q = (centre + rng.normal(0.0, 2.0, (count, 2))).clip(0.5, SIDE - 0.5)
    origin = np.stack([rng.integers(-1, 5, count).astype(float), rng.uniform(0.0, 3.0, count)], axis=1)
    origin[origin[:, 0] < 0, 1] = np.nan
    return Segments(p=centre, q=q, jump=rng.normal(size=(count, 3)), mean=rng.normal(size=(count, 3)),
                    on_border=rng.random(count) < 0.1, flux=rng.normal(size=(count, 3)), origin=origin)


def cut(segments: Segments, lattice: Lattice) -> Segments:
    """``segments`` cut at the cells, in an order other than the cells' (as a document's boundary comes)."""
    pieces, _ = cut_into_cells(segments, lattice)
    return pieces.take(np.random.default_rng(len(pieces)).permutation(len(pieces)))


def relative(got: np.ndarray, expected: np.ndarray) -> float:
    return float(np.abs(got - expected).max() / np.abs(expected).max())


def test_sorting_into_cells_equals_the_stable_take():
    rng = np.random.default_rng(2)
    lattice = Lattice(5, SIDE)
    segments = random_segments(rng, 3000, spread=0.6)
    outside = rng.uniform(-20.0, SIDE + 20.0, (200, 2))  # clamped to the border cells
    on_edges = rng.integers(0, 32, (200, 2)) * lattice.cell_size
    extra = random_segments(rng, 400)
    segments = Segments(**{name: np.concatenate([getattr(segments, name), getattr(extra, name)]) for name in FIELDS})
    segments = Segments(**{**{name: getattr(segments, name) for name in FIELDS},
                           "p": np.concatenate([segments.p[:-400], outside, on_edges]),
                           "q": np.concatenate([segments.q[:-400], outside, on_edges])})
    order, expected_start = cell_order(segments, lattice)
    expected = segments.take(order)
    got, cell_start = sort_into_cells(segments, lattice)
    assert np.array_equal(cell_start, expected_start)
    for name in FIELDS:
        assert np.array_equal(getattr(got, name), getattr(expected, name), equal_nan=True), name


def test_changed_runs_equal_the_reference():
    rng = np.random.default_rng(3)
    lattice = Lattice(5, SIDE)
    before = cut(random_segments(rng, 1500), lattice)
    flux, p = before.flux.copy(), before.p.copy()
    flux[rng.choice(len(flux), 30, replace=False), rng.integers(0, 3, 30)] += 1e-9  # E of a few
    p[rng.choice(len(p), 10, replace=False)] += 1e-12  # geometry of a few, in place
    keep = np.ones(len(p), bool)
    keep[rng.choice(len(p), 15, replace=False)] = False  # some removed
    after = Segments(**{**{name: getattr(before, name) for name in FIELDS}, "flux": flux, "p": p}).take(keep)
    moved = random_segments(rng, 20)  # some added elsewhere
    after = Segments(**{name: np.concatenate([getattr(after, name), getattr(moved, name)]) for name in FIELDS})
    old, old_start = sort_into_cells(before, lattice)
    new, new_start = sort_into_cells(after, lattice)
    expected = changed_runs_reference(old, old_start, new, new_start)
    assert 40 < len(expected) < 32 * 32 / 2
    assert np.array_equal(changed_runs(old, old_start, new, new_start), expected)
    assert len(changed_runs(old, old_start, old, old_start)) == 0


def random_delta(rng, cells: np.ndarray, n: int) -> np.ndarray:
    """Random multipoles ``(len(cells), 3, WIDTH + 1)`` of the size real ones fall off with."""
    shape = (len(cells), 3, WIDTH + 1)
    return (rng.normal(size=shape) + 1j * rng.normal(size=shape)) * 0.3 ** np.arange(WIDTH + 1)


@pytest.mark.parametrize("chosen", [False, True])
@pytest.mark.parametrize("count", [1, 6, 60, 3000])  # one cell; a few (corners, borders); sparse; most (grids)
def test_a_change_goes_down_onto_the_local_expansions_as_the_plain_pass(count, chosen):
    rng = np.random.default_rng(count)
    lattice = Lattice(6, SIDE)
    n = lattice.cells_per_side
    pass_orders = orders.pass_orders(6, 8, WIDTH) if chosen else orders.uniform_orders(6, WIDTH)
    corners = np.array([0, n - 1, n * (n - 1), n * n - 1, n // 2, n * n // 2])  # the edges of the index maps
    cells = np.unique(np.concatenate([corners[:count], rng.choice(n * n, max(count - 6, 0), replace=False)]))
    moments = random_delta(rng, cells, n)
    terms = 9 if chosen else WIDTH + 1
    base = rng.normal(size=(n, n, 3, terms)) + 1j * rng.normal(size=(n, n, 3, terms))
    local, change = downward_onto(level_sources(moments, np.arange(len(cells)), cells, lattice, pass_orders),
                                  lattice, pass_orders, base)
    delta = np.zeros((n * n, 3, WIDTH + 1), complex)
    delta[cells] = moments
    expected = downward_pass(coarser_multipoles(delta.reshape(n, n, 3, -1), WIDTH), lattice, WIDTH,
                             pass_orders if chosen else None)[..., :terms]
    assert relative(local - base, expected) < 1e-12
    assert np.abs(change - largest_part(expected, axis=(2, 3))).max() < 1e-12 * np.abs(expected).max()


@pytest.mark.parametrize("chosen", [False, True])
@pytest.mark.parametrize("count", [1, 40, 900])
def test_delta_local_equals_the_plain_pass(count, chosen):
    rng = np.random.default_rng(count + 1)
    lattice = Lattice(5, SIDE)
    n = lattice.cells_per_side
    pass_orders = orders.pass_orders(5, 8, WIDTH) if chosen else None
    delta = np.zeros((n * n, 3, WIDTH + 1), complex)
    cells = rng.choice(n * n, count, replace=False)
    delta[cells] = random_delta(rng, cells, n)
    delta = delta.reshape(n, n, 3, WIDTH + 1)
    expected = downward_pass(coarser_multipoles(delta, WIDTH), lattice, WIDTH, pass_orders)
    assert relative(delta_local(delta, lattice, WIDTH, pass_orders), expected) < 1e-12


def edited(segments: Segments, rng, moved: int) -> Segments:
    """``segments`` with ``moved`` of them shifted and given new E (a preview's change)."""
    index = rng.choice(len(segments), moved, replace=False)
    p, q, flux = segments.p.copy(), segments.q.copy(), segments.flux.copy()
    shift = rng.normal(0.0, 3.0, (moved, 2))
    p[index] = np.clip(p[index] + shift, 0.5, SIDE - 0.5)
    q[index] = np.clip(q[index] + shift, 0.5, SIDE - 0.5)
    flux[index] += rng.normal(size=(moved, 3))
    return Segments(**{**{name: getattr(segments, name) for name in FIELDS}, "p": p, "q": q, "flux": flux})


def assert_same_cells(got, expected):
    (cells, change, moved), (ref, ref_change, ref_moved) = got, expected
    assert np.array_equal(moved, ref_moved)
    assert np.array_equal(cells.cell_start, ref.cell_start)
    for name in FIELDS:
        assert np.array_equal(getattr(cells.segments, name), getattr(ref.segments, name), equal_nan=True)
    assert np.array_equal(cells.fine, ref.fine)
    assert relative(cells.local, ref.local) < 1e-12
    assert np.abs(change - ref_change).max() <= 1e-12 * max(ref_change.max(), 1e-300)
    assert cells.orders is ref.orders
    assert np.array_equal(cells.centres, cells.local[..., 0].real * INV_TWO_PI)  # written with the expansions


@pytest.mark.parametrize("pixel_order", [8, None])
def test_a_preview_propagates_as_the_reference_and_a_rebuild(pixel_order):
    rng = np.random.default_rng(5)
    lattice = Lattice(6, SIDE)
    segments = cut(random_segments(rng, 3000), lattice)
    cells = Cells.build(segments, lattice, WIDTH, pixel_order=pixel_order)
    new = edited(segments, rng, 25)
    got = propagated(cells, new, lattice, WIDTH, 0.0, only_moved=True)
    assert 10 < got[2].sum() < 60
    assert_same_cells(got, propagated_reference(cells, new, lattice, WIDTH, 0.0, only_moved=True))
    rebuilt = Cells.build(new, lattice, WIDTH, pixel_order=pixel_order)
    assert relative(got[0].local, rebuilt.local) < 1e-12
    assert relative(got[0].fine, rebuilt.fine) < 1e-14


@pytest.mark.parametrize("only_moved", [False, True])
def test_a_solve_propagates_as_the_reference(only_moved):
    """Every E moves a little (some cells' changes negligible, they wait), or most cells move (whole grids)."""
    rng = np.random.default_rng(6)
    lattice = Lattice(6, SIDE)
    segments = cut(random_segments(rng, 4000, spread=0.5), lattice)
    cells = Cells.build(segments, lattice, WIDTH, pixel_order=8)
    occupied = np.count_nonzero(np.diff(cells.cell_start))
    for size, least, most in ((1e-6, 0.01, 0.1), (1e-2, 0.9, 1.0)):
        flux = segments.flux * (1.0 + size * rng.normal(size=segments.flux.shape) ** 3)
        new = Segments(**{**{name: getattr(segments, name) for name in FIELDS}, "flux": flux})
        got = propagated(cells, new, lattice, WIDTH, 1e-5, only_moved=only_moved)
        assert_same_cells(got, propagated_reference(cells, new, lattice, WIDTH, 1e-5, only_moved=only_moved))
        assert least * occupied < got[2].sum() < most * occupied


@pytest.mark.parametrize("applied", [False, True])  # a drag's patches; some applied
def test_previews_patch_a_shared_base_until_an_exact_step(monkeypatch, applied):
    """A drag: previews from previews (their patches merged), then the exact step; each as the reference."""
    if applied:
        monkeypatch.setattr(cells_module, "PATCH_SHARE", 0.015)  # 61 cells: patched twice, then applied
    rng = np.random.default_rng(9)
    lattice = Lattice(6, SIDE)
    segments = cut(random_segments(rng, 3000), lattice)
    cells = reference = Cells.build(segments, lattice, WIDTH, pixel_order=8)
    bases = []
    for step in range(4):
        segments = edited(segments, rng, 12)
        got = propagated(cells, segments, lattice, WIDTH, 0.0, only_moved=True)
        expected = propagated_reference(reference, segments, lattice, WIDTH, 0.0, only_moved=True)
        assert_same_cells(got, expected)
        bases.append(got[0].fine_base is cells.fine_base)
        cells, reference = got[0], expected[0]
    assert bases == ([True, True, False, True] if applied else [True] * 4)
    moved = rng.choice(len(segments.flux), 200, replace=False)  # the exact solve: some E change
    flux = segments.flux.copy()
    flux[moved] *= 1.01
    segments = Segments(**{**{name: getattr(segments, name) for name in FIELDS}, "flux": flux})
    got = propagated(cells, segments, lattice, WIDTH, 1e-6)
    assert_same_cells(got, propagated_reference(reference, segments, lattice, WIDTH, 1e-6))
    assert got[0].patched_cells is None


def test_the_cells_two_patches_move_are_those_their_whole_arrays_differ_in():
    rng = np.random.default_rng(12)
    lattice = Lattice(6, SIDE)
    segments = cut(random_segments(rng, 3000), lattice)
    base = Cells.build(segments, lattice, WIDTH, pixel_order=8)
    one = propagated(base, edited(segments, rng, 12), lattice, WIDTH, 0.0, only_moved=True)[0]
    other = propagated(base, edited(segments, rng, 12), lattice, WIDTH, 0.0, only_moved=True)[0]
    assert one.fine_base is other.fine_base is base.fine_base  # patches of one snapshot
    for a, b in ((one, other), (one, base), (base, one), (one, one)):
        expected = np.any(a.fine != b.fine, axis=(2, 3))
        np.testing.assert_array_equal(a.moved_from(b), expected)
    assert one.moved_from(other).sum() > 10


def test_an_edit_that_moves_no_cell_shares_the_arrays():
    rng = np.random.default_rng(7)
    lattice = Lattice(5, SIDE)
    segments = cut(random_segments(rng, 1000), lattice)
    cells = Cells.build(segments, lattice, WIDTH, pixel_order=8)
    same, change, moved = propagated(cells, segments, lattice, WIDTH, 1e-6)
    assert same.fine is cells.fine and same.local is cells.local
    assert not change.any() and not moved.any()


def test_a_preview_touches_only_the_changed_cells_and_their_ancestors(monkeypatch):
    """Work, not time: P2M of the changed cells only, M2M of their ancestors only, small levels on one thread."""
    rng = np.random.default_rng(8)
    lattice = Lattice(7, SIDE)
    segments = cut(random_segments(rng, 6000, spread=0.4), lattice)
    cells = Cells.build(segments, lattice, WIDTH, pixel_order=8)
    new = edited(segments, rng, 4)
    seen = {}
    original_p2m, original_sources = cells_module.fine_multipoles, cells_module.level_sources

    def recorded_p2m(*args):
        seen["p2m"] = args[4]
        return original_p2m(*args)

    def recorded_sources(*args):
        sources = original_sources(*args)
        seen["sources"] = [None if level is None else (level.dense, len(level.src_re)) for level in sources]
        return sources

    monkeypatch.setattr(cells_module, "fine_multipoles", recorded_p2m)
    monkeypatch.setattr(cells_module, "level_sources", recorded_sources)
    threads = []
    original_level = level_kernels.level_local
    monkeypatch.setattr(level_kernels, "level_local",
                        lambda *args: threads.append((args[0], numba.get_num_threads())) or original_level(*args))
    _, _, moved = propagated(cells, new, lattice, WIDTH, 0.0, only_moved=True)
    old, new_sorted = cells, sort_into_cells(new, lattice)
    assert np.array_equal(seen["p2m"], changed_runs(old.segments, old.cell_start, *new_sorted))
    assert len(seen["p2m"]) <= 8 + 2 * 4  # each moved piece: its old and new cell, a few cut in two
    ancestors = np.flatnonzero(moved)
    for level in range(lattice.levels, 1, -1):
        dense = len(ancestors) >= passes._dense_count(2**level)
        assert seen["sources"][level] == ((True, 0) if dense else (False, len(ancestors))), level
        rows, columns = np.divmod(ancestors, 2**level)
        ancestors = np.unique((rows // 2) * 2 ** (level - 1) + columns // 2)
    work = [4**level * passes._term_pairs(cells.orders, level) / passes.CELL_TERM_PAIRS
            for level in range(2, lattice.levels + 1)]
    assert threads == [(2**level, 1 if cells_of_work < level_kernels.PARALLEL_CELLS else numba.get_num_threads())
                       for level, cells_of_work in zip(range(2, lattice.levels + 1), work)]


def test_huge_pages_empty_is_an_empty_array_at_a_huge_page():
    small = huge_pages_empty((10, 3), complex)
    assert small.shape == (10, 3) and small.dtype == complex
    big = huge_pages_empty((64, 64, 3, 9), complex)
    assert big.shape == (64, 64, 3, 9) and big.dtype == complex and big.flags.c_contiguous and big.flags.writeable
    assert big.ctypes.data % HUGE_PAGE == 0
    big[...] = 1.0  # every byte of it is the array's own
    assert big.sum() == big.size


@pytest.mark.parametrize("cells", [8, 64, 128])  # below huge pages, on ours, on numpy's own
def test_huge_pages_zeros_is_an_array_of_zeros(cells):
    shape = (cells, cells, 3, 17)
    zeros = huge_pages_zeros(shape, complex)
    assert zeros.shape == shape and zeros.dtype == complex and zeros.flags.c_contiguous and not zeros.any()
    if zeros.nbytes >= HUGE_PAGE and cells < 128:
        assert zeros.ctypes.data % HUGE_PAGE == 0
