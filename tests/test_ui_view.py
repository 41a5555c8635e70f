"""The view's commands in the editor window: Actual Size (1), Fit Canvas (Ctrl+0 and 5), the zoom percentage."""

from __future__ import annotations

import numpy as np
import pytest

pytest.importorskip("pytestqt", reason="pytest-qt is in the [test] extra")

from PySide6.QtCore import Qt  # noqa: E402

from fmr_editor.engine import build, rasterise  # noqa: E402

pytestmark = pytest.mark.gui

#: 8-bit levels a shown pixel may differ from the CPU's value (rounding, and the shader's float32 near field).
LEVELS = 2.0


def test_actual_size_shows_one_document_pixel_per_screen_pixel_as_the_cpu_raster(line):
    editor, window = line, line.window
    editor.key(Qt.Key.Key_1)
    canvas = editor.canvas
    view = canvas.device_view()
    assert view.scale == 1.0 and canvas.zoom_factor == 1.0
    assert view.offset_x == round(view.offset_x) and view.offset_y == round(view.offset_y)
    assert window.zoom_button.text() == "100%"
    editor.wait_idle()
    shown = canvas.grab_image().astype(np.float64)
    document = editor.document
    x, y = int(view.offset_x), int(view.offset_y)
    assert 0 <= x and 0 <= y and x + document.width <= view.width and y + document.height <= view.height
    expected = np.clip(rasterise(build(document), samples=1), 0, 1) * 255  # the CPU raster at 1:1
    inside = shown[y : y + document.height, x : x + document.width]
    assert np.abs(inside - expected).max() <= LEVELS


def test_fit_follows_ctrl_0_and_5_and_the_percentage_follows_the_view(line):
    editor, window = line, line.window
    canvas, button = editor.canvas, window.zoom_button
    editor.key(Qt.Key.Key_1)
    editor.key(Qt.Key.Key_Plus, Qt.KeyboardModifier.ControlModifier)
    assert canvas.zoom_factor == pytest.approx(1.25) and button.text() == "125%" and not canvas.fitted
    for key, modifiers in ((Qt.Key.Key_5, None), (Qt.Key.Key_0, Qt.KeyboardModifier.ControlModifier)):
        editor.key(Qt.Key.Key_1)
        editor.key(key, modifiers)
        assert canvas.fitted and button.text() == f"{canvas.zoom_factor * 100:.0f}%" != "100%"
