"""The drawing tools, driven by pointer events without Qt: documents and history they leave."""

from __future__ import annotations

import numpy as np
import pytest
from selections import by_index
from shapes import straight_chain

from fmr_editor.model import ColorStop, DiffusionCurve, DiffusionPoint, Document, Layer
from fmr_editor.model.history import History
from fmr_editor.tools import (
    TOOLS,
    BrushTool,
    EyedropperTool,
    PenTool,
    PointerEvent,
    SelectTool,
    StopsTool,
    ToolContext,
    create_tools,
    recolor_stops,
)
from fmr_editor.tools.overlay import Circle, Markers, Polyline, Rectangle

RED, GREEN, BLUE = (1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0)


def event(x: float, y: float, *modifiers: str, button: str = "left", clicks: int = 1) -> PointerEvent:
    return PointerEvent((x, y), button, frozenset(modifiers), clicks)


def click(tool, x: float, y: float, *modifiers: str, clicks: int = 1) -> None:
    tool.press(event(x, y, *modifiers, clicks=clicks))
    tool.release(event(x, y, *modifiers))


def drag(tool, path, *modifiers: str, release: bool = True) -> None:
    """Press at ``path[0]``, move through the rest, release at the end (unless told not to)."""
    tool.press(event(*path[0], *modifiers))
    for x, y in path[1:]:
        tool.move(event(x, y, *modifiers))
    if release:
        tool.release(event(*path[-1], *modifiers))


def line_curve(a=(20.0, 50.0), b=(50.0, 50.0), c=(80.0, 50.0), left=(), right=()) -> DiffusionCurve:
    """Two straight, evenly parametrised pieces a-b-c: s = distance / 30 from a."""
    return DiffusionCurve(straight_chain([a, b, c]), left=left, right=right)


def make_context(document: Document, **kwargs) -> ToolContext:
    return ToolContext(History(document), **kwargs)


@pytest.fixture
def line_doc() -> Document:
    stops = (ColorStop(0.5, RED),)
    return Document(100, 100, (line_curve(left=stops, right=(ColorStop(1.0, BLUE),)),))


def points_doc() -> Document:
    positions = [(10, 10), (30, 30), (45, 20), (70, 70), (90, 15)]
    return Document(100, 100, points=[DiffusionPoint(p, 5.0, GREEN) for p in positions])


# -- pen ------------------------------------------------------------------------------------------
def test_pen_clicks_make_corners_and_drags_make_mirrored_smooth_handles():
    context = make_context(Document(120, 80))
    context.options.color, context.options.secondary_color = RED, BLUE
    pen = PenTool(context)
    click(pen, 10, 10)
    click(pen, 40, 10)
    drag(pen, [(70, 30), (75, 35), (80, 40)])  # smooth anchor at (70, 30), out handle at (80, 40)
    click(pen, 100, 10)
    assert context.history.index == 0, "nothing is recorded before the curve is finished"
    assert pen.key("Return")
    assert context.history.labels == ("", "Draw Curve")
    curve = context.document.curves[0]
    expected = [
        (10, 10), (20, 10), (30, 10), (40, 10),  # two corners: handles at thirds, a straight piece
        (40 + 20 / 3, 10 + 10 / 3), (60, 20), (70, 30),  # corner toward the smooth anchor's in handle
        (80, 40), (100 - 20 / 3, 10 + 10), (100, 10),
    ]
    np.testing.assert_allclose(curve.control_points, expected, atol=1e-12)
    points = curve.control_points
    np.testing.assert_allclose(points[5] + points[7], 2 * points[6])  # mirrored about the anchor
    assert curve.left == (ColorStop(0.0, RED),) and curve.right == (ColorStop(0.0, BLUE),)
    assert context.selection == by_index(context.document, curves=[0])
    assert not pen.busy and pen.overlay() == []


def test_pen_double_click_finishes_without_an_extra_anchor():
    context = make_context(Document(100, 100))
    pen = PenTool(context)
    click(pen, 10, 10)
    click(pen, 50, 60)
    click(pen, 50, 60, clicks=2)
    assert len(context.document.curves) == 1
    np.testing.assert_allclose(context.document.curves[0].control_points[[0, -1]], [(10, 10), (50, 60)])
    assert context.document.curves[0].piece_count == 1
    assert context.history.labels == ("", "Draw Curve")


def test_pen_alt_drag_leaves_the_incoming_side_a_corner_and_shift_keeps_45_degrees():
    context = make_context(Document(100, 100))
    pen = PenTool(context)
    click(pen, 10, 10)
    drag(pen, [(40, 10), (50, 13)], "alt", "shift")  # shift: snapped to horizontal
    click(pen, 70, 10)
    pen.finish()
    points = context.document.curves[0].control_points
    np.testing.assert_allclose(points[4], (50, 10))  # out handle, snapped
    np.testing.assert_allclose(points[2], (40 - 10, 10))  # in side: a third of the way toward (10, 10)


def test_pen_escape_cancels_and_backspace_removes_the_last_anchor():
    context = make_context(Document(100, 100))
    start = context.document
    pen = PenTool(context)
    click(pen, 10, 10)
    click(pen, 20, 20)
    drag(pen, [(30, 30), (40, 40)], release=False)
    assert pen.key("Escape")
    pen.release(event(40, 40))
    assert context.document is start and context.history.labels == ("",) and not pen.busy
    assert not pen.key("Return"), "no curve in progress: the key is not the pen's"
    click(pen, 10, 10)
    click(pen, 20, 20)
    click(pen, 90, 90)
    assert pen.key("BackSpace")
    pen.key("Return")
    np.testing.assert_allclose(context.document.curves[0].control_points[-1], (20, 20))
    assert context.document.curves[0].piece_count == 1


