"""The scripted-editing session: edits, undo and redo through the live engine."""

from __future__ import annotations

import numpy as np
from shapes import scattered_document

from fmr_editor.engine import LiveStack, rasterise
from fmr_editor.model import DiffusionPoint, edits
from fmr_editor.session import Session


def cell_blocks(image: np.ndarray, cells: int) -> np.ndarray:
    """Largest absolute value of ``image (n, n, 3)`` in each of ``cells x cells`` blocks."""
    n = image.shape[0]
    return np.abs(image).reshape(cells, n // cells, cells, n // cells, 3).max(axis=(1, 3, 4))


def test_edit_undo_redo_give_the_rebuilt_images():
    doc = scattered_document(64, circles=3, seed=4)
    session = Session(doc)
    original = session.image()
    update = session.apply(lambda d: edits.set_stop_color(d, d.curves[1].id, "left", 0, (1.0, 0.0, 0.0)),
                           "Change Stop Colour")
    assert update.kind == "colours" and session.history.undo_label == "Change Stop Colour"
    edited = session.document
    rebuilt = rasterise(LiveStack(edited).composite)  # a fresh build's picture
    np.testing.assert_allclose(session.image(), rebuilt, atol=0.25 / 255)
    assert session.undo().kind == "restored"  # the kept state of the step before
    np.testing.assert_array_equal(session.image(), original)
    session.redo()
    np.testing.assert_allclose(session.image(), rebuilt, atol=0.25 / 255)
    assert session.apply(session.document, "Nothing") is None


def test_cells_not_reported_changed_keep_their_pixels():
    doc = scattered_document(64, circles=3, seed=4).with_points((DiffusionPoint((20.0, 20.0), 6.0, (1, 1, 1)),))
    session = Session(doc)
    cells = session.representation.lattice.cells_per_side
    size = 64 // cells * cells
    for edit in (
        lambda d: edits.add_points(d, [DiffusionPoint((50.0, 12.0), 3.0, (0.2, 0.9, 0.1)),
                                       DiffusionPoint((8.0, 50.0), 0.6, (1, 0, 0))]),
        lambda d: edits.set_stop_color(d, d.curves[0].id, "right", 0, (0.0, 0.0, 1.0)),
        lambda d: edits.move_control_point(d, d.curves[0].id, 1, tuple(d.curves[0].control_points[1] + 2.0)),
    ):
        before = session.image(size, size)
        update = session.apply(edit, "Edit")
        difference = cell_blocks(session.image(size, size) - before, cells)
        assert update.kind != "rebuild"
        assert difference[update.changed].max() > 1e-6  # something did change where it says so
        assert difference[~update.changed].max(initial=0.0) < 1e-6


def test_save_and_reopen_gives_the_same_document_and_pixels(tmp_path):
    session = Session(scattered_document(64, circles=2, seed=8))
    session.apply(lambda d: edits.add_points(d, [DiffusionPoint((30.0, 30.0), 5.0, (0.1, 0.2, 0.9))]), "Paint")
    assert session.history.modified
    path = session.save(tmp_path / "drawing.fmr")
    assert not session.history.modified
    reopened = Session.open(path)
    assert reopened.document == session.document
    assert [live.origin for live in reopened.live.fields.values()] == ["resumed"]  # no solve on opening
    np.testing.assert_array_equal(reopened.image(), session.image())
