"""Seamless cloning in the editor: two documents in tabs, a lasso selection, Copy, Paste Seamless with handles.

Driven like a user through real Qt events under Xvfb.  After every placement the canvas must show the
composite of a fresh build of the document (the clone blended anew, not a plain paste); each action is
one named step of its own document's history.
"""

from __future__ import annotations

import numpy as np
import pytest
from canvas_oracle import mismatches
from shapes import scattered_document

pytest.importorskip("pytestqt", reason="pytest-qt is in the [test] extra")

from PySide6.QtCore import Qt  # noqa: E402
from PySide6.QtWidgets import QMessageBox  # noqa: E402

from fmr_editor.io import load_fmr, save_fmr  # noqa: E402
from fmr_editor.model import edits, layer_edits  # noqa: E402
from fmr_editor.tools.transform import Handles  # noqa: E402

pytestmark = pytest.mark.gui

SIZE = 128
CORNERS = [(30.0, 36.0), (90.0, 36.0), (100.0, 70.0), (60.0, 95.0), (25.0, 70.0)]
CTRL = Qt.KeyboardModifier.ControlModifier
SHIFT = Qt.KeyboardModifier.ShiftModifier


def shows_the_composite(editor) -> None:
    """The canvas shows, to one 8-bit level, the composite of a fresh build of the current document."""
    editor.wait_idle()
    off = mismatches(editor.canvas.grab_image(), editor.fresh_picture(), editor.canvas.device_view(),
                     1.0)
    assert off["inside"] == 0 and off["outside"] == 0, off


@pytest.fixture
def two_documents(editor, tmp_path):
    """The editor with a source and a target document open in two tabs (the target active)."""
    paths = []
    for name, seed in (("source", 3), ("target", 8)):
        path = tmp_path / f"{name}.fmr"
        save_fmr(path, scattered_document(SIZE, seed=seed))
        editor.open(path)
        paths.append(path)
    assert editor.window.tabs.count() == 2 and editor.workspace.path == paths[1]
    return editor, paths


def lasso_corners(editor, corners) -> None:
    """Click the corners with the lasso, then the first one again to close the selection."""
    editor.key(Qt.Key.Key_L)
    for corner in corners:
        editor.click(*corner)
    editor.click(*corners[0])


def handles(editor) -> Handles:
    return Handles.of(editor.document.layer.clone, editor.context.zoom)


def test_copy_in_one_tab_paste_seamless_in_another_place_it_and_undo(two_documents, qtbot):
    editor, (source_path, target_path) = two_documents
    window = editor.window
    target_document = editor.document
    editor.key(Qt.Key.Key_Tab, CTRL)  # the source's tab
    assert editor.workspace.path == source_path and editor.history.index == 0
    lasso_corners(editor, CORNERS)
    region = editor.context.region
    assert region is not None and len(region) == len(CORNERS)
    np.testing.assert_allclose(sorted(map(tuple, region)), sorted(editor.doc(*c) for c in CORNERS), atol=1e-9)
    editor.key(Qt.Key.Key_C, CTRL)
    assert window.clip_commands.clipboard is not None and editor.history.index == 0  # copying is no step
    np.testing.assert_array_equal(window.clip_commands.clipboard.region, region)

    window.tabs.setCurrentIndex(1)
    assert editor.workspace.path == target_path and editor.document is target_document
    editor.key(Qt.Key.Key_V, CTRL | SHIFT)
    assert window.tool_name == "clone" and editor.history.in_transaction
    document = editor.document
    assert len(document.layers) == 2 and document.active == 1 and document.layer.clone is not None
    shows_the_composite(editor)  # the clone at once, blended

    box = handles(editor)
    middle = tuple(box.centre)
    editor.drag([middle, (middle[0] + 12, middle[1] + 6)])
    moved = editor.document.layer.clone.similarity
    np.testing.assert_allclose(moved.offset, np.subtract(editor.doc(middle[0] + 12, middle[1] + 6),
                                                          editor.doc(*middle)), atol=1e-9)
    shows_the_composite(editor)

    box = handles(editor)
    corner = tuple(box.box[2])
    outward = box.box[2] + 0.25 * (box.box[2] - box.centre)
    editor.drag([corner, tuple(outward)])
    assert editor.document.layer.clone.similarity.scale == pytest.approx(1.25, abs=0.03)
    box = handles(editor)
    turned = box.centre + np.array([[0.0, -1.0], [1.0, 0.0]]) @ (box.turn - box.centre)  # a quarter turn, clockwise
    editor.drag([tuple(box.turn), tuple(turned)])
    assert editor.document.layer.clone.similarity.degrees == pytest.approx(90.0, abs=2.0)
    shows_the_composite(editor)

    editor.key(Qt.Key.Key_Return)
    assert not editor.history.in_transaction and editor.history.labels == ("", "Paste Seamless")
    pasted = editor.document
    window.undo()
    assert editor.document == target_document
    window.redo()
    assert editor.document == pasted
    shows_the_composite(editor)
    window.tabs.setCurrentIndex(0)
    assert editor.history.labels == ("",) and not editor.history.modified  # the source is untouched