def test_a_new_pen_curve_drops_the_selection_and_ends_selected():
    context = make_context(Document(100, 100, [line_curve()]))
    context.selection = by_index(context.document, curves=[0], stops=[])
    pen = PenTool(context)
    click(pen, 10, 10)  # the curve selected before is not the one being drawn
    assert context.selection.empty and pen.busy
    click(pen, 30, 80)
    pen.key("Return")
    assert context.selection == by_index(context.document, curves=[1])


def test_pen_needs_two_anchors_and_closes_on_the_first_anchor():
    context = make_context(Document(100, 100))
    pen = PenTool(context)
    click(pen, 10, 10)
    pen.key("Return")
    assert context.history.index == 0 and not context.document.curves
    for x, y in [(10, 10), (60, 10), (60, 60)]:
        click(pen, x, y)
    click(pen, 11, 12)  # within the hit radius of the first anchor: closes the curve
    curve = context.document.curves[0]
    assert curve.piece_count == 3
    np.testing.assert_array_equal(curve.control_points[0], curve.control_points[-1])
    assert context.history.labels == ("", "Draw Curve") and not pen.busy


@pytest.mark.parametrize("corners, inside_on_left", [([(10, 10), (60, 10), (60, 60)], False),
                                                     ([(10, 10), (10, 60), (60, 60)], True)])
def test_pen_on_a_new_layer_draws_the_foreground_colour_opaque_inside_a_closed_curve_and_clear_outside(
        corners, inside_on_left):
    from fmr_editor.engine import LiveStack, evaluate_points
    from fmr_editor.model import layer_edits

    picture = Document(100, 100, [line_curve(left=(ColorStop(0.0, (0.1, 0.2, 0.3)),))])
    context = make_context(layer_edits.add_layer(picture))
    context.options.color, context.options.secondary_color = (0.9, 0.5, 0.0), (0.0, 0.0, 1.0)
    pen = PenTool(context)
    for x, y in corners + [corners[0]]:  # the last click closes the curve
        click(pen, x, y)
    curve = context.document.layers[1].curves[0]
    inside, outside = (curve.left, curve.right) if inside_on_left else (curve.right, curve.left)
    assert inside == (ColorStop(0.0, (0.9, 0.5, 0.0), 1.0),) and outside == (ColorStop(0.0, (0.9, 0.5, 0.0), 0.0),)
    middle = np.mean(corners, axis=0)  # the triangle's centroid
    shown, below = (evaluate_points(LiveStack(document).composite, [middle, (90.0, 90.0)])
                    for document in (context.document, picture))
    np.testing.assert_allclose(shown[0], (0.9, 0.5, 0.0), atol=1e-3)  # the closed shape covers its inside ...
    np.testing.assert_allclose(shown[1], below[1], atol=1e-6)  # ... and only that
    click(pen, 20, 80)  # an open stroke on the now translucent layer: the foreground colour, opaque, both sides
    click(pen, 80, 80)
    pen.key("Return")
    stroke = context.document.layers[1].curves[1]
    assert stroke.left == stroke.right == (ColorStop(0.0, (0.9, 0.5, 0.0), 1.0),)
    context.options.stroke_left_alpha, context.options.stroke_right_alpha = 1.0, 0.25  # or as the options say
    click(pen, 20, 90)
    click(pen, 80, 90)
    pen.key("Return")
    stroke = context.document.layers[1].curves[2]
    assert [s.alpha for s in stroke.left + stroke.right] == [1.0, 0.25]


def test_pen_on_the_bottom_layer_or_an_opaque_one_keeps_foreground_left_and_background_right():
    from fmr_editor.model import layer_edits

    for document in (Document(100, 100), layer_edits.add_layer(Document(100, 100, [line_curve()]),
                                                               Layer([line_curve()]))):
        context = make_context(document)
        context.options.color, context.options.secondary_color = (0.9, 0.5, 0.0), (0.0, 0.0, 1.0)
        pen = PenTool(context)
        for x, y in [(10, 10), (60, 10), (60, 60), (10, 10)]:
            click(pen, x, y)
        curve = context.document.layer.curves[-1]
        assert curve.left == (ColorStop(0.0, (0.9, 0.5, 0.0)),) and curve.right == (ColorStop(0.0, (0.0, 0.0, 1.0)),)


@pytest.mark.parametrize("corners", [[(20, 20), (80, 20), (80, 80), (20, 80)],  # clockwise on the screen
                                     [(20, 20), (20, 80), (80, 80), (80, 20)]])
