"""Row-wise results kept between edits (``engine/geometry/splice.py``) and the boundary cut only where curves
changed (``discretise.BoundaryCuts`` against the plain ``boundary_segments``)."""

from __future__ import annotations

import numpy as np
import pytest
from shapes import circle_points, scattered_document, straight_chain, uniform_curve

from fmr_editor.engine.geometry.discretise import (
    BoundaryCuts,
    boundary_segments,
    cell_cuts,
    curve_segments,
    cut_at_cells,
)
from fmr_editor.engine.geometry.segments import Segments, concatenate
from fmr_editor.engine.geometry.splice import Blocks, RowCache, reused_rows, splice
from fmr_editor.model import Document, edits

FIELDS = ("p", "q", "jump", "mean", "on_border", "flux", "origin")


def assert_same(got: Segments, expected: Segments) -> None:
    """Equal bit for bit (-0.0 is not 0.0), field by field."""
    assert len(got) == len(expected)
    for name in FIELDS:
        assert getattr(got, name).tobytes() == getattr(expected, name).tobytes(), name


def labelled(count: int, seed: int) -> Segments:
    rng = np.random.default_rng(seed)
    p = rng.uniform(0, 64, (count, 2))
    q = p + rng.normal(0, 6, (count, 2))
    jump = np.repeat(np.arange(count, dtype=float)[:, None], 3, axis=1)
    return Segments(p, q, jump, rng.random((count, 3)), np.zeros(count, bool), np.zeros((count, 3)))


def taken(blocks: Blocks) -> list[int]:
    """Each row's old row, -1 for rows worked out anew."""
    return blocks.to_old(np.arange(blocks.rows)).tolist()


def test_reused_rows_match_bits_in_place_or_by_common_start_and_end():
    old = labelled(50, 1)
    changed = old.take(np.arange(50))
    changed.mean[[3, 30]] += 1.0
    assert taken(reused_rows(old, changed)) == [i if i not in (3, 30) else -1 for i in range(50)]
    signed = old.take(np.arange(50))
    signed.flux[7, 1] = -0.0  # the same value, other bits: its pieces would differ
    assert taken(reused_rows(old, signed))[7] == -1
    longer = concatenate([old.take(np.arange(20)), labelled(3, 2), old.take(np.arange(22, 50))])
    assert taken(reused_rows(old, longer)) == [*range(20), -1, -1, -1, *range(22, 50)]
    assert reused_rows(old, longer).gone(50).tolist() == [20, 21]


def test_blocks_map_rows_both_ways_and_take_more_rows_anew():
    blocks = Blocks.of([3, 0, 2, 4, 1, 2], [10, 5, -1, 0, -1, -1])  # an empty block, two fresh ones joined
    assert (blocks.at.tolist(), blocks.length.tolist(), blocks.source.tolist()) == ([0, 3, 5, 9], [3, 2, 4, 3],
                                                                                     [10, -1, 0, -1])
    assert taken(blocks) == [10, 11, 12, -1, -1, 0, 1, 2, 3, -1, -1, -1]
    assert blocks.to_new(np.arange(14)).tolist() == [5, 6, 7, 8, -1, -1, -1, -1, -1, -1, 0, 1, 2, -1]
    assert blocks.fresh_rows().tolist() == [3, 4, 9, 10, 11] and blocks.gone(14).tolist() == [4, 5, 6, 7, 8, 9, 13]
    more = blocks.refreshed(np.array([0, 4, 6, 7]))
    assert taken(more) == [-1, 11, 12, -1, -1, 0, -1, -1, 3, -1, -1, -1]
    assert taken(Blocks.of([4, 4], [0, 4])) == list(range(8)) and len(Blocks.of([4, 4], [0, 4]).at) == 1


