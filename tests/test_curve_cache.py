"""The kept curve segments (engine/curve_cache.py) against ``curve_segments`` from scratch, edit after edit."""

from __future__ import annotations

import numpy as np
import pytest
from shapes import straight_chain, uniform_curve

from fmr_editor.engine.geometry.curve_cache import CurveSegments
from fmr_editor.engine.geometry.discretise import curve_segments
from fmr_editor.io import load_document
from fmr_editor.model import DiffusionCurve, Document, edits

FIELDS = ("p", "q", "jump", "mean", "on_border", "flux", "origin")


def assert_same(cache: CurveSegments, document: Document) -> None:
    """The cache's segments of ``document`` are ``curve_segments``'s, bit for bit."""
    assert_equal(cache.segments(document), curve_segments(document))


def assert_equal(got, expected) -> None:
    for name in FIELDS:
        np.testing.assert_array_equal(getattr(got, name), getattr(expected, name), err_msg=name)
        assert getattr(got, name).tobytes() == getattr(expected, name).tobytes(), name


def overlapping_document() -> Document:
    """Curves along shared lines: a retracing one, two that lie on it, one elsewhere."""
    return Document(100, 100, (
        uniform_curve(straight_chain([(10, 50), (80, 50), (30, 50), (45, 50)]), 0.9, 0.1),
        uniform_curve(straight_chain([(20, 50), (60, 50)]), 0.2, 0.7),
        uniform_curve(straight_chain([(50, 10), (50, 90)]), 0.5, 0.5),
        uniform_curve(straight_chain([(70, 50), (95, 50), (95, 20)]), 0.3, 0.6),
    ))


def test_edits_give_the_segments_of_a_fresh_discretisation():
    document = overlapping_document()
    cache = CurveSegments(0.05, 2.0)
    assert_same(cache, document)
    steps = [
        lambda d: edits.move_control_point(d, d.curves[1].id, 3, (75.0, 50.0)),  # slides along the shared line
        lambda d: edits.move_control_point(d, d.curves[1].id, 3, (75.0, 60.0)),  # leaves it
        lambda d: edits.add_curve(d, uniform_curve(straight_chain([(5, 50), (40, 50)]), 0.0, 1.0)),  # on top, last
        lambda d: edits.remove_curves(d, [d.curves[0].id]),  # what it covered comes back
        lambda d: edits.translate(d, (0.0, -10.0), curves=[d.curves[1].id]),
        lambda d: edits.remove_curves(d, [d.curves[len(d.curves) - 1].id]),
    ]
    for step in steps:
        document = step(document)
        assert_same(cache, document)
    assert_same(cache, overlapping_document())  # back to the start: new objects, everything searched


def real_file(shared_data, name: str) -> Document:
    """The shared real file ``berkbavas/NAME.xml``, opened; skips when it is absent."""
    path = shared_data / "orzan_xml" / "berkbavas" / f"{name}.xml"
    if not path.exists():
        pytest.skip(f"{path} is absent")
    return load_document(path)


def test_a_real_file_with_retraced_curves(shared_data):
    document = real_file(shared_data, "flower")
    cache = CurveSegments(0.05, 2.0)
    assert_same(cache, document)
    rng = np.random.default_rng(4)
    for _ in range(4):
        k = int(rng.integers(len(document.curves)))
        points = document.curves[k].control_points
        document = edits.move_control_point(document, document.curves[k].id, 0, tuple(points[0] + rng.normal(0, 3, 2)))
        assert_same(cache, document)
    document = edits.remove_curves(document, [document.curves[int(rng.integers(len(document.curves)))].id])
    assert_same(cache, document)


# --- the overlap search after an edit ----------------------------------------------------------------------------


def twins_document() -> Document:
    """Curves on shared lines, a curve repeated (its segments twins: the later copy keeps them) and others apart."""
    line = straight_chain([(10, 30), (90, 30)])
    curves = [uniform_curve(straight_chain([(10, 10 + 8 * i), (90, 12 + 8 * i)]), 0.1 * i, 0.5) for i in range(8)]
    curves += [uniform_curve(line, 0.9, 0.1), uniform_curve(straight_chain([(20, 30), (60, 30)]), 0.2, 0.7),
               uniform_curve(line, 0.4, 0.6)]  # the first and last: twins
    return Document(100, 100, curves)