def test_pen_on_a_hide_all_mask_shows_a_closed_curves_inside_whichever_way_it_is_drawn(corners):
    """Foreground inside and background outside (white, black): the layer shows exactly inside the shape."""
    from fmr_editor.engine import LiveStack, evaluate_points
    from fmr_editor.model import Mask, layer_edits

    below = Document(100, 100, [line_curve(left=(ColorStop(0.0, (0.1, 0.2, 0.3)),))])
    document = layer_edits.add_layer(below, Layer([line_curve(left=(ColorStop(0.0, GREEN),),
                                                               right=(ColorStop(0.0, GREEN),))]))
    document = layer_edits.select_layer(layer_edits.add_mask(document, 1, Mask(base=0.0)), 1, mask=True)
    context = make_context(document)
    context.options.color, context.options.secondary_color = (1.0, 1.0, 1.0), (0.0, 0.0, 0.0)
    pen = PenTool(context)
    for x, y in corners + [corners[0]]:  # the last click closes the curve
        click(pen, x, y)
    curve = context.document.layers[1].mask.curves[0]
    inside, outside = (curve.left, curve.right) if curve.inside_on_left() else (curve.right, curve.left)
    assert inside == (ColorStop(0.0, (1.0, 1.0, 1.0)),) and outside == (ColorStop(0.0, (0.0, 0.0, 0.0)),)
    shown, under = (evaluate_points(LiveStack(d).composite, [(50.0, 50.0), (95.0, 5.0)])
                    for d in (context.document, below))
    np.testing.assert_allclose(shown[0], GREEN, atol=1e-3)  # the layer inside the shape ...
    np.testing.assert_allclose(shown[1], under[1], atol=1e-6)  # ... and what lies below outside it


def test_pen_overlay_shows_the_curve_and_the_next_piece():
    context = make_context(Document(100, 100))
    pen = PenTool(context)
    click(pen, 10, 10)
    click(pen, 50, 10)
    pen.move(event(50, 50, button="none"))
    roles = [p.role for p in pen.overlay() if isinstance(p, Polyline)]
    assert roles == ["preview", "selected"]
    preview = pen.overlay()[0].points
    np.testing.assert_allclose(preview[[0, -1]], [(50, 10), (50, 50)])


# -- colour stops ---------------------------------------------------------------------------------
@pytest.mark.parametrize(
    ("ends", "left_click", "right_click"),
    [
        (((20, 50), (50, 50), (80, 50)), (35, 45), (65, 56)),  # walking right: left is up (y down)
        (((80, 50), (50, 50), (20, 50)), (65, 55), (35, 44)),  # walking left: left is down
        (((50, 20), (50, 50), (50, 80)), (55, 35), (44, 65)),  # walking down the screen: left is +x
    ],
)
def test_a_click_beside_a_curve_adds_a_stop_on_that_side(ends, left_click, right_click):
    context = make_context(Document(100, 100, (line_curve(*ends),)))
    context.options.color = GREEN
    tool = StopsTool(context)
    click(tool, *left_click)
    assert context.history.labels == ("", "Add Stop")
    curve = context.document.curves[0]
    assert curve.right == () and len(curve.left) == 1
    assert curve.left[0].color == GREEN
    assert curve.left[0].position == pytest.approx(0.5, abs=1e-9)
    click(tool, *right_click)
    curve = context.document.curves[0]
    assert len(curve.left) == 1 and curve.right[0].position == pytest.approx(1.5, abs=1e-9)
    assert context.history.labels == ("", "Add Stop", "Add Stop")
    assert context.selection == by_index(context.document, stops=[(0, "right", 0)])


def test_a_click_far_from_curves_adds_nothing(line_doc):
    context = make_context(line_doc)
    tool = StopsTool(context)
    click(tool, 50, 80)
    assert context.history.index == 0 and context.document is line_doc


def test_dragging_a_stop_moves_it_along_the_curve_as_one_step(line_doc):
    context = make_context(line_doc)
    tool = StopsTool(context)
    # the left stop at s = 0.5 sits at (35, 50); its marker 8 screen pixels up, on the left
    drag(tool, [(35, 42), (40, 45), (55, 47), (65, 30)])
    assert context.history.labels == ("", "Move Stop")
    curve = context.document.curves[0]
    assert curve.left[0].position == pytest.approx(1.5, abs=1e-9) and curve.left[0].color == RED
    assert curve.right == line_doc.curves[0].right
    assert context.selection == by_index(context.document, stops=[(0, "left", 0)])
    context.history.undo()
    assert context.document == line_doc


def test_a_moved_stop_stays_selected_when_it_passes_another():
    stops = (ColorStop(0.5, RED), ColorStop(1.0, GREEN))
    context = make_context(Document(100, 100, (line_curve(left=stops),)))
    tool = StopsTool(context)
    drag(tool, [(35, 42), (70, 42)])  # past the green stop at s = 1
    left = context.document.curves[0].left
    assert [s.color for s in left] == [GREEN, RED]
    assert context.selection == by_index(context.document, stops=[(0, "left", 1)])


def test_adding_a_stop_by_dragging_is_one_step_and_a_plain_click_is_a_step(line_doc):
    context = make_context(line_doc)
    context.options.color = GREEN
    tool = StopsTool(context)
    drag(tool, [(26, 56), (50, 60), (74, 56)])  # press on the right side at s = 0.2, drag to 1.8
    assert context.history.labels == ("", "Add Stop")
    right = context.document.curves[0].right
    assert [(round(s.position, 9), s.color) for s in right] == [(1.0, BLUE), (1.8, GREEN)]


