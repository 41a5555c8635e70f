"""The editor's panels under Xvfb: colour stops (gradient bars), history, tool options; the eyedropper."""

from __future__ import annotations

import numpy as np
import pytest
from selections import by_index
from shapes import straight_chain

pytest.importorskip("pytestqt", reason="pytest-qt is in the [test] extra")

from PySide6.QtCore import QPoint, Qt  # noqa: E402
from PySide6.QtGui import QColor  # noqa: E402

from fmr_editor.io import save_fmr  # noqa: E402
from fmr_editor.model import ColorStop, DiffusionCurve, Document, edits  # noqa: E402
from fmr_editor.tools import Selection  # noqa: E402
from fmr_editor.ui.gradient_bar import BAR, HANDLE  # noqa: E402

pytestmark = pytest.mark.gui

RED, GREEN, BLUE = (1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0)
HANDLE_Y = BAR + HANDLE // 2 + 1


@pytest.fixture
def two_stops(editor, tmp_path):
    """A 128x128 canvas, one straight two-piece curve from (16, 64) to (112, 64) with red and green stops at
    its ends on the left, blue on the right; the curve selected."""
    curve = DiffusionCurve(straight_chain([(16.0, 64.0), (64.0, 64.0), (112.0, 64.0)]),
                           left=(ColorStop(0.0, RED), ColorStop(2.0, GREEN)), right=(ColorStop(0.0, BLUE),))
    path = tmp_path / "stops.fmr"
    save_fmr(path, Document(128, 128, (curve,)))
    editor.open(path)
    editor.context.selection = by_index(editor.document, curves=[0])
    editor.window.stops_panel.refresh()
    return editor


def handle(bar, s: float) -> QPoint:
    return QPoint(round(bar.x_of(s)), HANDLE_Y)


def test_stops_panel_shows_the_selected_curve(two_stops):
    panel = two_stops.window.stops_panel
    assert panel.curve == two_stops.document.curves[0].id
    assert panel.bars["left"].stops == (ColorStop(0.0, RED), ColorStop(2.0, GREEN))
    assert panel.bars["right"].stops == (ColorStop(0.0, BLUE),)
    two_stops.context.selection = Selection()
    panel.refresh()
    assert panel.curve is None and not panel.bars["left"].isEnabled()


def test_dragging_a_handle_moves_the_stop_as_one_step(two_stops, qtbot):
    editor = two_stops
    bar = editor.window.stops_panel.bars["left"]
    start = editor.history.index
    target = QPoint(round(bar.x_of(0.5)), HANDLE_Y)
    qtbot.mousePress(bar, Qt.MouseButton.LeftButton, pos=handle(bar, 2.0))
    for x in np.linspace(handle(bar, 2.0).x(), target.x(), 6)[1:]:
        qtbot.mouseMove(bar, QPoint(round(x), HANDLE_Y))
    qtbot.mouseRelease(bar, Qt.MouseButton.LeftButton, pos=target)
    assert editor.history.index == start + 1 and editor.history.labels[-1] == "Move Stop"
    s = bar.s_of(target.x())
    assert editor.document.curves[0].left == (ColorStop(0.0, RED), ColorStop(s, GREEN))
    assert editor.context.selection.stops == by_index(editor.document, stops=[(0, "left", 1)]).stops
    # dragged past the other stop, it is sorted before it and stays selected
    qtbot.mousePress(bar, Qt.MouseButton.LeftButton, pos=target)
    qtbot.mouseMove(bar, QPoint(target.x() - 10, HANDLE_Y))
    qtbot.mouseMove(bar, QPoint(0, HANDLE_Y))
    qtbot.mouseRelease(bar, Qt.MouseButton.LeftButton, pos=QPoint(0, HANDLE_Y))
    assert editor.history.index == start + 2
    assert editor.document.curves[0].left == (ColorStop(0.0, RED), ColorStop(0.0, GREEN))
    assert editor.context.selection.stops == by_index(editor.document, stops=[(0, "left", 1)]).stops
    editor.wait_idle()


