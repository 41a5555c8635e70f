"""The tools in the editor window, driven by real mouse and key events (``qtbot``) under Xvfb.

Each gesture gives the expected document and exactly one undo step; Esc cancels a drag; undo then
redo restores the same document; keys reach the active tool before the menu shortcuts.
"""

from __future__ import annotations

import numpy as np
import pytest
from selections import by_index
from shapes import BLUE, RED, line_document, straight_chain

pytest.importorskip("pytestqt", reason="pytest-qt is in the [test] extra")

from PySide6.QtCore import Qt  # noqa: E402

from fmr_editor.model import ColorStop  # noqa: E402

pytestmark = pytest.mark.gui

CTRL = Qt.KeyboardModifier.ControlModifier
SHIFT = Qt.KeyboardModifier.ShiftModifier


def line_s(x: float) -> float:
    """Position along the line (piece units) of the point above ``x``."""
    return (x - 16.0) / 96.0


def one_step(editor, start: int, label: str) -> None:
    history = editor.history
    assert history.index == start + 1, history.labels
    assert len(history.labels) == start + 2
    assert history.labels[-1] == label
    assert editor.window.actions["undo"].text() == f"Undo {label}"


def test_pen_draws_a_curve_as_one_step(line):
    editor = line
    editor.key(Qt.Key.Key_P)
    assert editor.window.tool_name == "pen"
    start, before = editor.history.index, editor.document
    a, b = editor.doc(30, 20), editor.doc(90, 36)
    editor.click(30, 20)
    editor.click(90, 36)
    assert editor.document is before  # nothing reaches the document before the curve is finished
    editor.key(Qt.Key.Key_Return)  # the pen's, not a menu's
    one_step(editor, start, "Draw Curve")
    assert editor.document.curves[0] == before.curves[0]
    curve = editor.document.curves[1]
    np.testing.assert_allclose(curve.control_points, straight_chain([a, b]), atol=1e-9)
    options = editor.window.options
    assert curve.left == (ColorStop(0.0, options.color),)
    assert curve.right == (ColorStop(0.0, options.secondary_color),)
    assert editor.context.selection.curves == by_index(editor.document, curves=[1]).curves
    editor.wait_idle()


def test_backspace_goes_to_the_pen_before_the_delete_shortcut(line):
    editor = line
    editor.key(Qt.Key.Key_P)
    start = editor.history.index
    for x, y in ((20, 20), (60, 30), (100, 20)):
        editor.click(x, y)
    editor.key(Qt.Key.Key_Backspace)  # removes the last anchor; the menu's Delete would delete nothing here
    editor.key(Qt.Key.Key_Enter)
    one_step(editor, start, "Draw Curve")
    np.testing.assert_allclose(editor.document.curves[1].control_points,
                               straight_chain([editor.doc(20, 20), editor.doc(60, 30)]), atol=1e-9)


def test_adding_and_dragging_a_stop_each_make_one_step(line):
    editor = line
    editor.key(Qt.Key.Key_G)
    assert editor.window.tool_name == "stops"
    zoom = editor.context.zoom
    above = 64 - 3 / zoom  # 3 screen pixels above the line: its left side
    start = editor.history.index
    editor.drag([(40, above), (70, above)])
    one_step(editor, start, "Add Stop")
    s = line_s(editor.doc(70, above)[0])
    black = editor.window.options.color
    left = editor.document.curves[0].left
    assert len(left) == 2 and left[0] == ColorStop(0.0, RED)
    assert left[1].color == black and left[1].position == pytest.approx(s, abs=1e-3)
    assert editor.document.curves[0].right == (ColorStop(0.0, BLUE),)

    marker = 64 - editor.context.marker_offset  # the stop's marker sits beside the curve, on its side
    x = 16 + 96 * left[1].position
    editor.drag([(x, marker), (100, marker)])
    one_step(editor, start + 1, "Move Stop")
    moved = editor.document.curves[0].left
    assert moved[0] == ColorStop(0.0, RED) and len(moved) == 2
    assert moved[1].color == black
    assert moved[1].position == pytest.approx(line_s(editor.doc(100, marker)[0]), abs=1e-3)
    editor.wait_idle()


