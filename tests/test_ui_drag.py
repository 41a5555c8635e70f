"""A geometry drag on a real file feels live: image frames keep coming while the anchor moves, and the
exact image follows the release (issue 11).  The 20 fps target itself is measured by
``bench/bench_edits.py --session``; the floor here is one a loaded CI machine keeps."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest
from canvas_oracle import mismatches

pytest.importorskip("pytestqt", reason="pytest-qt is in the [test] extra")

from PySide6.QtCore import Qt  # noqa: E402

from fmr_editor.engine import LiveStack, rasterise  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "bench"))
from bench_edits import edited_curve  # noqa: E402

pytestmark = pytest.mark.gui

#: Events of the drag: one every 16 ms for a second.
EVENTS, INTERVAL_MS = 62, 16
#: Image frames the canvas must show during that second.
MIN_FRAMES = 15


def test_dragging_an_anchor_shows_frames_and_ends_on_the_exact_image(editor, shared_data):
    path = shared_data / "orzan_xml" / "berkbavas" / "lady_bug.xml"
    if not path.exists():
        pytest.skip(f"{path} is absent")
    editor.open(path)
    editor.key(Qt.Key.Key_V)
    document = editor.document
    k = edited_curve(document)
    x, y = document.curves[k].control_points[3]
    editor.click(x, y)  # selects the curve: its anchors can be taken
    editor.wait_idle()
    start = editor.history.index
    canvas, qtbot = editor.canvas, editor.qtbot
    editor.press(x, y)
    frames = canvas.frames_shown
    previews = 0
    for step in range(1, EVENTS + 1):
        editor.move(x + 12 * np.sin(step / 10), y + 0.3 * step)
        qtbot.wait(INTERVAL_MS)
        previews += not editor.workspace.frame.exact
    shown_during = canvas.frames_shown - frames
    editor.release(x + 12 * np.sin(EVENTS / 10), y + 0.3 * EVENTS)
    assert editor.history.index == start + 1 and editor.history.labels[-1].startswith("Move")
    rows = editor.window.history_panel.list
    assert rows.count() == start + 2 and rows.item(start + 1).text() == editor.history.labels[-1]  # listed at once
    assert previews > 0  # the frames were the approximate previews
    assert shown_during >= MIN_FRAMES, f"{shown_during} image frames in {EVENTS * INTERVAL_MS} ms"
    editor.wait_idle()
    assert editor.workspace.frame.exact and not editor.window.shading_label.isVisible()
    final = editor.document
    assert not np.array_equal(final.curves[k].control_points, document.curves[k].control_points)
    off = mismatches(canvas.grab_image(), editor.fresh_picture(), canvas.device_view(), 2.0)
    assert off["inside"] == 0 and off["outside"] == 0, off


def test_a_held_drag_shows_the_cpu_picture_of_its_frame_near_the_exact_one(editor, shared_data):
    """Pressing on lady_bug's highlight and moving it 6 px with the Select tool, the button held: the canvas shows
    what the CPU draws of the frame on screen, and that frame is within the preview's bound of the exact picture
    (or, if the engine says a preview would not be, the picture from before); after the release, a fresh build."""
    path = shared_data / "orzan_xml" / "berkbavas" / "lady_bug.xml"
    if not path.exists():
        pytest.skip(f"{path} is absent")
    editor.open(path)
    editor.key(Qt.Key.Key_V)
    before = editor.workspace.frame.picture
    curve = editor.document.curves[6]  # the highlight on the ladybird's back, close to other curves
    p0, p1, p2, p3 = curve.control_points[:4]
    x, y = 0.125 * p0 + 0.375 * p1 + 0.375 * p2 + 0.125 * p3  # on the curve: its first piece at t = 1/2
    canvas, workspace = editor.canvas, editor.workspace
    editor.press(x, y)
    for step in range(1, 7):
        editor.move(x + step, y + 0.5 * step)
        editor.qtbot.wait(20)
    assert workspace.history.in_transaction
    document = workspace.history.document
    assert not np.array_equal(document.curves[6].control_points, curve.control_points)  # it moves
    editor.qtbot.waitUntil(lambda: workspace.frame.document is document, timeout=60_000)
    frame = workspace.frame
    assert not frame.exact and editor.window.shading_label.isVisible()
    off = mismatches(canvas.grab_image(), frame.picture, canvas.device_view(), 2.0)
    assert off["inside"] == 0 and off["outside"] == 0, off
    shown = np.clip(rasterise(frame.picture, samples=1), 0, 1)
    if frame.stale:
        np.testing.assert_array_equal(shown, np.clip(rasterise(before, samples=1), 0, 1))
    else:
        exact = LiveStack(document, blur=editor.window.show_blur).composite
        difference = 255 * np.abs(shown - np.clip(rasterise(exact, samples=1), 0, 1)).max(axis=2)
        assert difference.mean() <= 1.0 and np.percentile(difference, 99) <= 4.0
    editor.release(x + 6, y + 3)
    editor.wait_idle()
    assert not editor.window.shading_label.isVisible()
    off = mismatches(canvas.grab_image(), editor.fresh_picture(), canvas.device_view(), 2.0)
    assert off["inside"] == 0 and off["outside"] == 0, off
