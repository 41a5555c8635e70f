"""Re-placing a seamless clone fast: one factorisation for every similarity, expansions at the region's cells only.

``test_clone.py`` holds the clone to a raster oracle; here each shortcut taken to re-place it quickly is held to
the plain computation it stands for: the source-pixel factorisation to a system assembled where the clone lands,
the sparse downward pass to the whole-level one, the copied segments' expansions to their direct sum, and a drag
through ``LiveStack`` (moves, turns, scales, the canvas edge) to a fresh build of every frame's document.
"""

from __future__ import annotations

import threading
from dataclasses import replace

import numba
import numpy as np
import pytest
import scipy.linalg
from shapes import scattered_document

from fmr_editor.engine import LiveStack, Representation, build, evaluate_points
from fmr_editor.engine.cloning import CopiedCells
from fmr_editor.engine.cloning import layer as clone_layer_module
from fmr_editor.engine.cloning.layer import layer_lattice
from fmr_editor.engine.fmm.expansions import m2l_matrix
from fmr_editor.engine.fmm.far_field import far_field_at
from fmr_editor.engine.fmm.lattice import Lattice, coarser_multipoles, downward_pass, fine_multipoles
from fmr_editor.engine.fmm.orders import pass_orders
from fmr_editor.engine.fmm.sparse_downward import (
    _m2l_tables,
    cascade,
    interactions,
    offset_parities,
    pass_levels,
    sparse_local,
)
from fmr_editor.engine.kernels.segment_sums import direct_sum, near_sum, pair_matrices
from fmr_editor.engine.representation import Settings
from fmr_editor.engine.solve import clone as clone_solve
from fmr_editor.engine.solve.clone import SCALE_STEPS, ClonedRegion, SeamlessClone, boundary_spacing
from fmr_editor.model import Document
from fmr_editor.model.clone import Similarity
from fmr_editor.model.clone_edits import copy_region, paste_seamless, place_clone

SIZE = 128
HEXAGON = np.array([[90.0, 62], [75, 88], [45, 88], [30, 62], [45, 36], [75, 36]])
GRID = np.stack(np.meshgrid(np.arange(1.5, SIZE, 2.5), np.arange(1.5, SIZE, 2.5)), axis=-1).reshape(-1, 2)


@pytest.fixture(scope="module")
def source():
    return build(scattered_document(SIZE, seed=3))


# -- the downward pass from a few cells to a few cells ------------------------------------------------------------


@pytest.fixture(scope="module")
def sources():
    rng = np.random.default_rng(5)
    lattice, order, n = Lattice(6, 256.0), 16, 64
    delta = np.zeros((n, n, 3, order + 1), complex)
    cells = np.unique(rng.integers(0, n * n, 70))
    delta.reshape(n * n, 3, -1)[cells] = rng.standard_normal((len(cells), 3, order + 1)) * (1 + 1j)
    return lattice, order, delta, cells, downward_pass(coarser_multipoles(delta, order), lattice, order)


def test_the_pascal_factors_make_the_m2l_matrices():
    order, log_size = 16, 1.7
    pre, pascal_t, post, log = _m2l_tables(order, log_size)
    for o, (dx, dy) in enumerate(offset_parities()[0]):
        factors = (pre[o, 0] + 1j * pre[o, 1])[:, None] * pascal_t.T * (post[o, 0] + 1j * post[o, 1])[None, :]
        factors[0, 0] = log[o, 0] + 1j * log[o, 1]
        expected = m2l_matrix(complex(dx, dy), order, log_size)
        np.testing.assert_allclose(factors, expected, rtol=1e-13, atol=1e-13 * np.abs(expected).max())


def test_the_pass_to_wanted_cells_equals_the_whole_level_pass_there_and_leaves_zero_elsewhere(sources):
    lattice, order, delta, cells, expected = sources
    n = lattice.cells_per_side
    wanted = np.random.default_rng(6).random((n, n)) < 0.35
    local = sparse_local(cells, delta.reshape(n * n, 3, -1)[cells], lattice, order, wanted)
    scale = np.abs(expected).max()
    np.testing.assert_allclose(local[wanted], expected[wanted], rtol=0, atol=1e-13 * scale)
    assert not local[~wanted].any()
    levels = pass_levels(wanted, lattice)  # carried down to a few cells only, as a clone's boundary needs
    some = np.flatnonzero(wanted)[::9]
    targets, few = cascade(interactions(cells, delta.reshape(n * n, 3, -1)[cells], lattice, order, levels), levels,
                           order, some)
    assert sorted(targets) == sorted(some)
    np.testing.assert_allclose(few, expected.reshape(n * n, 3, -1)[targets], rtol=0, atol=1e-13 * scale)