def test_double_click_asks_for_a_stop_colour(line_doc):
    asked = []
    context = make_context(line_doc, choose_color=lambda current: asked.append(current) or GREEN)
    tool = StopsTool(context)
    click(tool, 35, 42)
    click(tool, 35, 42, clicks=2)
    assert asked == [RED]
    assert context.document.curves[0].left == (ColorStop(0.5, GREEN),)
    assert context.history.labels == ("", "Change Stop Colour")
    context.choose_color = lambda current: None  # the user cancelled the dialog
    click(tool, 35, 42, clicks=2)
    assert context.history.index == 1


def test_delete_removes_the_selected_stops_as_one_step(line_doc):
    context = make_context(line_doc)
    tool = StopsTool(context)
    click(tool, 35, 42)  # left stop
    click(tool, 50, 58, "shift")  # right stop's marker at (50, 58): added to the selection
    assert context.selection == by_index(context.document, stops=[(0, "left", 0), (0, "right", 0)])
    assert tool.key("Delete")
    assert context.history.labels == ("", "Delete Stops")
    curve = context.document.curves[0]
    assert curve.left == () and curve.right == ()
    assert np.array_equal(curve.control_points, line_doc.curves[0].control_points)
    assert context.selection.empty  # no stop left to take their place


@pytest.mark.parametrize(("removed", "then"), [((0,), 0), ((1,), 1), ((3,), 2), ((1, 2), 1), ((2, 3), 1)])
def test_removing_stops_selects_the_one_that_took_their_place(removed, then):
    """The curve stays in the stops panel: the stop now at the first removed index, or the last."""
    left = tuple(ColorStop(s, (s / 2, 0.0, 0.0)) for s in (0.0, 0.5, 1.0, 2.0))
    document = Document(100, 100, (line_curve(left=left, right=(ColorStop(1.0, BLUE),)),))
    context = make_context(document)
    context.selection = by_index(document, stops=[(0, "left", i) for i in removed])
    assert StopsTool(context).key("Delete")
    kept = tuple(stop for i, stop in enumerate(left) if i not in removed)
    assert context.document.curves[0].left == kept
    assert context.selection == by_index(context.document, stops=[(0, "left", then)])


def test_recolouring_the_selected_stops_merges_a_slider_drag(line_doc):
    context = make_context(line_doc)
    context.selection = by_index(context.document, stops=[(0, "left", 0), (0, "right", 0)])
    for level in (0.2, 0.4, 0.6):
        assert recolor_stops(context, (level, level, level), merge_key="slider")
    curve = context.document.curves[0]
    assert curve.left[0].color == curve.right[0].color == (0.6, 0.6, 0.6)
    assert context.history.labels == ("", "Change Stops Colour")


# -- select and move ------------------------------------------------------------------------------
def test_moving_an_anchor_brings_its_handles_and_undo_redo_round_trips(line_doc):
    context = make_context(line_doc)
    tool = SelectTool(context)
    click(tool, 30, 51)  # select the curve: its nodes are shown
    assert context.selection == by_index(context.document, curves=[0]) and context.history.index == 0
    drag(tool, [(50, 50), (50, 55), (52, 60)])  # the middle anchor, control point 3
    assert context.history.labels == ("", "Move Anchor")
    moved = context.document
    delta = moved.curves[0].control_points - line_doc.curves[0].control_points
    np.testing.assert_allclose(delta[2:5], [(2, 10)] * 3)
    np.testing.assert_array_equal(delta[[0, 1, 5, 6]], 0)
    context.history.undo()
    assert context.document == line_doc
    context.history.redo()
    assert context.document is moved


def test_dragging_a_selected_curve_moves_it_whole_with_shift_constraint(line_doc):
    context = make_context(line_doc)
    tool = SelectTool(context)
    drag(tool, [(30, 50), (40, 53)], "shift")  # mostly right: constrained to horizontal
    assert context.history.labels == ("", "Move Curve")
    delta = context.document.curves[0].control_points - line_doc.curves[0].control_points
    np.testing.assert_allclose(delta, [(10, 0)] * 7)
    assert context.document.curves[0].left == line_doc.curves[0].left


def test_dragging_a_handle_of_a_smooth_anchor_turns_the_other_and_alt_breaks_it():
    control = [(10, 50), (20, 50), (40, 40), (50, 40), (60, 40), (80, 50), (90, 50)]  # smooth at 3
    document = Document(100, 100, (DiffusionCurve(control),))
    context = make_context(document)
    context.selection = by_index(context.document, curves=[0])
    tool = SelectTool(context)
    drag(tool, [(60, 40), (60, 50)])  # handle 4 down by 10
    points = context.document.curves[0].control_points
    np.testing.assert_allclose(points[4], (60, 50))
    np.testing.assert_allclose(points[2], (50 - 10 / np.sqrt(2), 40 - 10 / np.sqrt(2)))  # opposite, length 10
    assert context.history.labels[-1] == "Move Handle"
    context.history.undo()
    drag(tool, [(60, 40), (60, 50)], "alt")
    np.testing.assert_allclose(context.document.curves[0].control_points[2], (40, 40))


def test_a_click_without_movement_records_nothing(line_doc):
    context = make_context(line_doc)
    tool = SelectTool(context)
    click(tool, 30, 50)
    tool.press(event(50, 50))
    tool.move(event(50.5, 50.5))  # under the drag threshold
    tool.release(event(50.5, 50.5))
    assert context.history.index == 0 and context.document is line_doc
    assert context.selection == by_index(context.document, control_points=[(0, 3)])


