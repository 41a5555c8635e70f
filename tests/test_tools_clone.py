"""The lasso and the clone transform, without Qt: regions, handles, one step per session, Esc and Return."""

from __future__ import annotations

import numpy as np
import pytest
import shapely
from shapes import scattered_document
from test_tools import click, drag, event, make_context

from fmr_editor.model import Document, EditRefused, layer_edits
from fmr_editor.model.clone import Similarity
from fmr_editor.model.clone_edits import canvas_region, copy_region, paste_curves, paste_position, paste_seamless
from fmr_editor.model.color_transform import ColorTransform, hue_rotation
from fmr_editor.tools import CloneTool, LassoTool
from fmr_editor.tools.lasso import enclosed_region
from fmr_editor.tools.overlay import Polyline
from fmr_editor.tools.transform import Handles

SIZE = 128
SQUARE = [(30.0, 30.0), (80.0, 30.0), (80.0, 70.0), (30.0, 70.0)]


def test_an_outline_encloses_its_largest_loop_clipped_to_the_canvas():
    region, parts = enclosed_region(np.array(SQUARE), SIZE, SIZE)
    assert parts == 1 and shapely.Polygon(region).equals(shapely.Polygon(SQUARE))
    bow_tie = np.array([(10.0, 10.0), (60.0, 40.0), (60.0, 10.0), (10.0, 30.0)])  # two loops, the right one larger
    region, parts = enclosed_region(bow_tie, SIZE, SIZE)
    assert parts == 2 and shapely.Polygon(region).centroid.x > 35
    region, _ = enclosed_region(np.array([(-40.0, -40.0), (50.0, -40.0), (50.0, 50.0), (-40.0, 50.0)]), SIZE, SIZE)
    assert shapely.Polygon(region).equals(shapely.box(0, 0, 50, 50))
    for outline in ([(200.0, 200.0), (220.0, 200.0), (210.0, 230.0)], [(0.0, 0.0), (5.0, 5.0), (10.0, 10.0)]):
        with pytest.raises(EditRefused, match="no area on the canvas"):
            enclosed_region(np.array(outline), SIZE, SIZE)


def test_the_lasso_selects_by_corners_or_freehand_and_esc_clears():
    said = []
    context = make_context(Document(SIZE, SIZE), say=said.append)
    lasso = LassoTool(context)
    for corner in SQUARE + [(50.0, 90.0)]:
        click(lasso, *corner)
    assert lasso.busy and context.region is None
    assert lasso.key("BackSpace") and len(lasso.outline) == 4  # the last corner taken back
    assert any(isinstance(item, Polyline) and item.role == "ants" for item in lasso.overlay())
    click(lasso, *SQUARE[0])  # the first corner again closes it
    assert not lasso.busy and shapely.Polygon(context.region).equals(shapely.Polygon(SQUARE))
    assert context.history.index == 0  # a selection is no step
    drag(lasso, [(10.0, 10.0), (40.0, 12.0), (40.0, 40.0), (12.0, 40.0)])  # freehand: closes on release
    assert shapely.Polygon(context.region).area == pytest.approx(shapely.Polygon(
        [(10.0, 10.0), (40.0, 12.0), (40.0, 40.0), (12.0, 40.0)]).area)
    click(lasso, 5.0, 5.0)
    click(lasso, 6.0, 5.0)
    assert lasso.key("Return") and context.region is not None and "No selection" in said[-1]  # no area: kept
    assert lasso.key("Escape") and context.region is None
    assert not lasso.key("Escape")


@pytest.fixture
def pasting():
    """A clone tool whose document holds a clone layer (pasted, session open) over a target."""
    source, target = scattered_document(SIZE, seed=3), scattered_document(SIZE, seed=8)
    said = []
    context = make_context(target, say=said.append)
    tool = CloneTool(context)
    tool.paste(paste_seamless(target, copy_region(source, SQUARE)))
    return tool, target, said


def test_a_paste_is_one_step_kept_by_return_or_dropped_by_esc(pasting):
    tool, target, _ = pasting
    history = tool.context.history
    assert tool.busy and history.in_transaction and len(history.document.layers) == 2
    assert tool.key("Escape") and not tool.busy and history.document is target and history.index == 0
    tool.paste(paste_seamless(target, copy_region(scattered_document(SIZE, seed=3), SQUARE)))
    drag(tool, [(55.0, 50.0), (65.0, 45.0)])
    assert tool.busy and history.in_transaction  # the session stays open between drags
    assert tool.key("Return") and not tool.busy and history.labels == ("", "Paste Seamless")
    assert history.document.layer.clone.similarity.offset == pytest.approx((10.0, -5.0))