def rows_of(segments, curve) -> int:
    return int((segments.origin[:, 0] == curve.id).sum())


plain_afresh = CurveSegments._afresh


class SearchCount:
    """Segments handed to the overlap search: the whole-set search (``overlapping_pairs``) and the index's."""

    def __init__(self, monkeypatch) -> None:
        import fmr_editor.engine.geometry.curve_cache as curve_cache
        import fmr_editor.engine.geometry.overlap_index as overlap_index

        self.whole, self.indexed = 0, 0
        whole, near = curve_cache.overlapping_pairs, overlap_index._Near.__call__

        def counted_whole(segments, *args, **kwargs):
            self.whole += len(segments)
            return whole(segments, *args, **kwargs)

        def counted_near(near_self, lines):
            self.indexed += len(lines)
            return near(near_self, lines)

        monkeypatch.setattr(curve_cache, "overlapping_pairs", counted_whole)
        monkeypatch.setattr(overlap_index._Near, "__call__", counted_near)


def test_an_edit_searches_only_the_changed_curves_segments(monkeypatch):
    document = twins_document()
    cache = CurveSegments(0.05, 2.0)
    before = cache.segments(document)
    count = SearchCount(monkeypatch)
    moved = edits.move_control_point(document, document.curves[2].id, 3, (90.0, 40.0))
    after = cache.segments(moved)
    assert count.whole == 0
    changed = rows_of(before, document.curves[2]) + rows_of(after, moved.curves[2])
    assert count.indexed == cache.last_search == changed < len(after) / 4
    assert_equal(after, curve_segments(moved))


def test_moving_the_last_twin_searches_its_earlier_twins_too(monkeypatch):
    document = twins_document()
    cache = CurveSegments(0.05, 2.0)
    cache.segments(document)
    count = SearchCount(monkeypatch)
    last = document.curves[-1]
    moved = edits.translate(document, (0.0, 5.0), curves=[last.id])
    after = cache.segments(moved)
    assert count.whole == 0
    twin_rows = rows_of(curve_segments(Document(100, 100, [document.curves[8]])), document.curves[8])
    # the old and new rows of the moved curve, then its twins' rows: they are the last of their twins now
    assert count.indexed == cache.last_search == 2 * twin_rows + twin_rows
    assert_equal(after, curve_segments(moved))


def test_edits_of_documents_with_twins_give_the_segments_of_a_fresh_discretisation():
    document = twins_document()
    cache = CurveSegments(0.05, 2.0)
    assert_same(cache, document)
    copy_of = document.curves[9]
    history = [document]
    steps = [
        lambda d: edits.add_curve(d, uniform_curve(copy_of.control_points, 0.0, 1.0)),  # a new last twin
        lambda d: edits.remove_curves(d, [d.curves[-1].id]),  # the last twin goes: the one before takes over
        lambda d: edits.remove_curves(d, [d.curves[-1].id]),  # the other twin goes
        lambda d: edits.add_curve(d, uniform_curve(d.curves[8].control_points, 0.3, 0.3)),
        lambda d: edits.move_control_point(d, d.curves[8].id, 0, (15.0, 30.0)),  # an earlier twin moves off
        lambda d: Document(d.width, d.height, d.curves[::-1]),  # reordered: everything afresh
        lambda d: edits.remove_curves(d, [d.curves[0].id, d.curves[4].id]),
        lambda d: edits.translate(d, (60.0, 0.0), curves=[d.curves[1].id]),  # over the canvas edge
        lambda d: edits.translate(d, (-60.0, 0.0), curves=[d.curves[1].id]),  # and back
        lambda d: edits.set_stop_color(d, d.curves[2].id, "left", 0, (0.5, 0.5, 0.5)),
        lambda d: history[-3],  # undo: an earlier document's very curves
    ]
    for step in steps:
        document = step(document)
        history.append(document)
        assert_same(cache, document)
        cache.forget(history[-2].curves + document.curves)