def test_a_clone_is_chosen_and_moved_again_later_and_esc_drops_the_change(two_documents, qtbot):
    editor, _ = two_documents
    window = editor.window
    window.tabs.setCurrentIndex(0)
    lasso_corners(editor, CORNERS)
    window.clip_commands.copy()
    window.tabs.setCurrentIndex(1)
    window.clip_commands.paste_seamless()
    editor.key(Qt.Key.Key_Return)
    pasted = editor.document
    window.layers_panel.list.setCurrentRow(1)  # the bottom layer (the list shows the top first)
    assert editor.document.active == 0
    editor.click(*handles_of(pasted).centre)  # a click on the clone chooses its layer again
    assert editor.document.active == 1 and editor.history.labels == ("", "Paste Seamless")

    centre = tuple(handles(editor).centre)
    editor.drag([centre, (centre[0] - 15, centre[1])])
    assert editor.history.in_transaction
    editor.key(Qt.Key.Key_Escape)
    assert editor.document == pasted and not editor.history.in_transaction

    editor.drag([centre, (centre[0] - 15, centre[1])])
    editor.key(Qt.Key.Key_Right, SHIFT)  # and ten pixels back by the arrows
    editor.key(Qt.Key.Key_Return)
    assert editor.history.labels[-1] == "Transform Clone" and editor.history.index == 2
    dx, dy = np.subtract(editor.document.layer.clone.similarity.offset, pasted.layer.clone.similarity.offset)
    assert dx == pytest.approx(-5.0, abs=0.5) and dy == pytest.approx(0.0, abs=1e-9)
    shows_the_composite(editor)

    editor.key(Qt.Key.Key_P)  # the pen on a clone layer: refused with a message, no step
    editor.click(20, 20)
    editor.click(60, 30)
    editor.key(Qt.Key.Key_Return)
    assert editor.history.index == 2 and "clone layer" in window.status_label.text()

    bottom = editor.document.layers[0]  # an edit below the clone: it blends in anew
    recoloured = edits.set_stop_color(layer_edits.select_layer(editor.document, 0), bottom.curves[0].id, "left", 0,
                                      (0.1, 0.9, 0.2))
    editor.history.apply(recoloured, "Change Stop Colour")
    shows_the_composite(editor)


def handles_of(document) -> Handles:
    return Handles.of(document.layer.clone, 1.0)


