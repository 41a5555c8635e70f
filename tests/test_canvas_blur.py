"""Blur on the canvas (issue 29) against the CPU, under Xvfb (OpenGL through Mesa).

A blurred layer's image and alpha are evaluated beyond the window, reflected at the canvas border, and
blurred on the GPU (``render.blur_filter``) as ``engine.blur.window_picture`` blurs them on the CPU: the
canvas must show that, composed with the other layers, at a view with the checkerboard around the canvas
and at a zoom deep enough for the pyramid's octaves, after an edit of a colour and of a blur stop, and the
sharp composite once the blur is turned off.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from canvas_oracle import CHECKER, checkerboard, error_levels, window_samples
from layered import blurred_layers

pytest.importorskip("pytestqt", reason="pytest-qt is in the [test] extra")

from fmr_editor.engine import LiveStack  # noqa: E402
from fmr_editor.engine.blur import window_picture  # noqa: E402
from fmr_editor.model import BlurStop, ColorStop, edits, layer_edits  # noqa: E402
from fmr_editor.render import View  # noqa: E402

pytestmark = pytest.mark.gui

AROUND = View(1.7, 15.0, 10.0, 250, 240)  # the 128 px canvas and a margin of checkerboard
CLOSE = View(3.3, -95.0, -60.0, 250, 240)  # inside the canvas; blurs to 20 window pixels: octaves 1 and 2


@pytest.fixture
def canvas(gl_display, qtbot):
    from fmr_editor.ui.canvas import Canvas

    widget = Canvas()
    qtbot.addWidget(widget)
    widget.resize(AROUND.width, AROUND.height)
    widget.show()
    qtbot.waitExposed(widget)
    return widget


def check(canvas, picture, view: View) -> None:
    """The canvas shows ``window_picture`` of ``picture`` over the checkerboard, the checkerboard outside."""
    canvas.set_view(view)
    shown = canvas.grab_image()
    if canvas.renderer is None:
        pytest.skip(f"no usable OpenGL context: {canvas.error or 'the widget did not initialise'}")
    samples = window_samples(view)
    inside = ((samples >= 0) & (samples <= [picture.width, picture.height])).all(axis=1)
    values = window_picture(picture, (-view.offset_x / view.scale, -view.offset_y / view.scale), 1 / view.scale,
                            view.width, view.height).reshape(-1, 4)
    expected = values[:, :3] + (1.0 - values[:, 3:]) * checkerboard(view)[:, None]
    assert error_levels(shown.reshape(-1, 3)[inside], expected[inside]) <= 1.0
    assert set(np.unique(shown.reshape(-1, 3)[~inside])) <= CHECKER
    canvas.makeCurrent()
    drawn = canvas.renderer.read()[..., :3].reshape(-1, 3)[inside].astype(np.float64)
    canvas.doneCurrent()
    assert np.abs(drawn - expected[inside]).max() < 0.1 / 255  # the float image, before 8-bit rounding


def test_the_canvas_blurs_as_the_cpu_does_and_follows_edits(canvas):
    document = layer_edits.select_layer(blurred_layers(), 2)
    stack = LiveStack(document, blur=True)
    top = document.layers[2]
    assert stack.composite.layers[2].blur is not None
    canvas.set_representation(stack.composite, fit=False)
    for view in (AROUND, CLOSE):
        check(canvas, stack.composite, view)
    assert {key[1] for key in canvas.renderer.renderers} >= {"blur", "alpha"}

    curve = top.curves[0]
    green = (ColorStop(0.0, (0.1, 0.9, 0.2), 0.7),)
    recoloured = edits.replace_curve(document, curve.id, replace(curve, left=green))
    blurred_before = canvas.renderer.blurred
    update = stack.update(recoloured)
    changed = {key for key, field in update.fields.items() if field.changed.any()}
    assert changed == {(top.id, "image"), (top.id, "alpha")}  # the blur field did not change
    canvas.update_representation(stack.composite, {key: u.changed for key, u in update.fields.items()})
    check(canvas, stack.composite, CLOSE)
    assert canvas.renderer.blurred == blurred_before + 2  # the image and the alpha, once each

    softer = edits.replace_curve(recoloured, curve.id, replace(curve, left=green, blur=(BlurStop(0.0, 3.0),)))
    update = stack.update(softer)
    assert update.fields[top.id, "blur"].changed.any()
    canvas.update_representation(stack.composite, {key: u.changed for key, u in update.fields.items()})
    check(canvas, stack.composite, CLOSE)

    stack.set_blur(False)
    sharp = stack.composite
    assert all(layer.blur is None for layer in sharp.layers)
    canvas.update_representation(sharp, {})
    check(canvas, sharp, AROUND)  # window_picture of a picture without blur fields: the sharp one
    assert not any(key[1] == "blur" for key in canvas.renderer.renderers)


def test_a_pan_blurs_only_the_strips_it_uncovers(canvas):
    """A pan by whole pixels with nothing edited moves the blurred images and blurs the uncovered strips alone:
    the canvas is then what blurring afresh gives."""
    from fmr_editor.render.blur_filter import TILE

    stack = LiveStack(blurred_layers(), blur=True)
    canvas.set_representation(stack.composite, fit=False)
    check(canvas, stack.composite, CLOSE)
    renderer = canvas.renderer
    rows, columns = -(-CLOSE.height // TILE), -(-CLOSE.width // TILE)
    before = renderer.blurred_tiles
    panned = CLOSE.panned(16, -8)  # whole tiles: the octaves' pixels stay aligned
    check(canvas, stack.composite, panned)
    blurred = renderer.blurred_tiles - before
    assert 0 < blurred <= 2 * (2 * rows + columns)  # two fields, a strip of 2 tile columns and one of a row each
    assert blurred < rows * columns
