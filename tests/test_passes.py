"""The compiled passes of a build (``fmm.passes``) against the plain ones (``lattice``) and the direct sum."""

from __future__ import annotations

import importlib.util
from pathlib import Path

import numpy as np
import pytest

from fmr_editor.engine import Representation, evaluate_points
from fmr_editor.engine.cells import Cells, propagated
from fmr_editor.engine.fmm import orders
from fmr_editor.engine.fmm.lattice import (
    Lattice,
    cell_order,
    coarser_multipoles,
    cut_into_cells,
    downward_pass,
    fine_multipoles,
    upward_pass,
)
from fmr_editor.engine.fmm.passes import build_passes, downward, level_sources
from fmr_editor.engine.fmm.sparse_downward import delta_local
from fmr_editor.engine.geometry.discretise import boundary_segments, curve_segments
from fmr_editor.engine.geometry.segments import Segments
from fmr_editor.engine.kernels.fastmath import INV_TWO_PI
from fmr_editor.engine.kernels.segment_sums import direct_sum

_PATH = Path(__file__).resolve().parents[1] / "bench" / "hilbert.py"
_spec = importlib.util.spec_from_file_location("bench_hilbert", _PATH)
hilbert = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(hilbert)

SIDE = 256.0
WIDTH = 16


def random_segments(rng, count: int, lattice: Lattice, spread: float) -> Segments:
    """Short segments around the canvas centre (``spread`` of the side: small leaves most cells empty), cut and
    sorted by cell, with random E and C."""
    centre = rng.normal(SIDE / 2, spread * SIDE, (count, 2)).clip(1.0, SIDE - 1.0)
    q = (centre + rng.normal(0.0, 2.0, (count, 2))).clip(0.5, SIDE - 0.5)
    n = count
    segments = Segments(p=centre, q=q, jump=rng.normal(size=(n, 3)), mean=np.zeros((n, 3)),
                        on_border=np.zeros(n, bool), flux=rng.normal(size=(n, 3)))
    return cut_into_cells(segments, lattice)


def hilbert_segments(iteration: int, levels: int, seed: int = 0) -> tuple[Segments, np.ndarray, Lattice]:
    """The Hilbert benchmark scene's segments cut at the cells, with random E (as ``bench/bench_paper.py``)."""
    settings = hilbert.hilbert_settings(int(SIDE), levels=levels)
    document = hilbert.hilbert_document(iteration, int(SIDE))
    lattice = Lattice(levels, SIDE)
    curves = curve_segments(document, settings.tolerance, settings.max_length)
    segments = boundary_segments(curves, document, lattice.cell_size, settings.border_spacing)
    rng = np.random.default_rng(seed)
    border = segments.on_border[:, None]
    segments = Segments(p=segments.p, q=segments.q, mean=segments.mean, on_border=segments.on_border,
                        flux=np.where(border, 0.0, rng.standard_normal((len(segments), 3))),
                        jump=np.where(border, rng.uniform(0.0, 1.0, (len(segments), 3)), segments.jump))
    return (*cut_into_cells(segments, lattice), lattice)


def relative(got: np.ndarray, expected: np.ndarray) -> float:
    return float(np.abs(got - expected).max() / np.abs(expected).max())


@pytest.mark.parametrize("spread", [0.02, 0.1, 1.0])  # sparse fine levels, mixed, dense everywhere
@pytest.mark.parametrize("levels", [4, 6])
def test_uniform_orders_match_the_plain_passes(spread, levels):
    rng = np.random.default_rng(levels)
    lattice = Lattice(levels, SIDE)
    segments, cell_start = random_segments(rng, 3000, lattice, spread)
    fine, local = build_passes(segments, cell_start, lattice, orders.uniform_orders(levels, WIDTH))
    assert np.array_equal(fine, fine_multipoles(segments, cell_start, lattice, WIDTH))
    expected = downward_pass(upward_pass(segments, cell_start, lattice, WIDTH), lattice, WIDTH)
    assert relative(local, expected) < 1e-12


def test_a_sparse_level_above_a_dense_one_takes_its_multipoles_from_the_grid():
    rng = np.random.default_rng(3)
    lattice = Lattice(6, SIDE)
    segments, cell_start = random_segments(rng, 6000, lattice, 1.0)
    uniform = orders.uniform_orders(lattice.levels, WIDTH)
    fine = fine_multipoles(segments, cell_start, lattice, WIDTH).reshape(4**6, 3, WIDTH + 1)
    cells = np.flatnonzero(np.any(fine != 0, axis=(1, 2)))
    sources = level_sources(fine, cells, cells, lattice, uniform)
    assert [sources[level].dense for level in range(2, 7)] == [False, False, False, True, True]
    expected = downward_pass(upward_pass(segments, cell_start, lattice, WIDTH), lattice, WIDTH)
    assert relative(downward(sources, lattice, uniform), expected) < 1e-12


