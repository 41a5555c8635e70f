"""Undo history, change sets and edits of the document model."""

from __future__ import annotations

import numpy as np
import pytest
from shapes import scattered_document

from fmr_editor.model import ColorStop, DiffusionPoint, Document, edits
from fmr_editor.model.changes import ChangeSet
from fmr_editor.model.history import History


def dot(x: float, radius: float = 4.0) -> DiffusionPoint:
    return DiffusionPoint((x, 10.0), radius, (1.0, 0.5, 0.0))


@pytest.fixture
def history_and_calls():
    history = History(Document(32, 32))
    calls = []
    history.subscribe(lambda before, after: calls.append((before, after)))
    return history, calls


def test_undo_redo_walk_the_steps_and_name_them(history_and_calls):
    history, calls = history_and_calls
    start = history.document
    one = edits.add_points(start, [dot(1)])
    two = edits.add_points(one, [dot(2)])
    history.apply(one, "Paint")
    history.apply(two, "Paint Again")
    assert history.undo_label == "Paint Again" and history.redo_label is None
    history.undo()
    assert history.document is one and history.redo_label == "Paint Again"
    history.undo()
    assert history.document is start and not history.can_undo
    history.redo()
    history.redo()
    assert history.document is two
    assert [after for _, after in calls] == [one, two, one, start, one, two]


def test_a_new_edit_after_undo_drops_the_undone_steps(history_and_calls):
    history, _ = history_and_calls
    one = edits.add_points(history.document, [dot(1)])
    history.apply(one, "A")
    history.apply(edits.add_points(one, [dot(2)]), "B")
    history.undo()
    history.apply(edits.add_points(one, [dot(3)]), "C")
    assert history.labels == ("", "A", "C") and not history.can_redo


def test_equal_documents_and_merge_keys_do_not_add_steps(history_and_calls):
    history, calls = history_and_calls
    history.apply(Document(32, 32), "Nothing")
    assert history.index == 0 and calls == []
    for x in (1, 2, 3):
        history.apply(edits.add_points(Document(32, 32), [dot(x)]), "Slide", merge_key="slider")
    assert history.index == 1 and history.document.points == (dot(3),)
    history.undo()
    assert history.document == Document(32, 32)


def test_a_drag_is_one_step_and_cancel_restores_the_start(history_and_calls):
    history, calls = history_and_calls
    start = history.document
    history.begin("Move Point")
    for x in (1, 2, 3):
        history.preview(edits.add_points(start, [dot(x)]))
    assert not history.can_undo  # nothing recorded mid-drag
    history.commit()
    assert history.index == 1 and history.undo_label == "Move Point"
    assert history.document.points == (dot(3),)
    final = history.document
    history.begin("Move Point")
    history.preview(edits.add_points(final, [dot(9)]))
    history.cancel()
    assert history.document is final and history.index == 1
    assert calls[-1][1] is final  # listeners were taken back
    with pytest.raises(RuntimeError):
        history.commit()


def test_step_listeners_hear_of_every_new_step_and_every_transactions_end(history_and_calls):
    history, _ = history_and_calls
    seen = []
    history.subscribe_steps(lambda: seen.append((history.labels, history.index, history.in_transaction)))
    history.apply(edits.add_points(history.document, [dot(1)]), "Paint")
    assert seen[-1] == (("", "Paint"), 1, False)
    history.begin("Move Point")
    history.preview(edits.add_points(history.document, [dot(2)]))
    assert len(seen) == 1 and history.in_transaction  # previews add no step
    history.commit()  # the document shown does not change, but a step was added: a history list must hear of it
    assert seen[-1] == (("", "Paint", "Move Point"), 2, False) and len(seen) == 2
    history.begin("Move Point")
    history.preview(edits.add_points(history.document, [dot(3)]))
    history.cancel()
    assert len(seen) == 3 and seen[-1][1:] == (2, False)
    history.undo()
    history.mark_saved()
    assert [entry[1] for entry in seen[-2:]] == [1, 1]


def test_modified_follows_the_saved_step(history_and_calls):
    history, _ = history_and_calls
    assert not history.modified
    history.apply(edits.add_points(history.document, [dot(1)]), "Paint")
    assert history.modified
    history.mark_saved()
    history.undo()
    assert history.modified
    history.redo()
    assert not history.modified


