"""The document model: diffusion curves and the document (``fmr_editor.model``).

Checks
------
* ``DiffusionCurve`` validates its control points (3k+1 of them, k >= 1, all
  finite) and keeps a private read-only copy.
* Colour stops are sorted and clamped to ``[0, k]``; colours interpolate
  linearly between stops, are constant beyond the outermost ones, and a side
  without stops is black.
* ``point_at`` follows the cubic Bezier pieces in piece units.
* Equal curves compare and hash equal; ``Document`` validates its canvas size
  and ``with_curves`` leaves the original untouched.

Expected values come from the definitions (Bezier end points, straight-line
midpoints, hand-computed linear interpolation), never from the code itself.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from shapes import circle_points, straight_chain, uniform_curve

from fmr_editor.model import ColorStop, DiffusionCurve, Document

RED, GREEN, BLUE = (1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0)


def chain(k: int) -> np.ndarray:
    """``3k + 1`` distinct control points of a chain of ``k`` pieces."""
    return np.column_stack([np.arange(3 * k + 1, dtype=float), np.sin(np.arange(3 * k + 1))])


def lerp_reference(stops: list[tuple[float, tuple]], s: float) -> np.ndarray:
    """Piecewise-linear colour through sorted ``(position, colour)`` pairs, by hand."""
    if s <= stops[0][0]:
        return np.array(stops[0][1])
    if s >= stops[-1][0]:
        return np.array(stops[-1][1])
    for (s0, c0), (s1, c1) in zip(stops[:-1], stops[1:]):
        if s0 <= s <= s1:
            w = (s - s0) / (s1 - s0)
            return (1 - w) * np.array(c0) + w * np.array(c1)
    raise AssertionError("unreachable")


# --- control points ---------------------------------------------------------------------------


@pytest.mark.parametrize("count", [0, 1, 2, 3, 5, 6, 8, 9, 11])
def test_control_point_count_must_be_3k_plus_1(count):
    with pytest.raises(ValueError):
        DiffusionCurve(np.zeros((count, 2)) + np.arange(count)[:, None])


@pytest.mark.parametrize("count", [4, 7, 10, 13])
def test_control_point_counts_3k_plus_1_are_accepted(count):
    curve = DiffusionCurve(chain((count - 1) // 3))
    assert curve.piece_count == (count - 1) // 3
    assert curve.control_points.shape == (count, 2)


@pytest.mark.parametrize("shape", [(4,), (4, 3), (2, 4, 2)])
def test_control_points_must_be_an_n_by_2_array(shape):
    with pytest.raises(ValueError):
        DiffusionCurve(np.ones(shape))


@pytest.mark.parametrize("bad", [math.nan, math.inf, -math.inf])
def test_non_finite_control_points_are_rejected(bad):
    points = chain(2)
    points[3, 1] = bad
    with pytest.raises(ValueError):
        DiffusionCurve(points)


def test_curve_keeps_its_own_copy_of_the_control_points():
    points = chain(1)
    original = points.copy()
    curve = DiffusionCurve(points)
    points[:] = 99.0
    np.testing.assert_array_equal(curve.control_points, original)


def test_control_points_are_read_only():
    curve = DiffusionCurve(chain(1))
    with pytest.raises(ValueError):
        curve.control_points[0, 0] = 5.0
    with pytest.raises(ValueError):
        curve.control_points += 1.0


def test_curve_attributes_cannot_be_reassigned():
    curve = DiffusionCurve(chain(1))
    with pytest.raises(AttributeError):
        curve.left = ()  # frozen dataclass


# --- colour stops -----------------------------------------------------------------------------


def test_stops_are_sorted_and_clamped_to_the_piece_range():
    k = 2
    curve = DiffusionCurve(
        chain(k),
        left=(ColorStop(1.5, RED), ColorStop(-3.0, GREEN), ColorStop(0.5, BLUE), ColorStop(7.0, RED)),
        right=(ColorStop(2.5, BLUE), ColorStop(1.0, GREEN)),
    )
    assert [stop.position for stop in curve.left] == [0.0, 0.5, 1.5, float(k)]
    assert [stop.color for stop in curve.left] == [GREEN, BLUE, RED, RED]
    assert [stop.position for stop in curve.right] == [1.0, float(k)]
    assert [stop.color for stop in curve.right] == [GREEN, BLUE]


def test_stop_positions_end_up_in_the_piece_range_even_for_nan():
    try:
        curve = DiffusionCurve(chain(2), left=(ColorStop(math.nan, RED), ColorStop(1.0, BLUE)))
    except ValueError:
        return  # rejecting the stop is an acceptable answer too
    assert all(0.0 <= stop.position <= 2.0 for stop in curve.left)


def test_colours_interpolate_linearly_between_stops_and_are_constant_beyond():
    k = 3
    stops = [(0.4, (0.2, 0.9, 0.0)), (1.0, (1.0, 0.1, 0.5)), (2.2, (0.0, 0.5, 1.0))]
    curve = DiffusionCurve(chain(k), left=tuple(ColorStop(p, c) for p, c in stops))
    s = np.concatenate([np.linspace(0.0, k, 61), [0.4, 1.0, 2.2]])
    expected = np.array([lerp_reference(stops, value) for value in s])
    np.testing.assert_allclose(curve.left_colors_at(s), expected, rtol=0, atol=1e-12)
    # beyond the ends: exactly the end colours
    np.testing.assert_array_equal(curve.left_colors_at(np.array([0.0, 0.1])), [stops[0][1]] * 2)
    np.testing.assert_array_equal(curve.left_colors_at(np.array([2.5, 3.0])), [stops[-1][1]] * 2)


def test_colour_halfway_between_two_stops_is_their_average():
    curve = DiffusionCurve(chain(1), right=(ColorStop(0.2, RED), ColorStop(0.8, BLUE)))
    np.testing.assert_allclose(curve.right_colors_at(np.array([0.5])), [[0.5, 0.0, 0.5]], atol=1e-15)


def test_side_without_stops_is_black():
    curve = DiffusionCurve(chain(2), left=(ColorStop(1.0, RED),))
    s = np.linspace(0.0, 2.0, 9)
    np.testing.assert_array_equal(curve.right_colors_at(s), np.zeros((9, 3)))
    np.testing.assert_array_equal(curve.left_colors_at(s), np.tile(RED, (9, 1)))


# --- geometry ---------------------------------------------------------------------------------


def test_point_at_integer_positions_is_the_piece_end_points():
    points = circle_points(10.0, -4.0, 7.0)  # 4 pieces
    curve = DiffusionCurve(points)
    np.testing.assert_allclose(curve.point_at(np.arange(5.0)), points[::3], rtol=0, atol=1e-12)


def test_point_at_follows_the_bezier_formula():
    p0, p1, p2, p3 = np.array([[0.0, 0.0], [1.0, 3.0], [4.0, -2.0], [6.0, 1.0]])
    curve = DiffusionCurve(np.array([p0, p1, p2, p3]))
    for t in (0.1, 0.37, 0.5, 0.9):
        expected = (1 - t) ** 3 * p0 + 3 * (1 - t) ** 2 * t * p1 + 3 * (1 - t) * t**2 * p2 + t**3 * p3
        np.testing.assert_allclose(curve.point_at(np.array([t]))[0], expected, rtol=0, atol=1e-12)


def test_point_at_on_a_straight_chain_is_linear_in_each_piece():
    corners = [(0.0, 0.0), (10.0, 0.0), (10.0, 20.0), (-5.0, 12.0)]
    curve = DiffusionCurve(straight_chain(corners))
    corners = np.array(corners)
    midpoints = 0.5 * (corners[:-1] + corners[1:])
    np.testing.assert_allclose(curve.point_at(np.arange(3) + 0.5), midpoints, rtol=0, atol=1e-12)
    quarter = 0.75 * corners[1] + 0.25 * corners[2]
    np.testing.assert_allclose(curve.point_at(np.array([1.25]))[0], quarter, rtol=0, atol=1e-12)


# --- equality and hashing ---------------------------------------------------------------------


def make_curve(stop_position: float = 0.5) -> DiffusionCurve:
    return DiffusionCurve(
        chain(2),
        left=(ColorStop(stop_position, (0.1, 0.2, 0.3)), ColorStop(2.0, RED)),
        right=(ColorStop(0.0, BLUE),),
    )


def test_equal_curves_built_separately_compare_and_hash_equal():
    a, b = make_curve(), make_curve()
    assert a is not b
    assert a == b
    assert hash(a) == hash(b)
    assert len({a, b}) == 1


def test_colour_given_as_list_or_ints_equals_the_float_tuple():
    a = DiffusionCurve(chain(1), left=(ColorStop(0.0, [1, 0, 0]),))
    b = DiffusionCurve(chain(1), left=(ColorStop(0.0, RED),))
    assert a == b and hash(a) == hash(b)


def test_changed_stop_makes_curves_differ():
    assert make_curve(0.5) != make_curve(0.6)
    changed_colour = DiffusionCurve(
        chain(2),
        left=(ColorStop(0.5, (0.1, 0.2, 0.31)), ColorStop(2.0, RED)),
        right=(ColorStop(0.0, BLUE),),
    )
    assert make_curve() != changed_colour


def test_changed_control_point_or_swapped_sides_make_curves_differ():
    points = chain(2)
    points[4, 0] += 1e-9
    assert DiffusionCurve(points) != DiffusionCurve(chain(2))
    assert uniform_curve(chain(1), 1.0, 0.0) != uniform_curve(chain(1), 0.0, 1.0)


def test_curves_equal_up_to_signed_zero_hash_equal():
    points = chain(1)
    negated_zero = points.copy()
    negated_zero[0, 0] = -0.0  # e.g. the result of mirroring x -> -x
    a, b = DiffusionCurve(points), DiffusionCurve(negated_zero)
    assert a == b
    assert hash(a) == hash(b)


# --- document ---------------------------------------------------------------------------------


@pytest.mark.parametrize("width, height", [(0, 10), (10, 0), (-1, 10), (10, -1), (2.5, 10), (10, 2.5)])
def test_document_rejects_bad_canvas_sizes(width, height):
    with pytest.raises(ValueError):
        Document(width, height)


def test_document_rejects_infinite_size_with_value_error():
    with pytest.raises(ValueError):
        Document(math.inf, 10)


def test_document_accepts_whole_number_sizes_as_int():
    doc = Document(640.0, np.int64(480))
    assert (doc.width, doc.height) == (640, 480)
    assert type(doc.width) is int and type(doc.height) is int


def test_document_rejects_non_curve_items():
    with pytest.raises(TypeError):
        Document(10, 10, ["not a curve"])


def test_with_curves_returns_a_new_document_and_keeps_the_old():
    first = uniform_curve(chain(1), 1.0, 0.0)
    second = uniform_curve(circle_points(5.0, 5.0, 3.0), 0.5, 0.5)
    old = Document(32, 16, [first])
    new = old.with_curves([first, second])
    assert new is not old
    assert old.curves == (first,)
    assert new.curves == (first, second)
    assert isinstance(new.curves, tuple)
    assert (new.width, new.height) == (32, 16)


# --- stable ids --------------------------------------------------------------------------------


def _line(grey: float) -> DiffusionCurve:
    return uniform_curve(straight_chain([(8.0, 8.0), (40.0, 30.0)]), grey / 4, 0.0)


def test_items_get_distinct_ids_that_edits_keep_and_equality_ignores():
    from fmr_editor.model import DiffusionPoint, edits

    a, b = _line(1), _line(1)
    assert a.id != b.id and a == b and hash(a) == hash(b)  # the id is not part of the value
    dot = DiffusionPoint((1.0, 2.0), 3.0, (1.0, 0.0, 0.0))
    assert dot == DiffusionPoint((1.0, 2.0), 3.0, (1.0, 0.0, 0.0)) and dot.id != a.id
    doc = Document(64, 64, (a, b), (dot,))
    moved = edits.move_control_point(doc, b.id, 0, (5.0, 5.0))
    assert [c.id for c in moved.curves] == [a.id, b.id]
    assert np.array_equal(moved.curve(b.id).control_points[0], (5.0, 5.0))
    assert np.array_equal(moved.curve(a.id).control_points, a.control_points)  # not the equal twin
    assert edits.translate(doc, (1.0, 0.0), points=[dot.id]).points[0].id == dot.id


def test_ids_address_the_same_curve_after_others_are_removed_or_reordered():
    from fmr_editor.model import edits

    curves = [_line(k) for k in (1, 2, 3)]
    doc = Document(64, 64, tuple(curves))
    fewer = edits.remove_curves(doc, [curves[0].id])
    assert fewer.curve_index(curves[2].id) == 1 and fewer.curve(curves[2].id) is curves[2]
    reordered = doc.with_curves(reversed(doc.curves))
    recoloured = edits.set_stop_color(reordered, curves[1].id, "left", 0, (0.5, 0.5, 0.5))
    assert recoloured.curve(curves[1].id).left[0].color == (0.5, 0.5, 0.5)
    assert recoloured.curves[0] is curves[2] and recoloured.curves[2] is curves[0]
    with pytest.raises(KeyError):
        fewer.curve(curves[0].id)


def test_a_curve_added_twice_gets_a_new_id_for_its_second_place():
    curve = _line(1)
    doc = Document(64, 64, (curve, curve))
    assert doc.curves[0] is curve and doc.curves[1] == curve and doc.curves[1].id != curve.id


def test_ids_must_be_positive_whole_numbers():
    with pytest.raises(ValueError, match="id"):
        DiffusionCurve(_line(1).control_points, id=0)
    with pytest.raises(ValueError, match="id"):
        DiffusionCurve(_line(1).control_points, id=1.5)


def test_edits_the_document_cannot_take_are_refused_and_misuse_is_a_plain_error():
    """``EditRefused`` carries what a user asked for and cannot have; a wrong call stays a plain error."""
    from fmr_editor.model import EditRefused, edits, layer_edits
    from fmr_editor.model.clone import region_on_canvas

    line = DiffusionCurve(straight_chain([(10.0, 10.0), (50.0, 10.0)]), left=(ColorStop(0.0, (1, 0, 0)),))
    document = Document(64, 64, [line])
    refusals = [
        lambda: layer_edits.remove_layer(document),
        lambda: layer_edits.merge_down(document),
        lambda: layer_edits.invert_mask(document),
        lambda: edits.remove_anchors(document, line.id, [0]),
        lambda: region_on_canvas([(0, 0), (10, 10), (10, 0), (0, 10)], 64, 64),  # crosses itself
        lambda: region_on_canvas([(100, 100), (110, 100), (110, 110)], 64, 64),  # off the canvas
    ]
    for refuse in refusals:
        with pytest.raises(EditRefused):
            refuse()
    for misuse in (lambda: edits.set_stop_color(document, line.id, "up", 0, (0, 0, 0)),
                   lambda: edits.remove_anchors(document, line.id, [1])):
        with pytest.raises(ValueError) as raised:
            misuse()
        assert not isinstance(raised.value, EditRefused)