def test_the_colour_dialog_is_live_and_one_step_and_cancel_undoes_it(two_stops, qtbot):
    editor = two_stops
    panel = editor.window.stops_panel
    bar = panel.bars["left"]
    start, before = editor.history.index, editor.document
    qtbot.mouseDClick(bar, Qt.MouseButton.LeftButton, pos=handle(bar, 2.0))
    dialog = panel.dialog
    assert dialog is not None and dialog.isVisible()
    dialog.setCurrentColor(QColor(255, 128, 0))
    assert editor.document.curves[0].left[1].color == pytest.approx((1.0, 128 / 255, 0.0))
    dialog.setCurrentColor(QColor(0, 0, 255))
    assert editor.history.index == start + 1 and editor.history.labels[-1] == "Change Stop Colour"
    dialog.accept()
    assert editor.document.curves[0].left[1].color == pytest.approx(BLUE)
    assert editor.history.index == start + 1
    assert editor.document.curves[0].left[0] == ColorStop(0.0, RED)

    after = editor.document
    panel.color_buttons["left"].click()  # the selected stop's colour button
    dialog = panel.dialog
    dialog.setCurrentColor(QColor(10, 20, 30))
    assert editor.history.index == start + 2
    dialog.reject()
    assert editor.history.index == start + 1 and editor.document is after
    editor.history.undo()
    assert editor.document is before
    editor.wait_idle()


