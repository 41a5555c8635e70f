"""Geometry edits go through the kept factorisation, counted (issue 25): a segment as short as a point (roses
has one, where a curve starts on a cell line) must not switch that fast path off."""

from __future__ import annotations

import numpy as np
import pytest
from shapes import scattered_document, straight_chain

from fmr_editor.engine import LiveRepresentation, build, rasterise
from fmr_editor.engine.solve import solver as fast_solve
from fmr_editor.engine.solve.solver import solved_segments
from fmr_editor.model import ColorStop, DiffusionCurve, Document, edits
from fmr_editor.session import Session

SIZE = 128


@pytest.fixture
def with_a_point_segment() -> Document:
    """Scattered circles and a chain that comes in over the canvas edge: clipped there, its first piece is 1e-10 px
    long, below ``solver.POINT_LENGTH`` of the canvas (roses had one where a curve started a hair from a cell
    line, before ``cut_at_cells`` kept to ``MIN_PIECE``)."""
    document = scattered_document(SIZE, circles=3, seed=5)
    chain = DiffusionCurve(straight_chain([(-1.5, 64.5), (1e-10, 64.5), (60.7, 80.0), (90.0, 75.0)]),
                           left=(ColorStop(0.0, (0.9, 0.2, 0.1)),), right=(ColorStop(0.0, (0.1, 0.3, 0.8)),))
    return Document(SIZE, SIZE, document.curves + (chain,))


def same_picture(live: LiveRepresentation, document: Document) -> None:
    fresh = build(document)
    np.testing.assert_allclose(rasterise(live.representation, 64, 64, 1), rasterise(fresh, 64, 64, 1),
                               rtol=0, atol=1e-6)


@pytest.mark.parametrize("dense", [True, False], ids=["dense", "compressed"])
def test_a_point_segment_leaves_geometry_edits_to_the_kept_factorisation(with_a_point_segment, dense, monkeypatch):
    monkeypatch.setattr(fast_solve, "DENSE_CROSSOVER", 10**6 if dense else 0)
    document = with_a_point_segment
    live = LiveRepresentation(document)
    boundary = live._boundary
    assert len(solved_segments(boundary)) == len(boundary) - 1  # the case: one segment takes no part
    assert live.factorisations == 1
    curve = document.curves[1]
    moved = edits.move_control_point(document, curve.id, 3, tuple(curve.control_points[3] + (2.5, -1.5)))
    live.update(moved)
    assert live.factorisations == 1
    same_picture(live, moved)
    deleted = edits.remove_curves(moved, [moved.curves[0].id])
    live.update(deleted)
    assert live.factorisations == 1
    same_picture(live, deleted)
    chain = deleted.curves[-1]  # the chain itself, beyond its point segment
    live.update(edits.move_control_point(deleted, chain.id, 6, tuple(chain.control_points[6] + (0.0, 3.0))))
    assert live.factorisations == 1
    same_picture(live, live.document)


def test_a_new_factorisation_is_counted_when_too_much_changed(with_a_point_segment):
    """The counter counts: an edit replacing more segments than the update takes factorises again."""
    document = with_a_point_segment
    live = LiveRepresentation(document)
    bigger = Document(SIZE, SIZE, document.curves + scattered_document(SIZE, circles=30, seed=9).curves[:20])
    live.update(bigger)
    assert live.factorisations == 2


#: The real files opened in this test: those up to fruits' size (segments), as the editor opens them.
REAL_FILES = ["lady_bug", "poivron", "zephyr", "flower", "tomatos", "gm_cup", "astray", "fruits"]


@pytest.mark.slow
@pytest.mark.parametrize("name", REAL_FILES)
def test_an_anchor_move_on_a_real_file_makes_no_new_factorisation(shared_data, name):
    path = shared_data / "orzan_xml" / "berkbavas" / f"{name}.xml"
    if not path.exists():
        pytest.skip(f"{path} is absent")
    session = Session.open(path)
    (live,) = session.live.fields.values()
    before = live.factorisations
    document = session.document
    inside = [each for each in document.curves if len(each.control_points) > 4
              and 0 < each.control_points[3][0] < document.width and 0 < each.control_points[3][1] < document.height]
    curve = max(inside, key=lambda each: len(each.control_points))
    session.apply(edits.move_control_point(document, curve.id, 3, tuple(curve.control_points[3] + (1.5, 1.0))),
                  "Move Anchor")
    assert session.last_update.kind == "geometry"
    assert live.factorisations == before