def test_with_a_builds_orders_the_pass_to_wanted_cells_truncates_each_translation_as_the_whole_level_pass_does(
        sources):
    """Each translation keeps its level's and offset's terms (a build's ``pass_orders``): the reference is
    ``downward_pass`` with the same orders, whose fine level keeps the pixels' terms only."""
    lattice, order, delta, cells, every_term = sources
    n = lattice.cells_per_side
    orders = pass_orders(lattice.levels, 8, order)
    expected = downward_pass(coarser_multipoles(delta, order), lattice, order, orders)
    wanted = np.random.default_rng(7).random((n, n)) < 0.35
    local = sparse_local(cells, delta.reshape(n * n, 3, -1)[cells], lattice, order, wanted, orders)
    assert local.shape[-1] == orders.kept(lattice.levels) + 1 == 9
    assert not expected[..., 9:].any()
    scale = np.abs(expected).max()
    np.testing.assert_allclose(local[wanted], expected[wanted, :, :9], rtol=0, atol=1e-13 * scale)
    assert not local[~wanted].any()
    assert np.abs(local[wanted] - every_term[wanted, :, :9]).max() > 1e-6 * scale  # terms were dropped


# -- one factorisation for every similarity -------------------------------------------------------------------------


def target_frame_flux(clone: SeamlessClone, target: np.ndarray) -> np.ndarray:
    """``E`` on ``Gamma`` from the system assembled and factorised where the clone lands (the plain way)."""
    gp, gq = clone.gamma_p, clone.gamma_q
    single, double = pair_matrices(clone.midpoints, gp, gq)
    n = len(gp)
    double[np.arange(n), np.arange(n)] = 0.0
    system = np.zeros((n + 1, n + 1))
    system[:n, :n], system[:n, n], system[n, :n] = single, 1.0, np.hypot(*(gq - gp).T)
    copied = clone.copied
    rhs = np.zeros((n + 1, 3))
    rhs[:n] = 0.5 * target + double @ target - direct_sum(clone.midpoints, copied.p, copied.q, copied.flux,
                                                           copied.jump)
    rhs[n] = -(copied.flux * copied.lengths[:, None]).sum(axis=0)
    return scipy.linalg.solve(system, rhs)[:n]


@pytest.mark.parametrize("similarity", [
    Similarity(1.0, 0.0, (6.0, -4.0)),
    Similarity().about((60.0, 62.0), 1.05, 35.0).moved(4.0, -3.0),  # turned, scaled within the first step above 1
    Similarity(1.0, 0.0, (120.0, 0.0), mirror=True).about((60.0, 62.0), 0.7, -80.0),
    Similarity().about((60.0, 62.0), 1.6, 200.0),
])
def test_every_similarity_is_solved_through_the_source_pixel_factorisation(source, similarity):
    clone = SeamlessClone(source.segments, HEXAGON, similarity, canvas=(SIZE, SIZE))
    target = np.random.default_rng(1).random((len(clone.midpoints), 3))
    flux = clone.gamma(target).flux
    expected = target_frame_flux(clone, target)
    np.testing.assert_allclose(flux, expected, rtol=0, atol=1e-9 * np.abs(expected).max())
    again = SeamlessClone(source.segments, HEXAGON, similarity, canvas=(SIZE, SIZE))
    np.testing.assert_array_equal(again.gamma(target).flux, flux)  # a fresh build: the very same numbers


def test_the_region_is_clipped_while_its_boundary_is_factorised(source, monkeypatch):
    """The factorisation runs on a thread of its own: the constructor returns (the copied segments clipped) while it
    is held back, and the solve waits for it and gives what a factorisation in line gives."""
    release, factorised = threading.Event(), clone_solve._factorised
    monkeypatch.setattr(clone_solve, "_factorised", lambda system: release.wait(60) and factorised(system))
    region = ClonedRegion(source.segments, HEXAGON, 1.0)
    assert not region._factorising.done() and len(region.copied) > 0
    release.set()
    target = np.random.default_rng(2).random((len(region.gamma_p), 3))
    flux = region.flux(target, region.copied_at_gamma)
    n = len(region.gamma_p)
    rhs = np.vstack([0.5 * target + region._double @ target - region.copied_at_gamma, -region.copied_flux])
    single = pair_matrices(0.5 * (region.gamma_p + region.gamma_q), region.gamma_p, region.gamma_q)[0]
    system = np.block([[single, np.ones((n, 1))], [np.hypot(*(region.gamma_q - region.gamma_p).T)[None], 0.0]])
    expected = np.linalg.solve(system, rhs)[:n]
    np.testing.assert_allclose(flux, expected, rtol=0, atol=1e-12 * np.abs(expected).max())


