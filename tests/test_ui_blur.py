"""Blur in the editor window under Xvfb: View > Show Blur and the Colour Stops panel's blur bar (issue 29)."""

from __future__ import annotations

import numpy as np
import pytest
from canvas_oracle import mismatches
from selections import by_index
from shapes import circle_points

pytest.importorskip("pytestqt", reason="pytest-qt is in the [test] extra")

from PySide6.QtCore import QPoint, Qt  # noqa: E402

from fmr_editor.engine import LiveStack  # noqa: E402
from fmr_editor.io import save_fmr  # noqa: E402
from fmr_editor.model import BlurStop, ColorStop, DiffusionCurve, Document  # noqa: E402
from fmr_editor.ui.gradient_bar import BAR  # noqa: E402

pytestmark = pytest.mark.gui

ORANGE, BLUE = (1.0, 0.5, 0.1), (0.1, 0.2, 0.8)


@pytest.fixture
def soft_disc(editor, tmp_path):
    """A 128 x 128 canvas, an orange disc on blue whose edge goes from sharp to 5 px of blur around it."""
    points = circle_points(64, 64, 36)
    curve = DiffusionCurve(points, left=(ColorStop(0.0, ORANGE),), right=(ColorStop(0.0, BLUE),),
                           blur=(BlurStop(0.0, 0.0), BlurStop((len(points) - 1) / 6, 5.0)))
    path = tmp_path / "disc.fmr"
    save_fmr(path, Document(128, 128, (curve,)))
    editor.open(path)
    return editor


def shows(editor, picture) -> None:
    editor.wait_idle()
    off = mismatches(editor.canvas.grab_image(), picture, editor.canvas.device_view(), 1.0)
    assert off["inside"] == 0 and off["outside"] == 0, off


def test_show_blur_softens_the_canvas_and_is_remembered(soft_disc, qtbot):
    editor = soft_disc
    window = editor.window
    assert window.show_blur and window.actions["show_blur"].isChecked()  # on by default
    assert editor.workspace.frame.picture.layers[0].blur is not None  # solved with the document
    shows(editor, editor.fresh_picture())
    blurred = editor.canvas.grab_image()
    sharp_picture = LiveStack(editor.document).composite

    editor.key(Qt.Key.Key_B, Qt.KeyboardModifier.ControlModifier | Qt.KeyboardModifier.ShiftModifier)
    assert not window.show_blur and window.settings.value("view/show_blur", type=bool) is False
    qtbot.waitUntil(lambda: editor.workspace.frame.picture.layers[0].blur is None, timeout=30_000)
    shows(editor, sharp_picture)
    assert not any(role == "blur" for _, role in editor.canvas.renderer.renderers)
    difference = np.abs(editor.canvas.grab_image().astype(int) - blurred).max(axis=2)
    assert (difference > 20).sum() > 200  # the edge: sharp now

    window.actions["show_blur"].trigger()
    qtbot.waitUntil(lambda: editor.workspace.frame.picture.layers[0].blur is not None, timeout=30_000)
    shows(editor, editor.fresh_picture())
    assert np.array_equal(editor.canvas.grab_image(), blurred)


def test_the_blur_bar_adds_sets_and_removes_blur_stops(soft_disc, qtbot):
    editor = soft_disc
    panel = editor.window.stops_panel
    editor.context.selection = by_index(editor.document, curves=[0])
    panel.refresh()
    bar = panel.bars["blur"]
    assert [stop.position for stop in bar.stops] == [stop.position for stop in editor.document.curves[0].blur]
    assert bar.stops[0].color == (1.0, 1.0, 1.0) and bar.stops[1].color[0] < 1.0  # white is sharp
    start = editor.history.index
    length = editor.document.curves[0].piece_count
    qtbot.mouseDClick(bar, Qt.MouseButton.LeftButton, pos=QPoint(round(bar.x_of(length * 0.75)), BAR // 2))
    assert editor.history.labels[-1] == "Add Stop" and editor.history.index == start + 1
    blur = editor.document.curves[0].blur
    assert len(blur) == 3 and blur[2].blur == 5.0  # beyond the last stop: its blur
    assert editor.context.selection.stops == by_index(editor.document, stops=[(0, "blur", 2)]).stops
    assert panel.blur_value.isEnabled() and panel.blur_value.value() == 5.0

    panel.blur_value.setValue(1.5)
    panel.blur_value.setValue(2.0)  # a second change of the same stop: the same step
    assert editor.history.labels[-1] == "Change Blur" and editor.history.index == start + 2
    assert editor.document.curves[0].blur[2].blur == 2.0
    shows(editor, editor.fresh_picture())

    bar.setFocus()
    qtbot.keyClick(bar, Qt.Key.Key_Delete)
    assert editor.history.labels[-1] == "Delete Stop" and len(editor.document.curves[0].blur) == 2
    editor.history.undo()
    assert editor.document.curves[0].blur[2].blur == 2.0
    editor.wait_idle()