def test_splice_takes_old_pieces_and_puts_new_ones_between():
    old = labelled(10, 3)
    starts = np.array([0, 1, 3, 3, 4, 6, 7, 8, 9, 9, 10])  # rows 2 and 8 made no pieces
    fresh = labelled(4, 4)
    blocks = Blocks.of([1, 1, 3, 2, 2], [0, -1, 1, -1, 8])
    pieces, got_starts = splice(old, starts, blocks, fresh, np.array([0, 2, 2, 4]))
    expected = [old.take([0]), fresh.take([0, 1]), old.take([1, 2]), old.take([3]), fresh.take([2, 3]),
                old.take([9])]
    assert_same(pieces, concatenate(expected))
    np.testing.assert_array_equal(got_starts, [0, 1, 3, 5, 5, 6, 6, 8, 8, 9])
    rows, none = splice(old, None, blocks, fresh.take([0, 1, 2]), None)  # one piece a row: the rows themselves
    assert none is None
    assert_same(rows, concatenate([old.take([0]), fresh.take([0]), old.take([1, 2, 3]), fresh.take([1, 2]),
                                   old.take([8, 9])]))


def test_a_row_cache_works_out_only_changed_rows_and_forgets_dropped_outputs():
    calls = []

    def cut(segments, cell):
        calls.append(len(segments))
        return cell_cuts(segments, cell)

    cache = RowCache(cut)
    first = labelled(40, 5)
    out = cache([first], 8.0)
    assert_same(out, cut_at_cells(first, 8.0))
    second = concatenate([first.take(np.arange(10)), labelled(2, 6), first.take(np.arange(13, 40))])
    assert_same(cache([second], 8.0), cut_at_cells(second, 8.0))
    assert calls == [40, 2]
    assert_same(cache([second], 5.0), cut_at_cells(second, 5.0))  # another key: all rows
    assert calls[-1] == 39
    del out
    third = labelled(40, 5)  # equal to first, another object: its output went, so everything is cut
    cache([third], 8.0)
    assert calls[-1] == 40


def drag_steps(document: Document) -> list[Document]:
    """Edits that change the curves' rows in every way: a moved anchor, an added and a removed curve, a
    recoloured curve, curves reordered, a curve leaving the canvas."""
    first, last = document.curves[0].id, document.curves[-1].id
    return [
        edits.move_control_point(document, first, 3, tuple(document.curves[0].control_points[3] + (1.5, 0.5))),
        edits.add_curve(document, uniform_curve(straight_chain([(5, 60), (100, 70)]), 0.2, 0.9)),
        edits.remove_curves(document, [first]),
        edits.set_stop_color(document, last, "left", 0, (0.1, 0.2, 0.3)),
        Document(document.width, document.height, document.curves[::-1]),
        edits.translate(document, (90.0, 0.0), curves=[last]),
    ]


def test_boundary_segments_equal_the_reference_edit_after_edit():
    document = scattered_document(size=128)
    cuts = BoundaryCuts()
    held = []  # as LiveRepresentation, the last curves and boundary stay alive until replaced
    for cell in (8.0, 16.0):
        for step in [document, *drag_steps(document), document]:
            curves = curve_segments(step)
            got = cuts(curves, step, cell)
            assert_same(got, boundary_segments(curves, step, cell))
            held = [curves, got]
    assert held


def test_an_anchor_move_cuts_only_the_moved_curves_rows():
    document = Document(200, 200, [uniform_curve(circle_points(40 + 30 * i, 100, 12), 0.1 * i, 0.5)
                                   for i in range(5)])
    curves = curve_segments(document)
    cuts = BoundaryCuts()
    held = [curves, cuts(curves, document, 16.0)]
    moved = edits.move_control_point(document, document.curves[2].id, 0, (112.0, 101.0))
    moved_curves = curve_segments(moved)
    got = cuts(moved_curves, moved, 16.0)
    assert_same(got, boundary_segments(moved_curves, moved, 16.0))
    changed = len(reused_rows(curves, moved_curves).fresh_rows())
    assert 0 < cuts.computed_rows == changed <= (moved_curves.origin[:, 0] == moved.curves[2].id).sum()
    assert held


@pytest.mark.parametrize("spacing", [1.0, 3.0])
def test_another_canvas_gets_its_own_border(spacing):
    document = scattered_document(size=96)
    curves = curve_segments(document)
    cuts = BoundaryCuts()
    held = [cuts(curves, document, 12.0, spacing)]
    wider = Document(120, 96, document.curves)
    assert_same(cuts(curves, wider, 12.0, spacing), boundary_segments(curves, wider, 12.0, spacing))
    assert held