def test_painting_a_stroke_is_one_step_of_evenly_spaced_dabs(line):
    editor = line
    editor.key(Qt.Key.Key_B)
    options = editor.window.options
    options.brush_radius, options.brush_spacing, options.brush_amplitude = 6.0, 10.0, 0.75
    options.brush_color, options.brush_mode = (0.2, 0.9, 0.3), "glow"
    start = editor.history.index
    editor.drag([(30, 100), (90, 100)])
    one_step(editor, start, "Glow Stroke")
    (x0, y0), (x1, y1) = editor.doc(30, 100), editor.doc(90, 100)
    points = editor.document.points
    length = np.hypot(x1 - x0, y1 - y0)
    assert len(points) == 1 + int(length // 10.0)
    positions = np.array([p.position for p in points])
    np.testing.assert_allclose(positions[:, 1], y0, atol=1e-6)
    np.testing.assert_allclose(np.diff(positions[:, 0]), 10.0, atol=1e-6)
    assert positions[0, 0] == pytest.approx(x0)
    assert all(p.radius == 6.0 and p.amplitude == 0.75 and p.color == (0.2, 0.9, 0.3) for p in points)
    assert editor.document.curves == line_document().curves
    editor.wait_idle()


def test_moving_a_control_point_is_one_step_and_undo_redo_restore_it(line):
    editor = line
    editor.key(Qt.Key.Key_V)
    start, before = editor.history.index, editor.document
    editor.click(64, 64)  # selects the curve: no step
    assert (editor.context.selection.curves == by_index(editor.document, curves=[0]).curves
            and editor.history.index == start)
    editor.drag([(16, 64), (24, 90)])  # its first anchor, shown now
    one_step(editor, start, "Move Anchor")
    (x0, y0), (x1, y1) = editor.doc(16, 64), editor.doc(24, 90)
    expected = before.curves[0].control_points.copy()
    expected[:2] += (x1 - x0, y1 - y0)  # the anchor carries its handle
    np.testing.assert_allclose(editor.document.curves[0].control_points, expected, atol=1e-9)
    after = editor.document
    editor.wait_idle()
    shown = editor.canvas.grab_image()

    editor.key(Qt.Key.Key_Z, CTRL)
    assert editor.document is before and editor.window.actions["redo"].text() == "Redo Move Anchor"
    editor.wait_idle()
    editor.key(Qt.Key.Key_Z, CTRL | SHIFT)
    assert editor.document is after
    editor.key(Qt.Key.Key_Z, CTRL)
    editor.key(Qt.Key.Key_Y, CTRL)
    assert editor.document is after and editor.history.index == start + 1
    editor.wait_idle()
    assert np.abs(editor.canvas.grab_image().astype(int) - shown).max() <= 1


@pytest.mark.parametrize("tool", ["brush", "select", "stops"])
def test_escape_cancels_a_drag(line, tool):
    editor = line
    editor.window.set_tool(tool)
    start, before = editor.history.index, editor.document
    if tool == "select":
        editor.click(64, 64)
        points = [(64, 64), (80, 90)]  # moving the curve
    elif tool == "stops":
        points = [(50, 64 - 3 / editor.context.zoom), (90, 60)]  # adding a stop
    else:
        points = [(30, 30), (90, 90)]
    editor.drag(points, release=False)
    assert editor.document is not before  # the drag shows its preview
    editor.key(Qt.Key.Key_Escape)
    assert editor.document == before
    editor.release(*points[-1])
    assert editor.history.index == start and editor.document == before
    assert editor.window.actions["undo"].text() == "Undo"


def test_delete_removes_the_selected_curve_as_one_step(line):
    editor = line
    editor.key(Qt.Key.Key_V)
    start = editor.history.index
    editor.click(64, 64)
    editor.key(Qt.Key.Key_Delete)
    one_step(editor, start, "Delete Curve")
    assert editor.document.curves == ()
    editor.wait_idle()


def test_an_edit_redraws_only_the_cells_it_changed(line):
    editor = line
    editor.wait_idle()
    editor.canvas.grab_image()
    editor.key(Qt.Key.Key_B)
    editor.window.options.brush_radius, editor.window.options.brush_mode = 3.0, "glow"
    editor.window.options.brush_color = (0.9, 0.5, 0.1)
    editor.click(20, 20)  # the first points may change the lattice (a rebuild)
    editor.wait_idle()
    editor.canvas.grab_image()
    renderer = editor.canvas.renderer
    before, frames = renderer.evaluations.copy(), []
    editor.workspace.frame_ready.connect(frames.append)
    editor.click(100, 100)
    editor.wait_idle()
    assert frames[-1].document is editor.document  # the dab's frame, and any of an equal document after it
    changed = np.logical_or.reduce([frame.changed for frame in frames])
    assert {frame.kind for frame in frames} <= {"points", "none"} and "points" in {frame.kind for frame in frames}
    assert 0 < changed.sum() < changed.size / 4
    shown = editor.canvas.grab_image()
    since = renderer.evaluations - before  # however many paints the window made meanwhile
    assert since["cells"] >= 1 and since["full"] == 0 and since["shift"] == 0
    renderer.invalidate()
    assert np.abs(editor.canvas.grab_image().astype(int) - shown).max() <= 1


def test_arrow_keys_nudge_the_selection(line):
    editor = line
    editor.key(Qt.Key.Key_V)
    before = editor.document.curves[0].control_points
    editor.click(64, 64)
    start = editor.history.index
    editor.key(Qt.Key.Key_Right)
    editor.key(Qt.Key.Key_Down, SHIFT)
    assert editor.history.index == start + 2 and editor.history.labels[-2:] == ("Move Curve", "Move Curve")
    np.testing.assert_allclose(editor.document.curves[0].control_points, before + (1.0, 10.0))
    editor.key(Qt.Key.Key_Escape)  # no drag: the select tool clears the selection
    assert editor.context.selection.empty
    editor.key(Qt.Key.Key_Left)  # nothing selected: nothing moves, no step
    assert editor.history.index == start + 2


def test_a_refused_edit_says_why_and_a_bug_is_not_swallowed(line, monkeypatch):
    """The model's ``EditRefused`` is shown and changes nothing; any other error is a bug, reported as one (to
    ``sys.excepthook``, with its traceback), not as a refusal."""
    from fmr_editor.model import EditRefused, edits

    editor, window = line, line.window
    start, before = editor.history.index, editor.document
    editor.key(Qt.Key.Key_P)

    def refused(document, curve):
        raise EditRefused("the canvas is full")

    monkeypatch.setattr(edits, "add_curve", refused)
    editor.click(30, 20)
    editor.click(90, 36)
    editor.key(Qt.Key.Key_Return)
    assert window.status_label.text() == "Not done: the canvas is full"
    assert editor.history.index == start and editor.document is before

    def broken(document, curve):
        raise ValueError("operands could not be broadcast together")

    monkeypatch.setattr(edits, "add_curve", broken)
    editor.click(30, 20)
    editor.click(90, 36)
    with editor.qtbot.capture_exceptions() as caught:  # what sys.excepthook is given
        editor.key(Qt.Key.Key_Return)
    reported = [(kind, str(error)) for kind, error, _ in caught]
    assert reported == [(ValueError, "operands could not be broadcast together")]
    assert window.status_label.text().startswith("Internal error (ValueError)")
    assert editor.history.index == start and editor.document is before
