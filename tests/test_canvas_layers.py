"""A layered picture on the canvas against the CPU composite, under Xvfb (OpenGL through Mesa).

The canvas composes each layer's and mask's evaluated window image
(``render.PictureRenderer``); what it shows must be ``engine.evaluate_points``
of the composite at the pixel centres (over the checkerboard where it is not
opaque) to one 8-bit level, after edits to one layer, a mask dab and a hue
change as well, and each of those must redraw only what it changed.  A layer
is evaluated only where it may show (``render.culling``): what an edit, a pan
or a zoom reveals is evaluated then.
"""

from __future__ import annotations

import numpy as np
import pytest
from canvas_oracle import CHECKER, error_levels, shown_colours, window_samples
from layered import paint_over_glow, three_layers, translucent_layers, with_alphas
from shapes import circle_points, uniform_curve

pytest.importorskip("pytestqt", reason="pytest-qt is in the [test] extra")

from fmr_editor.engine import LiveStack, Role, evaluate_points  # noqa: E402
from fmr_editor.model import DiffusionPoint, Document, edits, layer_edits  # noqa: E402
from fmr_editor.model.color_transform import hue_rotation  # noqa: E402
from fmr_editor.model.layer import MASK_LUMA  # noqa: E402
from fmr_editor.render import View, bounds  # noqa: E402

pytestmark = pytest.mark.gui

VIEW = View(1.7, 15.0, 10.0, 250, 240)  # the 128 px canvas and a margin of checkerboard


@pytest.fixture
def canvas(gl_display, qtbot):
    from fmr_editor.ui.canvas import Canvas

    widget = Canvas()
    qtbot.addWidget(widget)
    widget.resize(VIEW.width, VIEW.height)
    widget.show()
    qtbot.waitExposed(widget)
    return widget


def check(canvas, picture, view: View = VIEW) -> None:
    """The canvas shows ``picture`` in ``view``: the composite inside the canvas, the checkerboard outside."""
    shown = canvas.grab_image()
    if canvas.renderer is None:
        pytest.skip(f"no usable OpenGL context: {canvas.error or 'the widget did not initialise'}")
    samples = window_samples(view)
    inside = ((samples >= 0) & (samples <= [picture.width, picture.height])).all(axis=1)
    expected = shown_colours(picture, view, inside)
    assert error_levels(shown.reshape(-1, 3)[inside], expected) <= 1.0
    assert not (~inside).any() or set(np.unique(shown.reshape(-1, 3)[~inside])) == CHECKER
    canvas.makeCurrent()
    drawn = canvas.renderer.read()[..., :3].reshape(-1, 3)[inside].astype(np.float64)
    canvas.doneCurrent()
    # the float image, before 8-bit rounding (one plain layer's is its field's, unclamped)
    assert np.abs(np.clip(drawn, 0, 1) - expected).max() < 0.1 / 255


def shown_three_layers(canvas):
    """``three_layers`` on the canvas, checked: the document, its stack and the fields' renderers."""
    document = three_layers()
    stack = LiveStack(document)
    canvas.set_representation(stack.composite, fit=False)
    canvas.set_view(VIEW)
    check(canvas, stack.composite)
    return document, stack, canvas.renderer.renderers


def test_the_canvas_shows_the_composite_and_follows_edits_of_one_layer(canvas, qtbot):
    document, stack, renderers = shown_three_layers(canvas)
    assert len(renderers) == 5  # three images, two masks
    assert len(canvas.renderer._groups(stack.composite.shown)) == 1  # composed in one pass

    middle = document.layers[1]
    dabbed = edits.add_points(layer_edits.select_layer(document, 1, mask=True),
                              [DiffusionPoint((50.0, 40.0), 9.0, (1.0, 1.0, 1.0), -1.0)])
    update = stack.update(dabbed)
    before = {key: renderer.evaluations.copy() for key, renderer in renderers.items()}
    canvas.update_representation(stack.composite, {key: u.changed for key, u in update.fields.items()})
    check(canvas, stack.composite)
    since = {key: renderers[key].evaluations - before[key] for key in before}
    assert since.pop((middle.id, "mask")) == {"cells": 1}  # the dab's cells only
    # its image where the dab's near points leave the mask unbounded (render.culling), if hidden there before
    assert set(since.pop((middle.id, "image"))) <= {"none", "cells"}
    assert all(set(counts) <= {"none"} for counts in since.values())  # the others evaluated nothing

    recoloured = layer_edits.set_transform(dabbed, 0, hue_rotation(200))
    assert stack.update(recoloured).fields == {}
    composed = canvas.renderer.composed
    before = canvas.renderer.evaluations.copy()
    canvas.update_representation(stack.composite, {})
    check(canvas, stack.composite)
    assert set(canvas.renderer.evaluations - before) <= {"none"}  # no field evaluated anything
    assert canvas.renderer.composed == composed + 1

    hidden = layer_edits.set_visible(layer_edits.set_opacity(recoloured, 2, 0.4), 1, False)
    stack.update(hidden)
    canvas.update_representation(stack.composite, {})
    check(canvas, stack.composite)
    assert set(renderers) == set(stack.fields) - {(middle.id, "image"), (middle.id, "mask")}  # hidden: released

    for index in (0, 2):  # every layer hidden: black on the canvas, the checkerboard around it
        hidden = layer_edits.set_visible(hidden, index, False)
    stack.update(hidden)
    canvas.update_representation(stack.composite, {})
    check(canvas, stack.composite)
    assert not evaluate_points(stack.composite, [[10.0, 10.0]]).any()