def test_change_sets_match_items_by_value():
    doc = scattered_document(64, circles=3, seed=1)
    points = (dot(1), dot(2), dot(2), dot(3))
    before = doc.with_points(points)
    after = edits.set_stop_color(before, before.curves[1].id, "left", 0, (0.1, 0.2, 0.3))
    after = after.with_points((dot(3), dot(2), dot(4)))  # reordered, one dot(2) and dot(1) gone, dot(4) new
    changes = ChangeSet.between(before, after)
    assert changes.curves_changed and changes.removed_curves == (1,) and changes.added_curves == (1,)
    assert changes.removed_points == (0, 1)  # dot(1) and the first dot(2)
    assert [after.points[i] for i in changes.added_points] == [dot(4)]
    appended = edits.add_points(before, [dot(5), dot(6)])
    assert ChangeSet.between(before, appended).added_points == (4, 5)
    assert ChangeSet.between(before, before).empty
    reordered = before.with_curves(before.curves[::-1])
    changes = ChangeSet.between(before, reordered)
    assert changes.curves_changed and changes.removed_curves == () and changes.added_curves == ()


def test_matching_past_the_same_head_and_tail_finds_what_counting_everything_finds():
    from fmr_editor.model.changes import _difference, _unmatched

    rng = np.random.default_rng(3)
    pool = [dot(i % 4) for i in range(8)]  # pairs of equal values as distinct objects
    for _ in range(200):
        before = tuple(pool[i] for i in rng.integers(0, 8, rng.integers(0, 9)))
        after = list(before)
        for _ in range(rng.integers(0, 3)):
            where = rng.integers(0, len(after) + 1)
            if rng.random() < 0.5 and after:
                after.pop(min(where, len(after) - 1))
            else:
                after.insert(where, pool[rng.integers(0, 8)])
        after = tuple(after)
        removed, added = _unmatched(before, after)
        expected_removed, expected_added = _difference(before, after)

        def values(items, indices):  # equal items are interchangeable: compare the multisets of values
            return sorted(items[i].position for i in indices)

        assert values(before, removed) == values(before, expected_removed)
        assert values(after, added) == values(after, expected_added)


def test_a_curve_replaced_among_many_is_matched_without_hashing_the_others(monkeypatch):
    from fmr_editor.model import DiffusionCurve

    doc = scattered_document(64, circles=40, seed=2)
    after = edits.set_stop_color(doc, doc.curves[17].id, "left", 0, (0.1, 0.2, 0.3))
    hashed = []
    original = DiffusionCurve.__hash__
    monkeypatch.setattr(DiffusionCurve, "__hash__", lambda curve: hashed.append(curve) or original(curve))
    changes = ChangeSet.between(doc, after)
    assert changes.removed_curves == (17,) and changes.added_curves == (17,)
    assert hashed and all(curve is doc.curves[17] or curve is after.curves[17] for curve in hashed)


def test_edits_change_only_what_they_name():
    doc = scattered_document(64, circles=2, seed=3)
    moved = edits.move_control_point(doc, doc.curves[0].id, 2, (5.0, 6.0))
    assert np.array_equal(moved.curves[0].control_points[2], (5.0, 6.0))
    assert moved.curves[1] is doc.curves[1] and moved.curves[0].left == doc.curves[0].left
    recoloured = edits.set_stop_color(doc, doc.curves[0].id, "right", 1, (1.0, 0.0, 0.0))
    assert recoloured.curves[0].right[1] == ColorStop(doc.curves[0].right[1].position, (1.0, 0.0, 0.0))
    assert recoloured.curves[0].left == doc.curves[0].left
    with pytest.raises(ValueError):
        edits.set_stop_color(doc, doc.curves[0].id, "up", 0, (0, 0, 0))
    fewer = edits.remove_stop(edits.add_stop(doc, doc.curves[0].id, "left", ColorStop(0.5, (0, 0, 0))),
                              doc.curves[0].id, "left", 0)
    assert len(fewer.curves[0].left) == len(doc.curves[0].left)


def test_translate_moves_only_the_named_items():
    doc = scattered_document(64, circles=2, seed=3).with_points([dot(1), dot(2)])
    ids = [curve.id for curve in doc.curves]
    moved = edits.translate(doc, (2.0, -1.0), curves=[ids[0]], control_points=[(ids[1], 3), (ids[0], 1)],
                            points=[doc.points[1].id])
    np.testing.assert_allclose(moved.curves[0].control_points, doc.curves[0].control_points + (2, -1))
    delta = moved.curves[1].control_points - doc.curves[1].control_points
    assert np.array_equal(np.flatnonzero(delta.any(axis=1)), [3]) and np.allclose(delta[3], (2, -1))
    assert moved.points == (dot(1), DiffusionPoint((4.0, 9.0), 4.0, (1.0, 0.5, 0.0)))
    assert moved.curves[2] is doc.curves[2] and moved.curves[0].left == doc.curves[0].left
    assert edits.translate(doc, (0, 0), curves=[ids[0]]) is doc
    assert edits.translate(doc, (1, 1), curves=[ids[0]]).points is doc.points  # points untouched: same tuple