@pytest.mark.parametrize("spread", [0.02, 1.0])
def test_chosen_orders_match_the_plain_passes_truncated_alike(spread):
    rng = np.random.default_rng(7)
    lattice = Lattice(6, SIDE)
    segments, cell_start = random_segments(rng, 3000, lattice, spread)
    chosen = orders.pass_orders(lattice.levels, 8, WIDTH)
    fine, local = build_passes(segments, cell_start, lattice, chosen)
    expected = downward_pass(upward_pass(segments, cell_start, lattice, WIDTH), lattice, WIDTH, chosen)
    assert relative(local, expected) < 1e-12
    assert not local[..., 9:].any()  # nothing past the pixels' degree at the fine level


def test_orders_follow_the_error_tables():
    limit = orders.tolerance(8)
    for (dx, dy) in [(2, 0), (2, 1), (3, 3)]:
        m, q = orders.offset_orders(dx, dy, limit)
        errors = orders.truncation_errors(*sorted((abs(dx), abs(dy)), reverse=True))
        assert errors[m, orders.TABLE_ORDER] <= limit < errors[m - 1, orders.TABLE_ORDER]
        assert errors[orders.TABLE_ORDER, q] <= limit < errors[orders.TABLE_ORDER, q - 1]
    # far offsets need fewer terms; coarser (stronger) levels more, up to the width
    assert orders.offset_orders(3, 3, limit)[0] < orders.offset_orders(2, 0, limit)[0]
    chosen = orders.pass_orders(6, 8, WIDTH)
    for level in range(2, 6):
        assert (chosen.multipole[level] >= chosen.multipole[level + 1]).all()
    assert chosen.multipole[6].max() < chosen.multipole[5].max() <= WIDTH
    assert chosen.kept(6) == 8


def test_truncation_table_bounds_one_translation():
    """A unit dipole at a source cell's corner, seen from the far corner of the target: the table's bound holds."""
    from fmr_editor.engine.fmm.expansions import m2l_matrix

    d = 2.0 + 0.0j
    source, target = d + (-0.5 + 0.5j), 0.5 - 0.5j
    m, q = 9, 8
    k = np.arange(orders.TABLE_ORDER + 1)
    dipole = np.where(k > 0, (source - d) ** np.maximum(k - 1, 0), 0.0)
    local = dipole[: m + 1] @ np.asarray(m2l_matrix(d, orders.TABLE_ORDER, 0.0))[: m + 1, : q + 1]
    error = abs(np.polyval(local[::-1], target) - 1.0 / (target - source))
    table = orders.truncation_errors(2, 0)
    assert error <= table[m, orders.TABLE_ORDER] + table[orders.TABLE_ORDER, q]


@pytest.mark.parametrize(("iteration", "levels"), [(4, 4), (4, 6), (5, 7)])
def test_chosen_orders_keep_the_direct_sum(iteration, levels):
    """Within 1/255 of the direct boundary integral, and within 2x of the error of order 16 everywhere."""
    segments, cell_start, lattice = hilbert_segments(iteration, levels)
    pixels = np.random.default_rng(3).uniform(0.0, SIDE, (1500, 2))
    exact = direct_sum(pixels, segments.p, segments.q, segments.flux, segments.jump)
    errors = []
    for pixel_order in (None, 8):
        cells = Cells.build(segments, lattice, WIDTH, pixel_order=pixel_order)
        rep = Representation(int(SIDE), int(SIDE), lattice, cells.segments, cells.cell_start, cells.local, 8)
        errors.append(np.abs(evaluate_points(rep, pixels) - exact).max())
    full, chosen = errors
    assert chosen < 1 / 255
    assert chosen < 2 * full


@pytest.mark.parametrize("changed", [5, 400])  # the sparse path and the whole-level one
def test_an_edit_carries_its_change_with_the_build_orders(changed):
    rng = np.random.default_rng(11)
    lattice = Lattice(6, SIDE)
    chosen = orders.pass_orders(lattice.levels, 8, WIDTH)
    delta = np.zeros((64, 64, 3, WIDTH + 1), complex)
    cells = rng.choice(64 * 64, changed, replace=False)
    delta.reshape(-1, 3, WIDTH + 1)[cells] = rng.normal(size=(changed, 3, WIDTH + 1)) * 0.3 ** np.arange(WIDTH + 1)
    expected = downward_pass(coarser_multipoles(delta, WIDTH), lattice, WIDTH, chosen)
    assert relative(delta_local(delta, lattice, WIDTH, chosen), expected) < 1e-12