def test_a_curve_of_no_segments_takes_no_other_curves_rows():
    """A curve flattened into no segments (all its points at one place) holds no rows; the curve made after it
    is told apart from it."""
    point = uniform_curve(np.full((4, 2), 50.0), 0.0, 1.0)
    document = Document(100, 100, (*twins_document().curves, point))
    cache = CurveSegments(0.05, 2.0)
    assert_same(cache, document)
    line = uniform_curve(straight_chain([(20, 70), (60, 70)]), 0.6, 0.6)
    document = Document(100, 100, (*document.curves[:-1], line, point))  # made after the point, put before it
    assert_same(cache, document)
    assert_same(cache, edits.add_curve(document, uniform_curve(straight_chain([(30, 70), (50, 70)]), 0.2, 0.2)))


def test_a_curve_over_the_edge_sends_every_segment_through_the_clip():
    """``clip_to_canvas`` of the whole set leaves it alone only when every segment lies inside; otherwise every
    end point is recomputed, which moves some near the origin by an ulp."""
    near_origin = uniform_curve(straight_chain([(1.9471888932322174, 0.8823814699152238),
                                                (0.2188232194149646, 0.14793014303273438),
                                                (2.45848369368079, 2.746991174105393)]), 0.5, 0.2)
    mover = uniform_curve(straight_chain([(50, 50), (80, 60)]), 0.1, 0.9)
    document = Document(100, 100, (near_origin, mover))
    cache = CurveSegments(0.05, 2.0)
    assert_same(cache, document)
    out = edits.translate(document, (40.0, 0.0), curves=[mover.id])
    assert not np.array_equal(curve_segments(out).q[:3], curve_segments(document).q[:3])  # the ulp
    assert_same(cache, out)
    assert_same(cache, edits.translate(out, (-40.0, 0.0), curves=[mover.id]))


def test_the_first_overlap_and_the_last_send_every_segment_through_the_split(monkeypatch):
    """``drop_covered_parts`` leaves a set without overlaps alone and splits every segment of one with some."""
    afresh = []
    monkeypatch.setattr(CurveSegments, "_afresh", lambda cache, *args: afresh.append(1) or plain_afresh(cache, *args))
    near_origin = uniform_curve(straight_chain([(1.9471888932322174, 0.8823814699152238),
                                                (0.2188232194149646, 0.14793014303273438),
                                                (2.45848369368079, 2.746991174105393)]), 0.5, 0.2)
    line = uniform_curve(straight_chain([(20, 50), (80, 50)]), 0.1, 0.9)
    apart = [uniform_curve(straight_chain([(10, 60 + 4 * i), (90, 61 + 4 * i)]), 0.5, 0.5) for i in range(8)]
    document = Document(100, 100, (near_origin, line, *apart))
    cache = CurveSegments(0.05, 2.0)
    assert_same(cache, document)
    covered = edits.add_curve(document, uniform_curve(straight_chain([(30, 50), (40, 50)]), 0.3, 0.3))
    assert not np.array_equal(curve_segments(covered).q[:3], curve_segments(document).q[:3])  # the ulp
    assert_same(cache, covered)
    assert_same(cache, edits.remove_curves(covered, [covered.curves[-1].id]))
    assert len(afresh) == 1  # the first document only: the edits were brought up to date


def test_a_copied_cache_goes_its_own_way():
    document = twins_document()
    cache = CurveSegments(0.05, 2.0)
    cache.segments(document)
    twin = cache.copy()
    one = edits.move_control_point(document, document.curves[9].id, 0, (25.0, 30.0))
    other = edits.remove_curves(document, [document.curves[10].id])
    assert_same(cache, one)
    assert_same(twin, other)
    assert_same(cache, edits.remove_curves(one, [one.curves[10].id]))
    assert_same(twin, edits.move_control_point(other, other.curves[9].id, 0, (25.0, 30.0)))


