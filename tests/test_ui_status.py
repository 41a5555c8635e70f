"""The status bar's message lasts until the document moves to another step; the mask being edited stays said."""

from __future__ import annotations

import pytest

pytest.importorskip("pytestqt", reason="pytest-qt is in the [test] extra")

from PySide6.QtCore import Qt  # noqa: E402

from fmr_editor.model import DiffusionPoint, edits  # noqa: E402

pytestmark = pytest.mark.gui

MASK_KEYS = Qt.KeyboardModifier.ControlModifier | Qt.KeyboardModifier.ShiftModifier


def recolour(editor, value: float) -> None:
    editor.history.apply(edits.set_stop_color(editor.document, editor.document.curves[0].id, "left", 0,
                                              (value, 0.5, 0.5)), "Change Stop Colour")


def test_a_message_lasts_until_the_document_moves_to_another_step(line):
    editor = line
    status = editor.window.status_label
    editor.window.say("Not done: the layer is locked")
    editor.history.mark_saved()  # the saved mark alone: the same step
    assert status.text() == "Not done: the layer is locked"
    recolour(editor, 0.1)  # the next edit
    assert status.text() == ""
    editor.window.say("Exported line.png")
    editor.history.undo()
    assert status.text() == ""
    editor.wait_idle()


def test_editing_a_mask_stays_said_through_the_edits_made_in_it(line):
    editor = line
    window, status = editor.window, editor.window.status_label
    window.actions["add_mask"].trigger()
    editor.key(Qt.Key.Key_M, MASK_KEYS)
    assert editor.document.editing_mask and status.text().startswith("Editing the mask of")
    said = status.text()
    window.say("Not done: something")
    dab = DiffusionPoint((40.0, 40.0), 10.0, (0.0, 0.0, 0.0), -0.5)
    editor.history.apply(edits.add_points(editor.document, [dab]), "Paint Mask")  # an edit of the mask
    assert editor.document.layer.mask.points and status.text() == said  # the standing message came back
    editor.key(Qt.Key.Key_M, MASK_KEYS)
    assert not editor.document.editing_mask and status.text() == ""
    editor.wait_idle()


def test_another_tab_shown_says_nothing_of_the_one_before(line):
    editor = line
    window = editor.window
    editor.drag([(30, 30), (40, 35)])  # the pointer over the canvas: its position shown
    assert window.position_label.text()
    window.say("Not done: the layer is locked")
    first = editor.workspace
    window.new_document((100, 100))
    editor.qtbot.waitUntil(lambda: window.job is None and editor.workspace is not first, timeout=30_000)
    assert window.position_label.text() == "" and window.status_label.text() == ""
    editor.wait_idle()


def test_a_clones_placement_said_gives_way_when_the_placement_is_dropped(line):
    editor = line
    window = editor.window
    editor.key(Qt.Key.Key_L)  # the lasso, round the middle of the canvas
    for corner in ((30.0, 30.0), (90.0, 30.0), (90.0, 90.0), (30.0, 90.0), (30.0, 30.0)):
        editor.click(*corner)
    editor.key(Qt.Key.Key_C, Qt.KeyboardModifier.ControlModifier)
    editor.key(Qt.Key.Key_V, MASK_KEYS)  # Ctrl+Shift+V: paste seamless, placed with handles
    assert editor.history.in_transaction and window.status_label.text().startswith("Place the clone")
    editor.key(Qt.Key.Key_Escape)  # dropped: no step was made, yet the placement is over
    assert not editor.history.in_transaction and window.status_label.text() == ""
    editor.wait_idle()


def test_a_refusal_in_the_middle_of_a_drag_stays_said_once_the_drag_is_undone(line, monkeypatch):
    """The drag's gesture is cancelled, then why is said: ending the gesture does not take the reason back."""
    from fmr_editor.model import EditRefused

    editor = line
    window = editor.window
    tool = window.tool
    moved = type(tool).move

    def refusing(self, event):
        moved(self, event)
        if editor.history.in_transaction:
            raise EditRefused("the curve cannot go there")

    monkeypatch.setattr(type(tool), "move", refusing)
    editor.drag([(64.0, 64.0), (70.0, 80.0)], release=False)  # on the line: a move of the curve, refused
    assert not editor.history.in_transaction and editor.history.index == 0
    assert window.status_label.text() == "Not done: the curve cannot go there"
    editor.release(70.0, 80.0)
    editor.wait_idle()