def test_adding_and_removing_stops_on_the_bar(two_stops, qtbot):
    editor = two_stops
    bar = editor.window.stops_panel.bars["left"]
    start = editor.history.index
    qtbot.mouseDClick(bar, Qt.MouseButton.LeftButton, pos=QPoint(round(bar.x_of(1.0)), BAR // 2))
    assert editor.history.labels[-1] == "Add Stop" and editor.history.index == start + 1
    left = editor.document.curves[0].left
    s = bar.s_of(round(bar.x_of(1.0)))
    assert len(left) == 3 and left[1].position == pytest.approx(s)
    np.testing.assert_allclose(left[1].color, np.array(RED) * (1 - s / 2) + np.array(GREEN) * s / 2, atol=1e-12)
    assert editor.context.selection.stops == by_index(editor.document, stops=[(0, "left", 1)]).stops
    bar.setFocus()
    qtbot.keyClick(bar, Qt.Key.Key_Delete)  # the bar's, before the menu's Delete
    assert editor.history.labels[-1] == "Delete Stop" and editor.history.index == start + 2
    assert editor.document.curves[0].left == (ColorStop(0.0, RED), ColorStop(2.0, GREEN))
    assert len(editor.document.curves) == 1
    panel = editor.window.stops_panel
    assert panel.curve == editor.document.curves[0].id  # still the panel's curve, the next stop selected
    assert editor.context.selection.stops == by_index(editor.document, stops=[(0, "left", 1)]).stops
    panel.remove_buttons["left"].click()
    assert editor.document.curves[0].left == (ColorStop(0.0, RED),) and panel.curve == editor.document.curves[0].id
    assert editor.context.selection.stops == by_index(editor.document, stops=[(0, "left", 0)]).stops
    editor.wait_idle()


def test_history_panel_lists_the_steps_and_a_click_jumps(two_stops, qtbot):
    editor = two_stops
    history = editor.history
    first = editor.document
    documents = [first]
    for k, color in enumerate((GREEN, BLUE, RED)):
        history.apply(documents[-1].with_curves([DiffusionCurve(first.curves[0].control_points,
                                                                left=(ColorStop(0.0, color),))]), f"Step {k}")
        documents.append(history.document)
    view = editor.window.history_panel.list
    assert [view.item(i).text() for i in range(view.count())] == ["Open stops.fmr", "Step 0", "Step 1", "Step 2"]
    assert view.currentRow() == 3 and view.item(3).font().bold()
    qtbot.mouseClick(view.viewport(), Qt.MouseButton.LeftButton, pos=view.visualItemRect(view.item(1)).center())
    assert history.index == 1 and history.document is documents[1]
    assert view.item(1).font().bold() and not view.item(3).font().bold()
    assert editor.window.actions["redo"].text() == "Redo Step 1"
    qtbot.mouseClick(view.viewport(), Qt.MouseButton.LeftButton, pos=view.visualItemRect(view.item(3)).center())
    assert history.document is documents[3]
    editor.wait_idle()


def test_tool_options_panel_sets_the_options(two_stops, qtbot):
    editor = two_stops
    window = editor.window
    panel = window.options_panel
    panel.spins["brush_radius"].setValue(33.0)
    panel.spins["brush_spacing"].setValue(4.5)
    assert window.options.brush_radius == 33.0 and window.options.brush_spacing == 4.5
    panel.spins["stroke_right_alpha"].setValue(0.3)
    assert window.options.stroke_right_alpha == 0.3 and window.options.stroke_left_alpha == 1.0
    editor.answers["color"] = QColor(255, 0, 0)
    qtbot.mouseClick(panel.foreground, Qt.MouseButton.LeftButton)
    assert window.options.color == (1.0, 0.0, 0.0)
    editor.key(Qt.Key.Key_X)  # swap
    assert window.options.color == (1.0, 1.0, 1.0) and window.options.secondary_color == (1.0, 0.0, 0.0)
    editor.key(Qt.Key.Key_D)
    assert window.options.color == (0.0, 0.0, 0.0) and window.options.secondary_color == (1.0, 1.0, 1.0)
    for name, key in (("pen", Qt.Key.Key_P), ("brush", Qt.Key.Key_B), ("eyedropper", Qt.Key.Key_I),
                      ("stops", Qt.Key.Key_G), ("select", Qt.Key.Key_V)):
        editor.key(key)
        assert window.tool_name == name and window.actions[f"tool:{name}"].isChecked()


def test_eyedropper_picks_the_colour_shown(two_stops):
    editor = two_stops
    editor.wait_idle()
    editor.key(Qt.Key.Key_I)
    shown = editor.canvas.grab_image()
    editor.click(40, 40)
    p = editor.at(40, 40)
    ratio = editor.canvas.devicePixelRatioF()
    pixel = shown[round(p.y() * ratio), round(p.x() * ratio)] / 255
    np.testing.assert_allclose(editor.window.options.color, pixel, atol=2 / 255)
    assert editor.history.index == 0


def test_double_click_on_a_stop_in_the_canvas_opens_its_live_colour_dialog(two_stops, qtbot):
    editor = two_stops
    editor.key(Qt.Key.Key_V)
    start = editor.history.index
    marker = (16.0, 64 - editor.context.marker_offset)  # the red stop at the start, on the left (above)
    qtbot.mouseDClick(editor.canvas, Qt.MouseButton.LeftButton, pos=editor.at(*marker))
    dialog = editor.window.stops_panel.dialog
    assert dialog is not None and dialog.isVisible()  # the panel's live dialog, not a blocking one
    dialog.setCurrentColor(QColor(255, 128, 0))  # shown at once
    assert editor.document.curves[0].left[0].color == pytest.approx((1.0, 128 / 255, 0.0))
    dialog.setCurrentColor(QColor(0, 255, 255))
    dialog.accept()
    assert editor.history.index == start + 1 and editor.history.labels[-1] == "Change Stop Colour"
    assert editor.document.curves[0].left == (ColorStop(0.0, (0.0, 1.0, 1.0)), ColorStop(2.0, GREEN))
    qtbot.mouseDClick(editor.canvas, Qt.MouseButton.LeftButton, pos=editor.at(*marker))
    dialog = editor.window.stops_panel.dialog
    dialog.setCurrentColor(QColor(10, 20, 30))
    dialog.reject()  # cancelled: nothing changes
    assert editor.history.index == start + 1
    assert editor.document.curves[0].left[0].color == (0.0, 1.0, 1.0)
    editor.wait_idle()


def test_with_no_curve_the_bars_are_empty_and_with_no_stop_chosen_the_colour_button_takes_the_middle_one(
        two_stops, qtbot):
    editor = two_stops
    panel = editor.window.stops_panel
    assert panel.title.text() == "Curve 1: 2 pieces"
    curve = editor.document.curves[0]
    editor.history.apply(edits.add_stop(editor.document, curve.id, "left", ColorStop(1.4, BLUE)), "Add Stop")
    panel.refresh()
    assert panel.color_buttons["left"].isEnabled()  # no stop chosen, yet the button works
    panel.color_buttons["left"].click()  # stops at 0, 1.4 and 2 of 2 pieces: 1.4 is the nearest the middle
    assert editor.context.selection.stops == by_index(editor.document, stops=[(0, "left", 1)]).stops
    dialog = panel.dialog
    dialog.setCurrentColor(QColor(0, 255, 0))
    dialog.accept()
    assert editor.document.curves[0].left == (ColorStop(0.0, RED), ColorStop(1.4, GREEN), ColorStop(2.0, GREEN))
    assert editor.history.labels[-1] == "Change Stop Colour"

    editor.context.selection = Selection()
    panel.refresh()
    assert panel.title.text() == "Select a curve to edit its colour stops."
    assert not panel.color_buttons["left"].isEnabled()
    bar = panel.bars["left"]
    image = bar.grab().toImage()
    middle = image.pixelColor(bar.width() // 2, BAR // 2 + 1)
    assert middle == bar.palette().window().color()  # an empty bar, not a black side


def test_the_history_and_layers_panels_follow_the_document_they_show_and_only_it(editor):
    """Bound to a history, the panels show its every change by themselves (no window pushes them); bound to
    another, they no longer hear the first."""
    from fmr_editor.model import layer_edits
    from fmr_editor.model.history import History

    first, second = History(Document(64, 64)), History(Document(32, 32))
    history_panel, layers_panel = editor.window.history_panel, editor.window.layers_panel  # no document open
    history_panel.bind(first, "Open first")
    layers_panel.bind(first)
    first.apply(layer_edits.add_layer(first.document), "New Layer")
    first.apply(layer_edits.rename_layer(first.document, None, "Sky"), "Rename Layer")
    rows = [history_panel.list.item(k).text() for k in range(history_panel.list.count())]
    assert rows == ["Open first", "New Layer", "Rename Layer"] and history_panel.list.currentRow() == 2
    assert [layers_panel.list.item(k).text() for k in range(layers_panel.list.count())][0] == "Sky"
    first.undo()
    assert history_panel.list.currentRow() == 1 and layers_panel.list.count() == 2

    history_panel.bind(second, "Open second")
    layers_panel.bind(second)
    first.apply(layer_edits.add_layer(first.document), "New Layer")  # no longer shown: not heard
    assert history_panel.list.count() == 1 and layers_panel.list.count() == 1
    second.apply(layer_edits.add_layer(second.document), "New Layer")
    assert history_panel.list.count() == 2 and layers_panel.list.count() == 2


def test_a_gradient_bar_shows_the_checkerboard_through_stops_that_are_not_opaque(gl_display, qtbot):
    from fmr_editor.ui.gradient_bar import MARGIN, GradientBar

    bar = GradientBar()
    qtbot.addWidget(bar)
    bar.resize(220, 40)
    bar.set_stops((ColorStop(0.0, RED, alpha=0.0), ColorStop(0.5, RED, alpha=0.0), ColorStop(1.0, RED)), 1.0)
    image = bar.grab().toImage()
    clear = {image.pixelColor(MARGIN + 2 + dx, 4).getRgb()[:3] for dx in range(12)}
    assert clear == {(204, 204, 204), (153, 153, 153)}  # the canvas's checkerboard, unmixed at alpha 0
    opaque = {image.pixelColor(bar.width() - MARGIN - 3 - dx, 4).getRgb()[:3] for dx in range(12)}
    assert all(r > 240 and g < 30 and b < 30 for r, g, b in opaque)  # red, no checkerboard
    bar.set_stops((ColorStop(0.0, RED), ColorStop(1.0, RED)), 1.0)
    image = bar.grab().toImage()
    assert {image.pixelColor(MARGIN + 2 + dx, 4).getRgb()[:3] for dx in range(12)} == {(255, 0, 0)}


def test_return_in_a_panels_number_box_hands_the_keys_back_to_the_canvas(line, qtbot):
    """Typed, then Return: the value taken and the canvas focused, so that B chooses the brush instead of going
    into the box unseen."""
    from PySide6.QtWidgets import QApplication

    editor = line
    window = editor.window
    radius = window.options_panel.spins["brush_radius"]
    radius.setFocus()
    radius.selectAll()
    qtbot.keyClicks(radius, "35")
    qtbot.keyClick(radius, Qt.Key.Key_Return)
    assert window.options.brush_radius == 35.0 and QApplication.focusWidget() is window.canvas
    qtbot.keyClick(QApplication.focusWidget(), Qt.Key.Key_B)  # where a key press goes: the focused widget
    assert window.tool_name == "brush" and radius.value() == 35.0
    blur = window.stops_panel.blur_value  # the stops panel's box as well (enabled while a blur stop is chosen)
    blur.setEnabled(True)
    blur.setFocus()
    assert QApplication.focusWidget() is blur
    qtbot.keyClick(blur, Qt.Key.Key_Return)
    assert QApplication.focusWidget() is window.canvas
    editor.wait_idle()


def test_in_a_small_window_the_panels_scroll_instead_of_spilling_over_the_docks_below(line, qtbot):
    from PySide6.QtWidgets import QDockWidget

    window = line.window
    assert window.minimumSizeHint().height() <= 500  # the panels' rows no longer hold the window taller
    window.resize(700, 500)
    qtbot.waitUntil(lambda: window.height() <= 500)
    stops_dock = next(d for d in window.findChildren(QDockWidget) if d.objectName() == "stops")
    seen = 0
    for box in (window.stops_panel.title, window.stops_panel.bars["left"], window.stops_panel.blur_value):
        shown = box.visibleRegion().boundingRect()
        if shown.isEmpty():  # scrolled out of sight
            continue
        seen += 1
        corners = (box.mapTo(window, shown.topLeft()), box.mapTo(window, shown.bottomRight()))
        assert all(stops_dock.geometry().contains(corner) for corner in corners), (corners, stops_dock.geometry())
    assert seen  # the panel's top at least is in sight
    line.wait_idle()