def test_move_stop_resorts_the_stops():
    doc = scattered_document(64, circles=1, seed=3)  # left stops at 0, 2, 4
    moved = edits.move_stop(doc, doc.curves[0].id, "left", 0, 3.0)
    left = moved.curves[0].left
    assert [s.position for s in left] == [2.0, 3.0, 4.0] and left[1].color == doc.curves[0].left[0].color
    assert edits.move_stop(doc, doc.curves[0].id, "left", 1, 99.0).curves[0].left[2].position == 4.0  # clamped to k
    assert moved.curves[0].right == doc.curves[0].right


def _same_stops_on(old, new, mapping):
    """Every stop of ``new`` is a stop of ``old`` moved by ``mapping``, at the same place on the curve."""
    for side in ("left", "right"):
        before, after = getattr(old, side), getattr(new, side)
        assert [b.color for b in before] == [a.color for a in after]
        expected = [mapping(b.position) for b in before]
        np.testing.assert_allclose([a.position for a in after], expected, atol=1e-12)
        np.testing.assert_allclose(new.point_at(np.array(expected)),
                                   old.point_at(np.array([b.position for b in before])), atol=1e-9)


def test_insert_anchor_keeps_the_shape_and_the_stops_places():
    doc = scattered_document(64, circles=1, seed=4)  # a 4-piece circle, stops at 0, 2, 4
    doc = edits.add_stop(edits.add_stop(doc, doc.curves[0].id, "left", ColorStop(1.1, (1, 0, 0))), doc.curves[0].id,
                         "right", ColorStop(1.5, (0, 1, 0)))
    old = doc.curves[0]
    new = edits.insert_anchor(doc, doc.curves[0].id, 1.25).curves[0]
    assert new.piece_count == 5

    def split(s):
        u = s - 1
        return np.select([s <= 1, s <= 1.25, s <= 2], [s, 1 + u / 0.25, 2 + (u - 0.25) / 0.75], s + 1)

    s = np.linspace(0, 4, 33)
    np.testing.assert_allclose(new.point_at(split(s)), old.point_at(s), atol=1e-12)
    _same_stops_on(old, new, lambda x: float(split(np.array(x))))
    assert (edits.insert_anchor(doc, doc.curves[0].id, 2.0) is doc
            and edits.insert_anchor(doc, doc.curves[0].id, 4.0) is doc)


def test_remove_anchors_joins_inner_pieces_and_cuts_end_pieces():
    doc = scattered_document(64, circles=1, seed=4)  # stops at 0, 2, 4
    old = doc.curves[0]
    points = old.control_points
    joined = edits.remove_anchors(doc, doc.curves[0].id, [6]).curves[0]  # anchor 2 of 0..4: pieces 1 and 2 join
    np.testing.assert_allclose(joined.control_points, np.delete(points, [5, 6, 7], axis=0))
    assert [s.position for s in joined.left] == [0.0, 1.5, 3.0]
    assert [s.color for s in joined.left] == [s.color for s in old.left]
    cut = edits.remove_anchors(doc, doc.curves[0].id, [0, 12]).curves[0]  # both end pieces go
    np.testing.assert_allclose(cut.control_points, points[3:-3])
    s = np.linspace(1, 3, 9)
    for side in ("left_colors_at", "right_colors_at"):  # colours along what remains are unchanged
        np.testing.assert_allclose(getattr(cut, side)(s - 1), getattr(old, side)(s), atol=1e-12)
    assert [s.position for s in cut.left] == [0.0, 1.0, 2.0]  # cut ends keep the colour there
    with pytest.raises(ValueError):
        edits.remove_anchors(doc, doc.curves[0].id, [4])  # a handle
    with pytest.raises(ValueError):
        edits.remove_anchors(doc, doc.curves[0].id, [0, 3, 6, 9])  # one anchor would remain


def test_unsubscribed_listeners_hear_nothing_more(history_and_calls):
    history, calls = history_and_calls
    heard = []

    def listener(before, after):
        heard.append("document")

    def steps():
        heard.append("steps")

    history.subscribe(listener)
    history.subscribe_steps(steps)
    history.apply(edits.add_points(history.document, [DiffusionPoint((1.0, 1.0), 2.0, (1.0, 0.0, 0.0))]), "Paint")
    assert sorted(heard) == ["document", "steps"]
    history.unsubscribe(listener)
    history.unsubscribe_steps(steps)
    history.unsubscribe(listener)  # twice: nothing
    history.undo()
    assert sorted(heard) == ["document", "steps"]