def test_propagated_equals_a_rebuild():
    rng = np.random.default_rng(5)
    lattice = Lattice(5, SIDE)
    segments, _ = random_segments(rng, 2000, lattice, 0.2)
    cells = Cells.build(segments, lattice, WIDTH, pixel_order=8)
    moved = segments.flux.copy()
    moved[:40] += 1.0
    edited = Segments(p=segments.p, q=segments.q, jump=segments.jump, mean=segments.mean,
                      on_border=segments.on_border, flux=moved)
    carried, _, _ = propagated(cells, edited, lattice, WIDTH, accuracy=1e-12)
    rebuilt = Cells.build(edited, lattice, WIDTH, pixel_order=8)
    assert carried.orders is rebuilt.orders is not None
    assert relative(carried.local, rebuilt.local) < 1e-12


def test_the_downward_pass_writes_each_fine_cells_centre_value():
    """``Cells.centres``: the far field at each fine cell's centre, ``Re L_0 / 2 pi``, written by the downward pass
    with the expansions (a build's and an edit's), not taken from them afterwards."""
    rng = np.random.default_rng(6)
    lattice = Lattice(5, SIDE)
    segments, _ = random_segments(rng, 2000, lattice, 0.3)
    cells = Cells.build(segments, lattice, WIDTH, pixel_order=8)
    assert np.array_equal(cells.centres, cells.local[..., 0].real * INV_TWO_PI)
    edited = Segments(p=segments.p, q=segments.q, jump=segments.jump, mean=segments.mean,
                      on_border=segments.on_border, flux=segments.flux * 1.5)
    carried = propagated(cells, edited, lattice, WIDTH, accuracy=1e-12)[0]
    assert carried.centres is not cells.centres
    assert np.array_equal(carried.centres, carried.local[..., 0].real * INV_TWO_PI)
    sources = level_sources(cells.fine.reshape(-1, 3, WIDTH + 1), np.arange(32 * 32), np.arange(32 * 32), lattice,
                            orders.uniform_orders(5, WIDTH))
    with pytest.raises(ValueError, match="centres"):
        downward(sources, lattice, orders.uniform_orders(5, WIDTH), centres=np.empty((16, 16, 3)))


def test_a_builds_levels_of_some_work_take_both_cores_and_an_edits_keep_one(monkeypatch):
    """``passes.BUILD_PARALLEL_CELLS``: a build's whole-level M2L runs on every thread from 256 cells of work (a
    level of 16 x 16 coarse cells), an edit's change and a solve's product below ``PARALLEL_CELLS`` (4,096) on
    one; the threads are given back after each level."""
    import numba

    from fmr_editor.engine.fmm import level_kernels, passes

    threads, seen, level_local = numba.get_num_threads(), [], level_kernels.level_local
    monkeypatch.setattr(level_kernels, "level_local", lambda size, *args: seen.append((size, numba.get_num_threads()))
                        or level_local(size, *args))
    rng = np.random.default_rng(8)
    lattice = Lattice(5, SIDE)
    segments, _ = random_segments(rng, 4000, lattice, 1.0)
    cells = Cells.build(segments, lattice, WIDTH, pixel_order=8)
    assert seen == [(4, 1), (8, 1), (16, threads), (32, threads)] and numba.get_num_threads() == threads
    seen.clear()
    edited = Segments(p=segments.p, q=segments.q, jump=segments.jump, mean=segments.mean,
                      on_border=segments.on_border, flux=segments.flux * 1.5)
    propagated(cells, edited, lattice, WIDTH, accuracy=1e-12)
    assert seen == [(4, 1), (8, 1), (16, 1), (32, 1)] and numba.get_num_threads() == threads
    seen.clear()
    delta_local(cells.fine, lattice, WIDTH, cells.orders)  # a solve's product
    assert seen == [(4, 1), (8, 1), (16, 1), (32, 1)]
    assert passes.BUILD_PARALLEL_CELLS < 16 * 16 * passes._term_pairs(cells.orders, 4) / passes.CELL_TERM_PAIRS


def test_cells_sort_as_a_stable_argsort():
    rng = np.random.default_rng(2)
    lattice = Lattice(5, SIDE)
    points = np.concatenate([rng.uniform(-5.0, SIDE + 5.0, (5000, 2)),  # outside: clamped to the border cells
                             rng.integers(0, 32, (500, 2)) * lattice.cell_size])  # on cell edges
    segments = Segments(p=points, q=points, jump=np.zeros((len(points), 3)), mean=np.zeros((len(points), 3)),
                        on_border=np.zeros(len(points), bool), flux=np.zeros((len(points), 3)))
    order, cell_start = cell_order(segments, lattice)
    cells = lattice.cell_of(points)
    flat = cells[:, 0] * 32 + cells[:, 1]
    assert np.array_equal(order, np.argsort(flat, kind="stable"))
    assert np.array_equal(cell_start, np.concatenate([[0], np.cumsum(np.bincount(flat, minlength=32 * 32))]))