def test_a_drag_back_to_its_start_records_nothing(line_doc):
    context = make_context(line_doc)
    tool = SelectTool(context)
    drag(tool, [(30, 50), (45, 60), (30, 50)])
    assert context.history.index == 0 and context.document == line_doc


def test_rubber_band_selects_exactly_the_points_inside():
    context = make_context(points_doc())
    tool = SelectTool(context)
    drag(tool, [(5, 5), (20, 20), (50, 40)])  # holds (10, 10), (30, 30), (45, 20)
    assert context.selection == by_index(context.document, points=[0, 1, 2])
    overlay = tool.overlay()
    assert not any(isinstance(p, Rectangle) for p in overlay)
    drag(tool, [(85, 10), (95, 20)], "shift")
    assert context.selection == by_index(context.document, points=[0, 1, 2, 4])
    drag(tool, [(60, 60), (80, 80)])
    assert context.selection == by_index(context.document, points=[3])
    click(tool, 50, 90)  # empty canvas
    assert context.selection.empty and context.history.index == 0


def test_rubber_band_takes_whole_curves_and_nodes_of_shown_curves(line_doc):
    other = line_curve((10, 90), (20, 90), (30, 90))
    context = make_context(Document(100, 100, (line_doc.curves[0], other)))
    tool = SelectTool(context)
    tool.press(event(5, 80))
    tool.move(event(40, 95))
    assert any(isinstance(p, Rectangle) for p in tool.overlay())
    tool.release(event(40, 95))
    assert context.selection == by_index(context.document, curves=[1])
    context.selection = by_index(context.document, curves=[0])
    drag(tool, [(45, 40), (85, 60)])  # around anchors 3 and 6 (and handles 4, 5) of the shown curve
    assert context.selection == by_index(context.document, control_points=[(0, 3), (0, 4), (0, 5), (0, 6)])


def test_delete_removes_the_selection_as_one_step():
    document = points_doc().with_curves([line_curve(), line_curve((10, 90), (20, 90), (30, 90))])
    context = make_context(document)
    tool = SelectTool(context)
    click(tool, 30, 50)  # curve 0
    click(tool, 10, 10, "shift")  # point 0
    click(tool, 70, 70, "shift")  # point 3
    assert context.selection == by_index(context.document, curves=[0], points=[0, 3])
    assert tool.key("Delete")
    assert context.history.labels == ("", "Delete")
    after = context.document
    assert after.curves == (document.curves[1],)
    assert after.points == tuple(document.points[i] for i in (1, 2, 4))
    assert context.selection.empty and not tool.key("Delete")
    context.history.undo()
    assert context.document == document


def test_deleting_an_inner_anchor_joins_its_pieces(line_doc):
    context = make_context(line_doc)
    context.selection = by_index(context.document, control_points=[(0, 3)])
    assert SelectTool(context).key("BackSpace")
    assert context.history.labels == ("", "Delete Anchor")
    curve = context.document.curves[0]
    np.testing.assert_allclose(curve.control_points, [(20, 50), (30, 50), (70, 50), (80, 50)])
    assert curve.left[0].position == pytest.approx(0.25)  # the stop keeps its place at x = 35


def test_double_click_on_a_curve_adds_an_anchor_without_changing_its_shape():
    document = Document(100, 100, (line_curve((10, 50), (50, 50), (90, 50)),))  # s = 1.5 at x = 70
    context = make_context(document)
    tool = SelectTool(context)
    click(tool, 70, 50)
    click(tool, 70, 50, clicks=2)
    assert context.history.labels == ("", "Add Anchor")
    curve = context.document.curves[0]
    assert curve.piece_count == 3
    np.testing.assert_allclose(curve.control_points[6], (70, 50))
    assert context.selection == by_index(context.document, control_points=[(0, 6)])
    s = np.linspace(0, 2, 17)
    split = np.select([s <= 1, s <= 1.5], [s, 1 + (s - 1) / 0.5], 2 + (s - 1.5) / 0.5)
    np.testing.assert_allclose(curve.point_at(split), document.curves[0].point_at(s), atol=1e-12)


def test_select_tool_drags_stops_of_the_selected_curve(line_doc):
    context = make_context(line_doc)
    tool = SelectTool(context)
    click(tool, 30, 50)
    drag(tool, [(50, 58), (20, 58)])  # the right stop (s = 1) to the start
    assert context.history.labels == ("", "Move Stop")
    assert context.document.curves[0].right[0].position == 0.0


def test_arrow_keys_nudge_and_escape_clears_the_selection():
    context = make_context(points_doc())
    tool = SelectTool(context)
    click(tool, 10, 10)
    assert tool.key("Right", frozenset({"shift"}))
    assert context.document.points[0].position == (20.0, 10.0)
    assert context.history.labels == ("", "Move Point")
    assert tool.key("Escape") and context.selection.empty
    assert not tool.key("Escape")


def test_hit_tolerance_is_in_screen_pixels(line_doc):
    context = make_context(line_doc, zoom=4.0)
    tool = SelectTool(context)
    click(tool, 30, 53)  # 3 document pixels = 12 screen pixels away: a miss
    assert context.selection.empty
    click(tool, 30, 51)  # 4 screen pixels: a hit
    assert context.selection == by_index(context.document, curves=[0])


