"""Layers in the editor window, driven through the Layers panel, the Layer menu and the tools under Xvfb.

Two layers, a painted mask, a hue shift, opacity, a rename and a hidden layer, each one named step; the
canvas shows the CPU composite after each; undo all and redo all give back every document; save and
reopen give the same document and the same pixels.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from canvas_oracle import mismatches

pytest.importorskip("pytestqt", reason="pytest-qt is in the [test] extra")

from PySide6.QtCore import QModelIndex, Qt  # noqa: E402

from fmr_editor.engine import LiveStack, rasterise  # noqa: E402
from fmr_editor.io import load_fmr  # noqa: E402
from fmr_editor.io.png import to_rgb8  # noqa: E402
from fmr_editor.model.color_transform import hue_rotation  # noqa: E402

pytestmark = pytest.mark.gui


def shows_the_composite(editor) -> None:
    """The canvas shows, to one 8-bit level, the composite of a fresh build of the current document, and is
    opaque (the window composes it by its alpha: a grab of the window blended what was not)."""
    editor.wait_idle()
    shown = editor.canvas.grab_image()
    off = mismatches(shown, editor.fresh_picture(), editor.canvas.device_view(), 1.0)
    assert off["inside"] == 0 and off["outside"] == 0, off
    editor.canvas.makeCurrent()
    alpha = editor.canvas.renderer.read()[..., 3]  # what the window composes the canvas by
    editor.canvas.doneCurrent()
    assert alpha.min() == 1.0, f"{(alpha < 1).sum()} pixels of the canvas are not opaque"


def test_layers_panel_mask_hue_undo_redo_save_and_reopen(line, tmp_path, qtbot):
    editor = line
    window, panel = editor.window, editor.window.layers_panel
    steps = [editor.document]

    def step(label: str) -> None:
        editor.wait_idle()
        assert editor.history.labels[-1] == label and editor.history.index == len(steps)
        steps.append(editor.document)

    qtbot.mouseClick(panel.buttons["new_layer"], Qt.MouseButton.LeftButton)
    step("New Layer")
    assert len(editor.document.layers) == 2 and editor.document.active == 1 and panel.list.count() == 2

    window.actions["add_mask"].trigger()  # with a mask the layer is no longer empty (clear): Glow adds to it
    step("Add Mask")
    editor.key(Qt.Key.Key_B)  # Glow dabs on the new layer
    window.options.brush_color, window.options.brush_radius, window.options.brush_amplitude = (0.2, 0.9, 0.3), 14, 0.8
    window.options.brush_mode = "glow"
    editor.drag([(30, 30), (90, 40)])
    step("Glow Stroke")
    assert editor.document.layers[0].points == () and len(editor.document.layers[1].points) > 3
    editor.key(Qt.Key.Key_M, Qt.KeyboardModifier.ControlModifier | Qt.KeyboardModifier.ShiftModifier)
    assert editor.document.editing_mask and editor.history.index == len(steps) - 1  # no step
    steps[-1] = editor.document
    window.options.brush_color = (0.0, 0.0, 0.0)  # dark subtracts from the mask
    editor.drag([(40, 30), (60, 40)])
    step("Paint Mask")
    mask = editor.document.layers[1].mask
    assert mask.base == 1.0 and {p.amplitude for p in mask.points} == {-0.8}
    editor.wait_idle()
    tinted = mismatches(editor.canvas.grab_image(), editor.fresh_picture(),
                        editor.canvas.device_view(), 1.0)
    assert tinted["inside"] > 100  # while the mask is edited, what it hides is tinted red
    window.layer_commands.edit_mask()
    assert not editor.document.editing_mask
    steps[-1] = editor.document  # choosing the target changes the current step's document, adds none
    shows_the_composite(editor)

    window.layer_commands.adjust_colors()
    dialog = window.layer_commands.color_dialog
    assert not dialog.from_own.isVisible()  # nothing adjusted before: nothing to start from
    dialog.set_values(hue=120)
    dialog.accept()
    step("Colour Adjust")
    assert editor.document.layers[1].transform == hue_rotation(120)
    window.layer_commands.adjust_colors()  # again: the sliders add to the layer's adjustment ...
    dialog = window.layer_commands.color_dialog
    assert dialog.from_own.isVisible() and dialog.transform.is_identity
    dialog.set_values(hue=30)
    assert editor.history.document.layers[1].transform == hue_rotation(120).then(hue_rotation(30))
    dialog.from_own.setChecked(True)  # ... or take its place
    assert editor.history.document.layers[1].transform == hue_rotation(30)
    dialog.reject()
    assert editor.document.layers[1].transform == hue_rotation(120) and editor.history.labels[-1] == "Colour Adjust"

    panel.opacity.setValue(60)
    panel.opacity.setValue(70)  # one drag of the slider: one step
    step("Layer Opacity")
    assert editor.document.layers[1].opacity == 0.7

    panel.list.item(0).setText("glow")  # the top row, renamed as the editor would after a double click
    step("Rename Layer")
    panel.list.model().moveRow(QModelIndex(), 0, QModelIndex(), 2)  # drag the top row below the other
    qtbot.waitUntil(lambda: editor.history.labels[-1] == "Move Layer", timeout=5000)  # once the view is done
    step("Move Layer")
    assert [layer.name for layer in editor.document.layers] == ["glow", "Layer 1"] and editor.document.active == 0
    shows_the_composite(editor)

    panel.list.item(0).setCheckState(Qt.CheckState.Unchecked)  # the eye of the top row
    step("Hide Layer")
    assert not editor.document.layers[1].visible
    shows_the_composite(editor)

    for expected in reversed(steps[:-1]):
        window.undo()
        assert editor.document == expected
    shows_the_composite(editor)
    for expected in steps[1:]:
        window.redo()
        assert editor.document == expected
    shows_the_composite(editor)
    # Opening builds the points' polynomials afresh (dabs were added one by one, to within the points' tolerance),
    # so the reopened pixels are those of a fresh build of the document, shown and rendered here for comparison.
    fresh = LiveStack(editor.document).composite
    editor.canvas.set_representation(fresh, fit=False)
    shown = editor.canvas.grab_image()
    pixels = rasterise(fresh, 64, 64, samples=1)

    target = tmp_path / "layers.fmr"
    editor.answers["save"] = target
    window.save_as()
    qtbot.waitUntil(lambda: window.job is None and not editor.history.modified, timeout=30_000)
    assert load_fmr(target).document == editor.document
    window.close_document()  # else opening it shows its tab again
    assert window.workspace is None
    editor.open(target)
    assert editor.document == steps[-1] and editor.workspace.frame.kind == "build"
    reopened = rasterise(editor.workspace.frame.picture, 64, 64, samples=1)
    assert np.abs(reopened - pixels).max() < 1e-9  # the points' polynomials are summed again: rounding apart
    assert np.array_equal(to_rgb8(reopened), to_rgb8(pixels))
    assert np.array_equal(editor.canvas.grab_image(), shown)


def test_paint_mode_covers_with_a_fill_layer_instead_of_adding_up(line, qtbot):
    editor = line
    window = editor.window
    editor.key(Qt.Key.Key_B)
    window.options.brush_mode, window.options.brush_color = "paint", (0.1, 0.2, 0.9)
    window.options.brush_amplitude, window.options.brush_radius, window.options.brush_spacing = 1.0, 12.0, 4.0
    for y in (50, 54):  # two overlapping strokes: one fill layer, covering, not adding up
        editor.drag([(30, y), (100, y)])
    editor.wait_idle()
    document = editor.document
    assert [label for label in editor.history.labels[1:]] == ["Paint Stroke", "Paint Stroke"]
    assert len(document.layers) == 2 and document.active == 0 and document.layers[1].name == "Paint #1a33e6"
    colour = editor.workspace.sample(60.0, 52.0)
    np.testing.assert_allclose(colour, (0.1, 0.2, 0.9), atol=1e-3)  # covered: the brush colour, not more
    shows_the_composite(editor)


def test_a_layer_command_refused_says_why_and_one_that_breaks_is_reported_as_a_bug(line, monkeypatch):
    from fmr_editor.model import EditRefused, layer_edits

    editor, window = line, line.window
    start, before = editor.history.index, editor.document

    def refused(document):
        raise EditRefused("a document holds at most 64 layers")

    monkeypatch.setattr(layer_edits, "add_layer", refused)
    window.actions["new_layer"].trigger()
    assert window.status_label.text() == "Not done: a document holds at most 64 layers"
    assert editor.history.index == start and editor.document is before

    def broken(document):
        raise IndexError("list index out of range")

    monkeypatch.setattr(layer_edits, "add_layer", broken)
    with editor.qtbot.capture_exceptions() as caught:  # what sys.excepthook is given
        window.actions["new_layer"].trigger()
    assert [(kind, str(error)) for kind, error, _ in caught] == [(IndexError, "list index out of range")]
    assert window.status_label.text().startswith("Internal error (IndexError)")
    assert editor.history.index == start and editor.document is before and len(editor.document.layers) == 1


def test_a_closed_curve_made_clear_outside_in_the_stop_dialog_covers_only_its_inside(editor, tmp_path, qtbot):
    from shapes import circle_points, scattered_document, uniform_curve

    from fmr_editor.io import save_fmr
    from fmr_editor.model import Layer
    from fmr_editor.tools import Selection

    disc = uniform_curve(circle_points(64, 60, 30), left=0.9, right=0.9)  # grey on both sides, inside on its left
    below = scattered_document(128, seed=3)
    path = tmp_path / "disc.fmr"
    save_fmr(path, below.__class__(128, 128, layers=(below.layers[0], Layer((disc,), name="Disc")), active=1))
    editor.open(path)
    opaque = editor.document
    shows_the_composite(editor)  # the disc's layer covers everything
    panel = editor.window.stops_panel
    opened_disc = editor.document.layers[1].curves[0].id
    editor.context.selection = Selection.of(stops=[(opened_disc, "right", 0)])
    panel.refresh()
    panel.edit_color("right")
    dialog = panel.dialog
    clear = dialog.currentColor()
    clear.setAlphaF(0.0)
    dialog.setCurrentColor(clear)
    dialog.accept()
    editor.wait_idle()
    assert editor.history.labels[-1] == "Change Stop Colour"
    stop = editor.document.layers[1].curves[0].right[0]
    assert stop.alpha == 0.0 and stop.color == pytest.approx((0.9, 0.9, 0.9), abs=1 / 255)
    shows_the_composite(editor)  # the layer below shows outside the disc
    picture = LiveStack(editor.document).composite
    outside = rasterise(picture, 32, 32, samples=1)[0, 0]
    assert np.abs(outside - rasterise(LiveStack(below).composite, 32, 32, samples=1)[0, 0]).max() < 1e-6
    clear_document = editor.document
    editor.window.undo()
    assert editor.document == opaque
    shows_the_composite(editor)
    editor.window.redo()
    assert editor.document == clear_document
    shows_the_composite(editor)
    pixels = rasterise(editor.workspace.frame.picture, 64, 64, samples=1)
    target = tmp_path / "disc-clear.fmr"
    editor.answers["save"] = target
    editor.window.save_as()
    qtbot.waitUntil(lambda: editor.window.job is None and not editor.history.modified, timeout=30_000)
    editor.window.close_document()
    editor.open(target)
    assert editor.document == clear_document
    assert np.array_equal(rasterise(editor.workspace.frame.picture, 64, 64, samples=1), pixels)  # as saved
    shows_the_composite(editor)


def test_a_new_layer_over_lady_bug_is_clear_and_a_closed_pen_curve_covers_only_its_inside(editor, shared_data,
                                                                                           qtbot):
    editor.open(shared_data / "orzan_xml" / "berkbavas" / "lady_bug.xml")
    picture = rasterise(editor.fresh_picture(), 64, 64, samples=1)  # blurred, as shown
    qtbot.mouseClick(editor.window.layers_panel.buttons["new_layer"], Qt.MouseButton.LeftButton)
    editor.wait_idle()
    assert len(editor.document.layers) == 2 and editor.document.layers[1].empty
    np.testing.assert_array_equal(rasterise(editor.fresh_picture(), 64, 64, samples=1), picture)
    shows_the_composite(editor)  # clear: lady_bug as it was

    editor.window.options.color = (0.1, 0.3, 0.9)
    editor.key(Qt.Key.Key_P)
    corners = [(150.0, 150.0), (350.0, 150.0), (350.0, 350.0), (150.0, 350.0)]
    for x, y in corners + corners[:1]:  # the last click, on the first anchor, closes the curve
        editor.click(x, y)
    editor.wait_idle()
    assert editor.history.labels[-1] == "Draw Curve"
    curve = editor.document.layers[1].curves[0]
    assert {stop.color for stop in curve.left + curve.right} == {(0.1, 0.3, 0.9)}
    assert sorted(stop.alpha for stop in curve.left + curve.right) == [0.0, 1.0]
    shows_the_composite(editor)
    shown = rasterise(editor.workspace.frame.picture, 64, 64, samples=1)
    centres = (np.arange(64) + 0.5) * 8  # lady_bug is 512 px: 8 px a pixel of the 64 x 64 raster
    within = (centres > 160) & (centres < 340)  # 10 px inside the square, along one axis
    beyond = (centres < 140) | (centres > 360)  # 10 px outside it
    inside, outside = within[:, None] & within[None, :], beyond[:, None] | beyond[None, :]
    np.testing.assert_allclose(shown[inside], np.broadcast_to((0.1, 0.3, 0.9), shown[inside].shape), atol=1e-3)
    np.testing.assert_allclose(shown[outside], picture[outside], atol=1e-6)  # lady_bug untouched outside


def test_a_stop_made_clear_on_an_open_picture_shows_as_the_cpu_composes_it(editor):
    from fmr_editor.model import edits

    editor.open(Path(__file__).parents[1] / "resources" / "samples" / "ribbon.xml")
    shows_the_composite(editor)
    curve = editor.document.curves[1]
    clear = edits.set_stop_alpha(editor.document, curve.id, "left", 0, 0.0)
    editor.history.apply(edits.set_stop_alpha(clear, curve.id, "left", 1, 0.3), "Change Stop Alpha")
    shows_the_composite(editor)


def test_the_mask_button_is_enabled_with_its_menu_and_the_opacity_slider_keeps_its_length(editor, tmp_path):
    from shapes import line_document

    from fmr_editor.io import save_fmr

    panel = editor.window.layers_panel
    assert not panel.buttons["mask"].isEnabled()  # no document: every item of its menu is disabled
    save_fmr(tmp_path / "line.fmr", line_document())
    editor.open(tmp_path / "line.fmr")
    assert panel.buttons["mask"].isEnabled() and editor.window.actions["add_mask"].isEnabled()
    lengths = []
    for percent in (100, 36, 7):
        panel.opacity.setValue(percent)
        panel.layout().activate()
        lengths.append(panel.opacity.width())
    assert panel.opacity_label.text() == "7%" and len(set(lengths)) == 1, lengths
    editor.wait_idle()


def test_colour_adjust_keeps_the_colour_of_a_layer_whose_colour_is_its_transform(gl_display, qtbot):
    """An SVG's background and a Paint layer hold no curves: their colour is their transform, not an earlier
    adjustment, so the dialog does not offer to drop it."""
    from fmr_editor.model import Document, Layer, layer_edits
    from fmr_editor.model.color_transform import ColorTransform
    from fmr_editor.model.history import History
    from fmr_editor.ui.color_adjust import ColorAdjustDialog

    background = Layer(name="Rect 1", transform=ColorTransform(np.zeros((3, 3)), (0.2, 0.4, 0.6)))
    painted, index = layer_edits.with_fill_layer(Document(64, 64), (0.9, 0.5, 0.1))
    for document in (Document(64, 64, layers=(background,)), layer_edits.select_layer(painted, index)):
        assert not document.layer.transform.is_identity
        dialog = ColorAdjustDialog(History(document))
        qtbot.addWidget(dialog)
        dialog.show()
        assert not dialog.from_own.isVisible()
        dialog.reject()