def random_curve(rng: np.random.Generator) -> DiffusionCurve:
    """On a few shared lines, near the origin, or anywhere (some over the canvas edge)."""
    kind = rng.integers(4)
    if kind == 0:
        y = float(rng.choice([20.0, 50.0]))
        points = [(x, y) for x in rng.uniform(-10, 110, rng.integers(2, 5))]
    elif kind == 1:
        points = [(t, 0.5 * t + 10) for t in rng.uniform(-5, 105, rng.integers(2, 4))]
    elif kind == 2:
        points = [tuple(rng.uniform(0.1, 4.0, 2)) for _ in range(rng.integers(2, 4))]
    else:
        points = [tuple(rng.uniform(-20, 120, 2)) for _ in range(rng.integers(2, 4))]
    return uniform_curve(straight_chain(points), float(rng.random()), float(rng.random()))


def random_edit(document: Document, history: list[Document], rng: np.random.Generator) -> Document:
    ids = [curve.id for curve in document.curves]
    kind = rng.integers(7) if len(ids) > 3 else 0
    pick = ids[int(rng.integers(len(ids)))]
    if kind == 0:
        return edits.add_curve(document, random_curve(rng))
    if kind == 1:
        return edits.remove_curves(document, [pick])
    if kind == 2:  # a twin of a curve, last
        return edits.add_curve(document, uniform_curve(document.curve(pick).control_points, 0.1, 0.9))
    if kind == 3:
        points = document.curve(pick).control_points
        k = int(rng.integers(len(points)))
        return edits.move_control_point(document, pick, k, tuple(points[k] + rng.normal(0, 5, 2)))
    if kind == 4:
        return edits.translate(document, tuple(rng.normal(0, 3, 2)), curves=[pick])
    if kind == 5:
        return Document(document.width, document.height, document.curves[-1:] + document.curves[:-1])
    return history[-int(rng.integers(1, min(4, len(history)) + 1))]


@pytest.mark.parametrize("rebuild_rows", [4096, 0])
def test_random_edits_give_the_segments_of_a_fresh_discretisation(monkeypatch, rebuild_rows):
    """With the index's tree kept, and planted anew after every edit."""
    import fmr_editor.engine.geometry.curve_cache as curve_cache
    import fmr_editor.engine.geometry.overlap_index as overlap_index

    monkeypatch.setattr(overlap_index, "REBUILD_ROWS", rebuild_rows)
    monkeypatch.setattr(overlap_index, "REBUILD_SHARE", 0.125 if rebuild_rows else 0.0)
    monkeypatch.setattr(curve_cache, "FRESH_SHARE", 1.0)  # small documents: most edits change a large share
    for seed in range(4):
        rng = np.random.default_rng(seed)
        document = Document(100, 100, [random_curve(rng) for _ in range(12)])
        cache, history = CurveSegments(0.05, 2.0), []
        for _ in range(40):
            assert_same(cache, document)
            history.append(document)
            document = random_edit(document, history, rng)
            cache.forget(history[-1].curves + document.curves)


def test_fruits_with_twins(shared_data):
    document = real_file(shared_data, "fruits")
    cache = CurveSegments(0.05, 2.0)
    cache.segments(document)
    rng = np.random.default_rng(5)
    for _ in range(3):
        curve = document.curves[int(rng.integers(len(document.curves)))]
        document = edits.move_control_point(document, curve.id, 0, tuple(curve.control_points[0] + rng.normal(0, 2, 2)))
        got = cache.segments(document)
        assert cache.last_search < len(got) / 10
        assert_equal(got, curve_segments(document))


def test_forgetting_keeps_the_curves_of_the_last_document_and_those_asked_for():
    document = twins_document()
    cache = CurveSegments(0.05, 2.0)
    cache.segments(document)
    for step in range(5):
        moved = edits.move_control_point(document, document.curves[3].id, 0, (10.0 + step, 40.0))
        cache.segments(moved)
        cache.forget(document.curves + moved.curves)  # as LiveRepresentation: the document before and now
        assert len(cache._entries) == len(moved.curves) + 1  # the moved curve's version before stays
        document = moved
    cache.forget(())
    assert len(cache._entries) == len(document.curves)