def test_selection_drops_indices_an_undo_takes_away():
    context = make_context(points_doc())
    context.options.brush_mode = "glow"
    click(BrushTool(context), 50, 50)  # a sixth point
    context.selection = by_index(context.document, points=[5, 0])
    context.history.undo()
    assert context.selection == by_index(context.document, points=[0])


# -- brush ----------------------------------------------------------------------------------------
def test_a_brush_stroke_paints_evenly_spaced_dabs_as_one_step():
    context = make_context(Document(100, 100))
    options = context.options
    options.brush_color, options.brush_radius, options.brush_amplitude, options.brush_spacing = BLUE, 7.0, 0.25, 10.0
    options.brush_mode = "glow"
    brush = BrushTool(context)
    drag(brush, [(10, 10), (13, 10), (27, 10), (27, 10), (50, 10), (50, 25)])
    assert context.history.labels == ("", "Glow Stroke")
    points = context.document.points
    expected = [(10, 10), (20, 10), (30, 10), (40, 10), (50, 10), (50, 20)]
    np.testing.assert_allclose([p.position for p in points], expected, atol=1e-9)
    assert {(p.radius, p.color, p.amplitude) for p in points} == {(7.0, BLUE, 0.25)}
    outline = brush.overlay()
    assert len(outline) == 1 and isinstance(outline[0], Circle) and outline[0].radius == 7.0
    assert outline[0].centre == (50.0, 25.0)


def test_a_brush_click_paints_one_dab():
    context = make_context(Document(100, 100))
    context.options.brush_mode = "glow"
    click(BrushTool(context), 40, 60)
    assert [p.position for p in context.document.points] == [(40.0, 60.0)]
    assert context.history.labels == ("", "Glow Stroke")


def test_paint_is_the_brush_s_default_mode():
    context = make_context(Document(100, 100))
    click(BrushTool(context), 40, 60)
    assert len(context.document.layers) == 2 and context.document.layers[1].mask.points
    assert context.history.labels == ("", "Paint Stroke")


def test_glow_on_a_clear_layer_paints_and_glows_elsewhere():
    from fmr_editor.model import layer_edits

    picture = Document(100, 100, [line_curve()])
    clear = layer_edits.add_layer(picture)  # empty, above the bottom layer: no picture to add light to
    bottom = Document(100, 100)  # the bottom layer starts opaque, as before
    drawn = layer_edits.add_layer(picture, Layer(curves=(line_curve(),)))
    for document, paints in ((clear, True), (bottom, False), (drawn, False)):
        context = make_context(document)
        context.options.brush_mode, context.options.brush_color = "glow", BLUE
        click(BrushTool(context), 40, 60)
        after = context.document
        if paints:
            assert context.history.labels == ("", "Paint Stroke")
            assert len(after.layers) == 3 and after.layers[1].empty
            assert layer_edits.fill_color(after.layers[2]) == BLUE and len(after.layers[2].mask.points) == 1
        else:
            assert context.history.labels == ("", "Glow Stroke")
            assert len(after.layers) == len(document.layers) and len(after.layer.points) == 1


def test_in_glow_mode_alt_erases_the_layers_points_under_the_stroke():
    context = make_context(Document(100, 100))
    context.options.brush_mode, context.options.brush_radius = "glow", 5.0
    brush = BrushTool(context)
    for x in (20, 50, 80):
        click(brush, x, 50)
    drag(brush, [(45, 30), (55, 70)], "alt")  # passes within a radius of the middle dab alone
    assert [p.position for p in context.document.points] == [(20.0, 50.0), (80.0, 50.0)]
    assert context.history.labels == ("",) + ("Glow Stroke",) * 3 + ("Erase Points",)
    drag(brush, [(45, 90), (55, 95)], "alt")  # meets no dab: no step
    assert len(context.history.labels) == 5
    context.options.brush_mode = "paint"  # Paint: Alt paints as ever (its dabs are a fill layer's mask)
    click(brush, 30, 30, "alt")
    assert context.history.labels[-1] == "Paint Stroke"


def test_a_stroke_that_reaches_no_canvas_pixel_or_erases_nothing_makes_no_step():
    from fmr_editor.model import layer_edits

    for mode in ("paint", "glow"):
        context = make_context(Document(100, 100))
        context.options.brush_mode, context.options.brush_radius = mode, 5.0
        brush, blank = BrushTool(context), context.document
        click(brush, -16, 50)  # 3.2 radii left of the canvas: its Gaussian is below exp(-9) there
        drag(brush, [(120, -20), (130, 120)])  # every dab 4 radii or more to the right
        assert context.history.labels == ("",) and context.document is blank
        click(brush, -14, 50)  # 2.8 radii: it reaches the canvas
        assert len(context.history.labels) == 2
    document = layer_edits.select_layer(layer_edits.add_mask(Document(100, 100)), 0, mask=True)
    context = make_context(document)
    brush = BrushTool(context)
    drag(brush, [(10, 10), (20, 10)], "alt")  # erasing a mask with no dabs
    assert context.history.labels == ("",)