def test_plain_paste_saving_and_closing_ask_per_document(two_documents, tmp_path, qtbot):
    editor, (_, target_path) = two_documents
    window = editor.window
    window.tabs.setCurrentIndex(0)
    editor.key(Qt.Key.Key_L)
    x, y = editor.canvas.to_document(4, 4)  # in the window's margin, off the canvas
    assert x < 0 and y < 0
    editor.drag([(x, y), (70.0, y), (70.0, 60.0), (x, 60.0)])  # freehand, over the canvas edge
    region = editor.context.region
    assert region.min() == 0.0 and region.max() <= 70.5  # clipped to the canvas
    window.clip_commands.copy()
    window.tabs.setCurrentIndex(1)
    before = editor.document
    editor.key(Qt.Key.Key_V, CTRL)  # into the active layer, as they are
    assert editor.history.labels[-1] == "Paste" and not editor.history.in_transaction
    pasted = editor.document
    assert len(pasted.layers) == 1 and len(pasted.curves) > len(before.curves)
    assert pasted.curves[:len(before.curves)] == before.curves
    assert editor.context.selection.curves == {c.id for c in pasted.curves[len(before.curves):]}  # to move on
    shows_the_composite(editor)

    window.clip_commands.paste_seamless()
    editor.key(Qt.Key.Key_Return)
    document = editor.document
    editor.answers["save"] = tmp_path / "cloned.fmr"
    window.save_as()
    qtbot.waitUntil(lambda: window.job is None and not editor.history.modified, timeout=60_000)
    assert window.tabs.tabText(1) == "cloned.fmr"
    assert load_fmr(tmp_path / "cloned.fmr").document == document

    window.tabs.setCurrentIndex(0)
    window.deselect()
    assert editor.context.region is None
    editor.history.apply(edits.remove_curves(editor.document, [editor.document.curves[0].id]), "Delete")
    assert window.tabs.tabText(0) == "source.fmr*"
    editor.answers["question"] = QMessageBox.StandardButton.Cancel
    window.close()
    assert window.isVisible() and len(editor.questions) == 1 and "source.fmr" in editor.questions[0][1]
    editor.answers["question"] = QMessageBox.StandardButton.Discard
    window.close()
    qtbot.waitUntil(lambda: not window.isVisible(), timeout=30_000)
    assert window.workspaces == [] and window.workspace is None


def test_a_paste_session_gives_way_to_undo_the_layers_panel_and_other_tabs(two_documents, qtbot):
    editor, (source_path, target_path) = two_documents
    window = editor.window
    window.tabs.setCurrentIndex(0)
    lasso_corners(editor, CORNERS)
    window.clip_commands.copy()
    window.tabs.setCurrentIndex(1)
    target = editor.document
    window.layers_panel.list.setFocus()
    window.actions["paste_seamless"].trigger()
    assert editor.canvas.hasFocus()  # so that Return and Esc reach the handles
    assert window.actions["undo"].isEnabled()
    window.actions["undo"].trigger()  # Ctrl+Z drops the paste, as Esc does
    assert editor.document == target and not editor.history.in_transaction and window.tool_name == "clone"

    window.clip_commands.paste_seamless()
    window.layers_panel.list.setCurrentRow(1)  # the bottom layer: the placement is kept, then the layer chosen
    assert editor.history.labels == ("", "Paste Seamless") and editor.document.active == 0
    window.layers_panel.list.setCurrentRow(0)
    assert editor.document.active == 1

    editor.key(Qt.Key.Key_B)  # a glow dab on a clone layer: refused with a message, no step
    window.options.brush_mode = "glow"
    editor.click(60, 60)
    assert editor.history.index == 1 and "clone layer" in window.status_label.text()
    assert not window.actions["add_mask"].isEnabled()  # a clone layer's mask is its region

    window.tabs.setCurrentIndex(0)
    editor.answers["question"] = QMessageBox.StandardButton.Discard
    window.close_document(window.workspaces[1])  # a tab behind with changes: asked about, closed
    assert len(editor.questions) == 1 and "target.fmr" in editor.questions[0][1]
    assert [w.path for w in window.workspaces] == [source_path] and editor.workspace.path == source_path