def test_the_copied_cells_are_expanded_on_one_core_while_the_boundary_is_factorised_on_the_other(source, monkeypatch):
    release, factorised = threading.Event(), clone_solve._factorised
    monkeypatch.setattr(clone_solve, "_factorised", lambda system: release.wait(60) and factorised(system))
    threads, seen, levels = numba.get_num_threads(), [], clone_layer_module.pass_levels
    monkeypatch.setattr(clone_layer_module, "pass_levels", lambda *args: seen.append(numba.get_num_threads())
                        or levels(*args))
    clone = SeamlessClone(source.segments, HEXAGON, Similarity(1.0, 0.0, (6.0, -4.0)), canvas=(SIZE, SIZE))
    lattice = Lattice(5, float(SIZE))
    held = CopiedCells.build(clone, lattice, Settings())
    assert not clone.cloned.factorising.done() and numba.get_num_threads() == threads
    release.set()
    clone.cloned.factorising.result()
    again = CopiedCells.build(clone, lattice, Settings())
    assert seen == [1, threads]
    for level, other in zip(held.m2l, again.m2l):
        assert (level is None) == (other is None)
        if level is not None:
            np.testing.assert_allclose(level, other, rtol=0, atol=1e-13 * np.abs(other).max())


def test_a_failed_factorisation_is_raised_where_the_solve_needs_it(source, monkeypatch):
    def failing(system):
        raise MemoryError("no room for the boundary system")

    monkeypatch.setattr(clone_solve, "_factorised", failing)
    region = ClonedRegion(source.segments, HEXAGON, 1.0)
    with pytest.raises(MemoryError, match="boundary system"):
        region.flux(np.zeros((len(region.gamma_p), 3)), region.copied_at_gamma)


def test_a_placement_keeps_the_factorisation_within_a_step_of_scale_and_takes_a_new_one_beyond(source):
    clone = SeamlessClone(source.segments, HEXAGON, Similarity(1.0, 0.0, (4.0, 2.0)), canvas=(SIZE, SIZE))
    turned = clone.placed(clone.similarity.about((60.0, 62.0), 1.0, 50.0))
    scaled = clone.placed(clone.similarity.about((60.0, 62.0), 0.95, -20.0))
    assert turned._factors is clone._factors and scaled._factors is clone._factors
    assert clone.placed(clone.similarity.about((60.0, 62.0), 0.9))._factors is not clone._factors  # another step
    assert clone.placed(Similarity(1.0, 0.0, (70.0, 0.0)))._factors is not clone._factors  # cut by the canvas edge
    for scale in (0.37, 0.9, 1.0, 1.01, 2.5):
        length = scale * boundary_spacing(1.0, scale)
        assert 2.0 ** (-1 / SCALE_STEPS) < length <= 1.0


def test_the_copied_sum_at_gamma_from_their_expansions_is_the_direct_sum_shifted_by_the_scale(source):
    similarity = Similarity().about((60.0, 62.0), 1.3, 25.0)
    clone = SeamlessClone(source.segments, HEXAGON, similarity, canvas=(SIZE, SIZE))
    picture = LiveStack(scattered_document(SIZE, seed=8)).composite
    copied = CopiedCells.build(clone, layer_lattice(clone, picture, Settings()), Settings())
    order, lattice, mids = Settings().propagation_order, copied.lattice, clone.midpoints
    ours = copied.at(mids)
    local = downward_pass(coarser_multipoles(fine_multipoles(copied.segments, copied.cell_start, lattice, order),
                                             order), lattice, order, copied.orders)  # the whole-level passes
    seg = copied.segments
    whole = far_field_at(local, lattice, lattice.cell_of(mids), mids) + near_sum(
        mids, lattice.cells_per_side, lattice.cell_size, copied.cell_start, seg.p, seg.q, seg.flux, seg.jump)
    np.testing.assert_allclose(ours, whole, rtol=0, atol=1e-13 * np.abs(whole).max())
    placed = clone.copied
    direct = direct_sum(mids, placed.p, placed.q, placed.flux, placed.jump)
    # the truncation at the pixels' orders: what the pixels read there too, within a hundredth of a colour level
    np.testing.assert_allclose(ours, direct, rtol=0, atol=0.01 / 255)
    shift = np.log(similarity.scale) / (2 * np.pi) * clone.cloned.copied_flux  # the sum in source pixels, scaled
    np.testing.assert_allclose(direct, clone.cloned.copied_at_gamma + shift, rtol=0, atol=1e-10 * np.abs(direct).max())


# -- the layer's fields -----------------------------------------------------------------------------------------------