def test_handles_move_scale_and_turn_about_the_box_centre(pasting):
    tool, _, _ = pasting
    context = tool.context
    handles = Handles.of(context.document.layer.clone, context.zoom)
    np.testing.assert_allclose(handles.box, SQUARE)
    np.testing.assert_allclose(handles.centre, (55.0, 50.0))
    drag(tool, [tuple(handles.box[2]), (92.5, 80.0)])  # the corner 1.5 times as far from the centre
    clone = context.document.layer.clone
    assert clone.similarity.scale == pytest.approx(1.5)
    np.testing.assert_allclose(Handles.of(clone, 1.0).centre, (55.0, 50.0), atol=1e-9)
    turn = Handles.of(clone, context.zoom).turn
    drag(tool, [tuple(turn), (55.0 + (50.0 - turn[1]), 50.0)], "shift")  # to the right: a quarter turn
    clone = context.document.layer.clone
    assert clone.similarity.degrees == pytest.approx(90.0) and clone.similarity.scale == pytest.approx(1.5)
    np.testing.assert_allclose(Handles.of(clone, 1.0).centre, (55.0, 50.0), atol=1e-9)
    np.testing.assert_allclose(clone.placed_region[0], (55.0 + 30.0, 50.0 - 37.5), atol=1e-9)
    assert tool.key("Right", frozenset({"shift"}))
    assert context.document.layer.clone.similarity.offset[0] == pytest.approx(clone.similarity.offset[0] + 10.0)
    tool.finish()
    assert context.history.labels == ("", "Paste Seamless")


def test_a_placement_off_the_canvas_is_refused_and_other_clones_are_chosen_by_a_click(pasting):
    tool, _, said = pasting
    context = tool.context
    drag(tool, [(55.0, 50.0), (55.0 + 400.0, 50.0)], release=False)
    assert "wholly outside" in said[-1]
    assert context.document.layer.clone.similarity.offset == (0.0, 0.0)  # the last placement stays
    tool.release(event(455.0, 50.0))
    tool.finish()
    pasted = context.document
    context.history.retarget(layer_edits.select_layer(pasted, 0))
    assert tool.overlay() == []  # no clone active, no handles
    click(tool, 5.0, 5.0)
    assert context.document.active == 0 and "Click inside a clone" in said[-1]
    click(tool, 55.0, 50.0)
    assert context.document.active == 1 and context.history.index == 1  # choosing is no step
    drag(tool, [(55.0, 50.0), (60.0, 50.0)])
    tool.finish()
    assert context.history.labels == ("", "Paste Seamless", "Transform Clone")
    assert context.document.layer.clone.similarity == Similarity(offset=(5.0, 0.0))


def test_copy_carries_the_layers_colour_adjustment_and_paste_curves_adds_to_the_active_layer():

    source = scattered_document(SIZE, seed=3)
    turned = layer_edits.set_transform(source, 0, hue_rotation(150))
    copied = copy_region(turned, SQUARE)
    baked = layer_edits.baked(turned.layer)
    assert copied.source.curves == baked.curves and copied.source.layer.transform.is_identity
    with pytest.raises(EditRefused, match="Paint layer"):  # an offset no curve carries
        copy_region(layer_edits.set_transform(Document(SIZE, SIZE), 0,
                                              ColorTransform(np.zeros((3, 3)), (1.0, 0.5, 0.0))), SQUARE)

    target = scattered_document(SIZE, seed=8)
    pasted = paste_curves(target, copied, (5.0, -5.0))
    added = pasted.curves[len(target.curves):]
    assert len(pasted.layers) == 1 and pasted.curves[:len(target.curves)] == target.curves and added
    assert all(curve.id not in {c.id for c in target.curves} for curve in added)
    np.testing.assert_allclose(added[0].control_points - [5.0, -5.0],
                               next(c for c in copied.source.curves if c.left == added[0].left).control_points)
    with pytest.raises(EditRefused, match="nothing to paste"):
        paste_curves(target, copy_region(Document(SIZE, SIZE), SQUARE))

    assert paste_position(copied, target) == Similarity()  # in place: it fits
    small = Document(40, 30)
    offset = np.asarray(paste_position(copied, small).offset)
    np.testing.assert_allclose(shapely.Polygon(copied.region + offset).centroid.coords[0], (20.0, 15.0))
    np.testing.assert_array_equal(canvas_region(small), [[0, 0], [40, 0], [40, 30], [0, 30]])


def test_the_pen_on_a_clone_layer_refuses_at_its_first_click(pasting):
    """Not after the whole curve is drawn: the first anchor is refused, and nothing is drawn."""
    from fmr_editor.tools import PenTool

    tool, _, _ = pasting
    assert tool.key("Return") and tool.context.document.layer.clone is not None  # placed: the clone layer active
    pen = PenTool(tool.context)
    with pytest.raises(EditRefused, match="clone layer holds no curves"):
        click(pen, 40.0, 40.0)
    assert not pen.busy
    pen.context.history.apply(layer_edits.select_layer(pen.context.document, 0), "Select Layer")
    click(pen, 40.0, 40.0)  # another layer: drawn as ever
    assert pen.busy