def test_on_a_mask_light_dabs_add_dark_dabs_subtract_and_alt_erases():
    from fmr_editor.model import layer_edits

    document = layer_edits.select_layer(layer_edits.add_mask(Document(100, 100)), 0, mask=True)
    context = make_context(document)
    options = context.options
    options.brush_amplitude, options.brush_spacing, options.brush_radius = 0.5, 10.0, 6.0
    brush = BrushTool(context)
    options.brush_color = (0.9, 0.8, 0.7)
    drag(brush, [(10, 10), (30, 10)])
    options.brush_color = (0.1, 0.0, 0.2)
    drag(brush, [(10, 50), (30, 50)])
    mask = context.document.layer.mask
    assert context.document.layer.points == ()  # the layer itself is untouched
    assert [(p.color, p.amplitude) for p in mask.points] == [((1.0, 1.0, 1.0), 0.5)] * 3 + [((1.0, 1.0, 1.0), -0.5)] * 3
    drag(brush, [(12, 48), (22, 48)], "alt")  # erases the dabs within the radius of its path
    assert [p.position for p in context.document.layer.mask.points] == [(10, 10), (20, 10), (30, 10), (30, 50)]
    assert context.history.labels == ("", "Paint Mask", "Paint Mask", "Erase Mask")


def test_paint_mode_dabs_go_into_one_fill_layer_above_the_active_layer():
    from fmr_editor.model import layer_edits

    context = make_context(Document(100, 100))
    options = context.options
    options.brush_mode, options.brush_color, options.brush_amplitude = "paint", BLUE, 0.8
    brush = BrushTool(context)
    drag(brush, [(10, 10), (30, 10)])
    drag(brush, [(10, 20), (30, 20)])
    document = context.document
    assert len(document.layers) == 2 and document.active == 0 and document.layers[0].points == ()
    fill = document.layers[1]
    assert layer_edits.fill_color(fill) == BLUE and fill.mask.base == 0.0 and len(fill.mask.points) == 6
    assert {(p.color, p.amplitude) for p in fill.mask.points} == {((1.0, 1.0, 1.0), 0.8)}
    options.brush_color = RED  # another colour: another fill layer, over the first, as paint goes on
    click(brush, 50, 50)
    click(brush, 55, 50)  # the same colour again: the same layer
    assert [layer_edits.fill_color(layer) for layer in context.document.layers[1:]] == [BLUE, RED]
    options.brush_color = BLUE  # blue over the red: a third fill layer on top
    click(brush, 60, 50)
    assert [layer_edits.fill_color(layer) for layer in context.document.layers[1:]] == [BLUE, RED, BLUE]
    assert context.document.active == 0 and len(context.document.layers[2].mask.points) == 2
    assert context.history.labels == ("",) + ("Paint Stroke",) * 5


# -- escape during any drag ----------------------------------------------------------------------
def _select_curve_then_drag(context):
    tool = SelectTool(context)
    click(tool, 30, 50)
    drag(tool, [(50, 50), (60, 70)], release=False)
    return tool


def _drag_curve(context):
    tool = SelectTool(context)
    drag(tool, [(30, 50), (60, 70)], release=False)
    return tool


def _drag_stop(context):
    tool = StopsTool(context)
    drag(tool, [(35, 42), (70, 42)], release=False)
    return tool


def _add_stop_and_drag(context):
    tool = StopsTool(context)
    drag(tool, [(30, 56), (70, 56)], release=False)
    return tool


def _paint(context):
    tool = BrushTool(context)
    drag(tool, [(10, 10), (60, 60), (90, 20)], release=False)
    return tool


def _drag_point(context):
    tool = SelectTool(context)
    drag(tool, [(10, 90), (40, 40)], release=False)
    return tool


@pytest.mark.parametrize("gesture", [_select_curve_then_drag, _drag_curve, _drag_stop, _add_stop_and_drag,
                                     _paint, _drag_point])
def test_escape_during_a_drag_restores_the_document_and_leaves_the_history(line_doc, gesture):
    document = line_doc.with_points([DiffusionPoint((10, 90), 5.0, RED)])
    context = make_context(document)
    seen = []
    context.history.subscribe(lambda before, after: seen.append(after))
    tool = gesture(context)
    assert context.document != document, "the drag shows its edit while it lasts"
    assert tool.key("Escape")
    assert context.document is document and seen[-1] is document
    assert context.history.labels == ("",) and not context.history.can_redo
    tool.release(event(90, 20))  # the button comes up after Esc: nothing more happens
    tool.move(event(10, 10))
    assert context.document is document and context.history.index == 0


# -- eyedropper -----------------------------------------------------------------------------------
def test_eyedropper_sets_the_colour_from_the_sampler_and_never_the_document(line_doc):
    context = make_context(line_doc, sample=lambda x, y: (x / 100, y / 100, 0.5))
    tool = EyedropperTool(context)
    click(tool, 30, 40)
    assert context.options.color == (0.3, 0.4, 0.5)
    click(tool, 60, 10, "alt")
    assert context.options.secondary_color == (0.6, 0.1, 0.5) and context.options.color == (0.3, 0.4, 0.5)
    drag(tool, [(10, 10), (90, 90)], release=False)
    assert context.options.color == (0.9, 0.9, 0.5)
    (sample,) = [p for p in tool.overlay() if isinstance(p, Markers) and p.kind == "sample"]
    np.testing.assert_allclose(sample.positions, [(90, 90)])
    np.testing.assert_allclose(sample.colors, [(0.9, 0.9, 0.5)])
    assert tool.key("Escape")
    assert context.options.color == (0.3, 0.4, 0.5)
    assert context.document is line_doc and context.history.index == 0