def test_a_clone_layers_fields_are_the_whole_level_fmr_of_their_segments_in_its_cells_and_zero_elsewhere():
    pasted = paste_seamless(scattered_document(SIZE, seed=8), copy_region(scattered_document(SIZE, seed=3), HEXAGON),
                            Similarity(1.1, 20.0, (-4.0, 6.0)))
    stack = LiveStack(pasted)
    live = stack.clones[pasted.layer.id]
    cells = live._copied.cells
    lattice = live.image.lattice
    at = lattice.cell_of(GRID)
    mine = cells[at[:, 0], at[:, 1]]
    order = Settings().propagation_order
    for rep, orders in ((live.image, live._copied.orders), (live.mask, None)):  # the mask with every term
        fine = fine_multipoles(rep.segments, rep.cell_start, lattice, order)
        whole = replace(rep, local=downward_pass(coarser_multipoles(fine, order), lattice, order, orders))
        shown, expected = evaluate_points(rep, GRID), evaluate_points(whole, GRID)
        np.testing.assert_allclose(shown[mine], expected[mine], rtol=0, atol=1e-12)
        assert not shown[~mine].any()
        assert np.abs(expected[~mine]).max() < 2e-3  # the layer is 0 there, up to the boundary's discretisation


def drag(document: Document) -> list[Document]:
    """A drag of the clone layer: moves, a turn, scales within and beyond a step, and over the canvas edge."""
    similarity = document.layer.clone.similarity
    steps = [similarity.moved(2.5, -1.0), similarity.moved(4.0, 1.5), similarity.about((60, 62), 1.0, 15.0),
             similarity.about((60, 62), 0.96, 20.0), similarity.about((60, 62), 0.8, 20.0),
             similarity.moved(45.0, 0.0), similarity.moved(4.0, 1.5)]
    return [place_clone(document, 1, step) for step in steps]


def test_a_drag_through_the_stack_gives_every_frame_as_a_fresh_build_and_keeps_the_factorisation():
    pasted = paste_seamless(scattered_document(SIZE, seed=8), copy_region(scattered_document(SIZE, seed=8), HEXAGON),
                            Similarity(offset=(3.0, 2.0)))
    stack = LiveStack(pasted)
    factors = stack.clones[pasted.layer.id]._seamless._factors
    kept = []
    for frame in drag(pasted):
        stack.update(frame, exact=False)
        kept.append(stack.clones[pasted.layer.id]._seamless._factors is factors)
        fresh = LiveStack(frame).composite
        np.testing.assert_allclose(evaluate_points(stack.composite, GRID), evaluate_points(fresh, GRID), rtol=0,
                                   atol=1e-9)
    assert kept == [True, True, True, True, False, False, True]  # not for another step of scale, nor at the edge


def test_a_moved_clone_reports_the_cells_of_both_regions_and_nothing_changes_elsewhere():
    pasted = paste_seamless(scattered_document(SIZE, seed=8), copy_region(scattered_document(SIZE, seed=3), HEXAGON),
                            Similarity(offset=(-20.0, 0.0)))
    stack = LiveStack(pasted)
    live = stack.clones[pasted.layer.id]
    before = {"image": evaluate_points(live.image, GRID), "mask": evaluate_points(live.mask, GRID),
              "picture": evaluate_points(stack.composite, GRID)}
    moved = place_clone(pasted, 1, pasted.layer.clone.similarity.moved(12.0, 5.0))
    update = stack.update(moved, exact=False)
    changed = {kind: update.fields[pasted.layer.id, kind].changed for kind in ("image", "mask")}
    assert 0.1 < changed["image"].mean() < 0.9
    assert (changed["mask"] <= changed["image"]).all()  # the mask: where only one region lies, and the rings
    at = live.image.lattice.cell_of(GRID)
    for kind, rep in (("image", live.image), ("mask", live.mask)):  # each field the same where it is not named
        outside = ~changed[kind][at[:, 0], at[:, 1]]
        assert np.abs(evaluate_points(rep, GRID) - before[kind])[outside].max() < 1e-6, kind
    after = evaluate_points(stack.composite, GRID)
    outside = ~changed["image"][at[:, 0], at[:, 1]]
    assert np.abs(after - before["picture"])[outside].max() < 1e-6
    assert np.abs(after - before["picture"])[~outside].max() > 0.05  # the clone moved


def test_a_clone_pasted_from_a_layer_of_the_document_takes_that_layers_solution():
    document = scattered_document(SIZE, seed=8)
    stack = LiveStack(document)
    pasted = paste_seamless(document, copy_region(document, HEXAGON), Similarity(offset=(10.0, 5.0)))
    stack.update(pasted)
    source = stack.fields[pasted.layer.id, "source"]
    assert source.origin == "twin"  # no solve
    assert source.representation.segments is stack.fields[document.layer.id, "image"].representation.segments
    fresh = LiveStack(pasted).composite
    np.testing.assert_allclose(evaluate_points(stack.composite, GRID), evaluate_points(fresh, GRID), rtol=0, atol=1e-9)
    assert isinstance(source.representation, Representation)