def test_a_mask_of_points_alone_shows_its_first_curve(canvas):
    document, stack, _ = shown_three_layers(canvas)
    assert len(stack.composite.layers[1].mask.near[0].p) == 0  # the middle mask: points alone, no segment loop
    ring = uniform_curve(circle_points(40, 50, 20), 1.0, 0.0)
    update = stack.update(edits.add_curve(layer_edits.select_layer(document, 1, mask=True), ring))
    assert len(stack.composite.layers[1].mask.near[0].p) > 0
    canvas.update_representation(stack.composite, {key: field.changed for key, field in update.fields.items()})
    check(canvas, stack.composite)


def test_the_canvas_clamps_each_layer_before_blending_as_the_composite_does(canvas):
    stack = LiveStack(paint_over_glow())  # a glow far above 1 under green paint
    canvas.set_representation(stack.composite, fit=False)
    canvas.set_view(VIEW)
    check(canvas, stack.composite)


def test_the_canvas_shows_translucent_layers_as_the_composite_does_and_follows_their_alpha_and_colour(canvas):
    stack = LiveStack(translucent_layers())  # alpha fields on two layers, one of them masked
    canvas.set_representation(stack.composite, fit=False)
    canvas.set_view(VIEW)
    check(canvas, stack.composite)
    renderers = canvas.renderer.renderers
    top = stack.composite.layers[2]
    # each alpha field rides in its image's fourth channel (the same segments): no renderer of its own
    assert all(renderers[layer.id, Role.IMAGE].alpha is layer.alpha for layer in stack.composite.layers[1:])
    assert Role.ALPHA not in {key[1] for key in renderers}

    curve = stack.document.layers[2].curves[0]
    document = layer_edits.select_layer(stack.document, 2)
    for edit in (lambda d: edits.set_stop_alpha(d, curve.id, "left", 0, 0.05),  # the alpha field alone
                 lambda d: edits.set_stop_color(d, curve.id, "left", 0, (0.1, 0.9, 0.2))):  # the colour alone
        document = edit(document)
        update = stack.update(document)
        assert (top.id, Role.IMAGE) in update.fields or (top.id, Role.ALPHA) in update.fields
        canvas.update_representation(stack.composite, {key: field.changed for key, field in update.fields.items()})
        check(canvas, stack.composite)
        assert renderers[top.id, Role.IMAGE].alpha is stack.composite.layers[2].alpha


@pytest.mark.parametrize("make", [three_layers, translucent_layers])
def test_layers_composed_in_several_passes_show_what_one_pass_shows(canvas, monkeypatch, make):
    from fmr_editor.render import picture_renderer

    monkeypatch.setattr(picture_renderer, "PASS_LAYERS", 1)  # a pass a layer, each over those below it
    stack = LiveStack(make())
    canvas.set_representation(stack.composite, fit=False)
    canvas.set_view(VIEW)
    check(canvas, stack.composite)
    assert len(canvas.renderer._groups(stack.composite.shown)) == len(stack.composite.shown) == 3


def test_where_the_picture_is_clear_the_canvas_shows_the_checkerboard(canvas):
    disc = with_alphas(uniform_curve(circle_points(64, 60, 30), left=0.9, right=0.9), left=1.0, right=0.0)
    picture = LiveStack(Document(128, 128, [disc])).composite  # one layer, opaque inside the disc only
    canvas.set_representation(picture, fit=False)
    canvas.set_view(VIEW)
    check(canvas, picture)
    samples = window_samples(VIEW)
    clear = (samples >= 0).all(axis=1) & (samples <= 128).all(axis=1) & (np.hypot(*(samples - (64, 60)).T) > 34)
    assert set(np.unique(canvas.grab_image().reshape(-1, 3)[clear])) == CHECKER  # inside the canvas, too


def test_the_canvas_leaves_hidden_cells_out_and_shows_them_when_an_edit_reveals_them(canvas):
    document, stack, renderers = shown_three_layers(canvas)
    bottom, top = document.layers[0], document.layers[2]
    covered = renderers[bottom.id, Role.IMAGE].stale  # under the top layer's circle
    assert 0.03 < covered.mean() < 0.5
    outside = renderers[top.id, Role.IMAGE].stale  # beyond its circle
    assert outside.mean() > 0.05 and not (covered & outside).any()
    assert renderers[top.id, Role.MASK].stale.mean() > covered.mean()  # where its weight is 1 as well

    circle = document.layers[2].mask.curves[0].id
    moved = edits.translate(layer_edits.select_layer(document, 2, mask=True), (-40.0, 30.0), curves=[circle])
    update = stack.update(moved)
    canvas.update_representation(stack.composite, {key: field.changed for key, field in update.fields.items()})
    check(canvas, stack.composite)  # what the circle uncovered is evaluated, what it covers left
    assert (covered & ~renderers[bottom.id, Role.IMAGE].stale).any()
    mask = renderers[top.id, Role.MASK]
    kept, fresh = mask.value_bounds(), bounds.cell_value_bounds(stack.composite.layers[2].mask, MASK_LUMA)
    np.testing.assert_array_equal(kept[0], fresh[0])
    np.testing.assert_array_equal(kept[1], fresh[1])

    for view in (VIEW.panned(-37.0, 21.0), VIEW.zoomed(1.6, 90.0, 100.0)):
        canvas.set_view(view)
        check(canvas, stack.composite, view)

    update = stack.update(document)  # the circle back, the view too: the bottom is covered again
    canvas.update_representation(stack.composite, {key: field.changed for key, field in update.fields.items()})
    canvas.set_view(VIEW)
    check(canvas, stack.composite)
    assert renderers[bottom.id, Role.IMAGE].stale.any()
    stack.update(layer_edits.set_visible(layer_edits.set_visible(document, 1, False), 2, False))
    canvas.update_representation(stack.composite, {})  # drawn by the bottom image's renderer alone
    check(canvas, stack.composite)