# -- registry and events --------------------------------------------------------------------------
def test_every_tool_has_a_unique_name_and_shortcut():
    context = make_context(Document(10, 10))
    tools = create_tools(context)
    assert list(tools) == [cls.name for cls in TOOLS] == ["select", "pen", "stops", "brush", "eyedropper", "lasso",
                                                          "clone"]
    assert len({cls.shortcut for cls in TOOLS}) == len(TOOLS)
    assert all(tool.context is context and tool.overlay() == [] for tool in tools.values())


def test_pointer_events_reject_unknown_buttons_and_modifiers():
    with pytest.raises(ValueError):
        PointerEvent((0, 0), "thumb")
    with pytest.raises(ValueError):
        PointerEvent((0, 0), modifiers=frozenset({"meta"}))
    assert PointerEvent((1, 2), modifiers={"shift"}).shift


def test_pen_pressing_the_last_anchor_again_pulls_out_its_handle_and_adds_no_piece():
    context = make_context(Document(100, 100))
    pen = PenTool(context)
    click(pen, 10, 10)
    click(pen, 50, 10)
    click(pen, 51, 11)  # a second click on the last anchor: no zero-length piece
    drag(pen, [(50, 10), (60, 30)])  # pulls its outgoing handle out
    click(pen, 90, 10)
    pen.finish()
    points = context.document.curves[0].control_points
    assert context.document.curves[0].piece_count == 2
    np.testing.assert_allclose(points[[2, 4]], [(50 - 40 / 3, 10), (60, 30)])  # in side stays a corner


def test_the_ends_of_a_closed_curve_move_together():
    context = make_context(Document(100, 100))
    pen = PenTool(context)
    for x, y in [(10, 10), (60, 10), (60, 60), (10, 10)]:
        click(pen, x, y)
    before = context.document.curves[0].control_points
    context.selection = by_index(context.document, control_points=[(0, 0)])
    drag(SelectTool(context), [(10, 10), (20, 5)])
    points = context.document.curves[0].control_points
    np.testing.assert_allclose(points[[0, -1]], [(20, 5), (20, 5)])
    np.testing.assert_allclose(points[[1, -2]] - before[[1, -2]], [(10, -5), (10, -5)])
    np.testing.assert_array_equal(points[2:-2], before[2:-2])
    assert context.history.labels == ("", "Draw Curve", "Move Anchor")


def test_select_overlay_shows_the_selected_curve_with_nodes_and_stops_on_their_sides(line_doc):
    context = make_context(line_doc)
    tool = SelectTool(context)
    click(tool, 30, 50)
    click(tool, 50, 50)  # the middle anchor
    marks = {p.kind: p for p in tool.overlay() if isinstance(p, Markers)}
    np.testing.assert_allclose(marks["anchor"].positions, [(20, 50), (50, 50), (80, 50)])
    assert marks["anchor"].selected.tolist() == [False, True, False]
    assert len(marks["handle"].positions) == 4 and not marks["handle"].selected.any()
    # left stop (red, s = 0.5) above the line, right stop (blue, s = 1) below: 8 screen pixels off
    np.testing.assert_allclose(marks["stop"].positions, [(35, 42), (50, 58)])
    np.testing.assert_allclose(marks["stop"].colors, [RED, BLUE])
    context.zoom = 2.0
    np.testing.assert_allclose(
        [p for p in tool.overlay() if isinstance(p, Markers) and p.kind == "stop"][0].positions, [(35, 46), (50, 54)]
    )


def test_stops_tool_shows_where_a_click_would_add_a_stop():
    context = make_context(Document(100, 100, (line_curve(),)))
    context.options.color = GREEN
    tool = StopsTool(context)
    tool.move(event(65, 53, button="none"))  # below a rightward line: its right side
    (ghost,) = [p for p in tool.overlay() if isinstance(p, Markers)]
    np.testing.assert_allclose(ghost.positions, [(65, 58)])
    np.testing.assert_allclose(ghost.colors, [GREEN])
    tool.move(event(65, 80, button="none"))
    assert not any(isinstance(p, Markers) for p in tool.overlay())


def test_escape_puts_the_selection_back_with_the_document():
    stops = (ColorStop(0.5, RED), ColorStop(1.0, GREEN))
    document = Document(100, 100, (line_curve(left=stops),))
    context = make_context(document)
    tool = StopsTool(context)
    click(tool, 35, 42)  # select the red stop
    drag(tool, [(35, 42), (70, 42)], release=False)  # past the green one: the selection follows it
    assert context.selection == by_index(context.document, stops=[(0, "left", 1)])
    tool.key("Escape")
    assert context.selection == by_index(context.document, stops=[(0, "left", 0)]) and context.document is document
    drag(tool, [(65, 56), (70, 56)], release=False)  # a new stop on the right side
    assert context.selection == by_index(context.document, stops=[(0, "right", 0)])
    tool.key("Escape")
    assert context.selection == by_index(context.document, stops=[(0, "left", 0)]) and context.document is document


def test_the_stops_tool_deletes_only_stops(line_doc):
    context = make_context(line_doc)
    context.selection = by_index(context.document, curves=[0], stops=[(0, "right", 0)])
    assert StopsTool(context).key("Delete")
    assert context.document.curves[0].right == () and len(context.document.curves) == 1
    assert context.history.labels == ("", "Delete Stop")
