"""Discretisation into straight segments (``fmr_editor.engine.geometry``).

Checks
------
* ``flatten_curve``: the polyline stays within ``tolerance`` of the curve, no
  segment is longer than ``max_length``, it runs from the curve's first to its
  last point, colour-stop positions are vertices, and each segment's colour
  data are the mean and jump of the two sides at its midpoint parameter.
* ``clip_to_canvas``: clipped parts lie in the canvas and have exactly the
  length of the segment/rectangle intersection (computed with shapely); parts
  running along the canvas edge are dropped.
* ``canvas_border``: a closed chain of length ``2(w + h)`` with the canvas on
  its left (docs/design.md section 1: with y down the left normal is ``(t_y, -t_x)``).
* ``cut_at_cells``: every piece lies in one lattice cell, lengths and colours
  are preserved, and the number of pieces matches the lattice lines crossed.
* ``boundary_segments`` puts curve segments first and the border last.

References are computed independently: brute-force point-to-polyline
distances in numpy, hand-written linear interpolation, shapely intersections.
"""

from __future__ import annotations

import numpy as np
import pytest
import shapely
from shapes import circle_points, straight_chain, uniform_curve

from fmr_editor.engine.geometry.discretise import (
    boundary_segments,
    canvas_border,
    clip_to_canvas,
    curve_colors,
    curve_segments,
    cut_at_cells,
)
from fmr_editor.engine.geometry.flatten import (
    _max_speed,
    flatten_curve,
    flatten_curve_reference,
    flatten_curves,
    stop_colors,
)
from fmr_editor.engine.geometry.segments import Segments
from fmr_editor.model import ColorStop, DiffusionCurve, Document

SAMPLES_PER_PIECE = 2000


# --- helpers ----------------------------------------------------------------------------------


def make_segments(p, q, jump=None, mean=None) -> Segments:
    """Curve segments from ``p`` to ``q`` with the given (or zero) colour data."""
    p, q = np.asarray(p, float).reshape(-1, 2), np.asarray(q, float).reshape(-1, 2)
    n = len(p)
    jump = np.zeros((n, 3)) if jump is None else np.asarray(jump, float)
    mean = np.zeros((n, 3)) if mean is None else np.asarray(mean, float)
    return Segments(p, q, jump, mean, np.zeros(n, bool), np.zeros((n, 3)))


def labelled_segments(p, q) -> Segments:
    """Segments whose jump ``(i, -i, 0.5)`` and mean ``(0.25 i, 1, -i)`` identify segment ``i``."""
    i = np.arange(len(p), dtype=float)
    jump = np.column_stack([i, -i, np.full_like(i, 0.5)])
    mean = np.column_stack([0.25 * i, np.ones_like(i), -i])
    return make_segments(p, q, jump, mean)


def point_to_polyline_distance(points: np.ndarray, p: np.ndarray, q: np.ndarray) -> np.ndarray:
    """Distance from each of ``points`` to the nearest of the segments ``p -> q`` (brute force)."""
    best = np.full(len(points), np.inf)
    for start in range(0, len(p), 64):
        a, b = p[start : start + 64], q[start : start + 64]
        d = b - a
        w = points[:, None, :] - a[None, :, :]
        t = np.clip((w * d).sum(-1) / np.maximum((d * d).sum(-1), 1e-300), 0.0, 1.0)
        nearest = a[None] + t[..., None] * d[None]
        best = np.minimum(best, np.hypot(*(points[:, None, :] - nearest).transpose(2, 0, 1)).min(axis=1))
    return best


def random_curve(rng: np.random.Generator) -> DiffusionCurve:
    """A random chain of 1-3 cubic pieces with random stops on both sides."""
    k = int(rng.integers(1, 4))
    points = rng.uniform(0.0, 60.0, size=(3 * k + 1, 2))
    left = tuple(ColorStop(float(s), tuple(rng.uniform(0, 1, 3))) for s in rng.uniform(0, k, 3))
    right = tuple(ColorStop(float(s), tuple(rng.uniform(0, 1, 3))) for s in rng.uniform(0, k, 2))
    return DiffusionCurve(points, left=left, right=right)


def random_curves(seed: int, count: int = 6) -> list[DiffusionCurve]:
    rng = np.random.default_rng(seed)
    return [random_curve(rng) for _ in range(count)]


def dense_points(curve: DiffusionCurve) -> np.ndarray:
    return curve.point_at(np.linspace(0.0, curve.piece_count, SAMPLES_PER_PIECE * curve.piece_count + 1))


def lerp(stops: list[tuple[float, tuple]], s: float) -> np.ndarray:
    """Linear interpolation through sorted ``(position, colour)`` pairs, constant beyond the ends."""
    if s <= stops[0][0]:
        return np.array(stops[0][1], float)
    for (s0, c0), (s1, c1) in zip(stops[:-1], stops[1:]):
        if s <= s1:
            w = (s - s0) / (s1 - s0)
            return (1 - w) * np.array(c0, float) + w * np.array(c1, float)
    return np.array(stops[-1][1], float)


# --- flatten_curve ----------------------------------------------------------------------------


@pytest.mark.parametrize("tolerance", [0.02, 0.1, 0.5])
def test_flattened_polyline_stays_within_tolerance_of_the_curve(tolerance):
    for curve in random_curves(seed=11):
        seg = flatten_curve(curve, tolerance, max_length=1e6)
        distance = point_to_polyline_distance(dense_points(curve), seg.p, seg.q)
        assert distance.max() <= tolerance


@pytest.mark.parametrize("tolerance, max_length", [(5.0, 0.7), (2.0, 3.0), (0.05, 2.0)])
def test_no_flattened_segment_is_longer_than_max_length(tolerance, max_length):
    for curve in random_curves(seed=12):
        seg = flatten_curve(curve, tolerance, max_length)
        assert seg.lengths.max() <= max_length * (1 + 1e-12)


def test_max_length_holds_where_the_parametrisation_is_fast():
    curve = DiffusionCurve(np.array([[0.0, 0.0], [10.0, 0.0], [10.0, 0.0], [10.0, 0.0]]))
    seg = flatten_curve(curve, tolerance=1.0, max_length=2.0)
    assert seg.lengths.max() <= 2.0 * (1 + 1e-12)


def test_max_length_holds_on_a_uniformly_parametrised_chain():
    """Where speed is constant the control-polygon bound is exact, so the limit must hold."""
    curve = DiffusionCurve(straight_chain([(0.0, 0.0), (17.0, 0.0), (17.0, 9.5), (3.0, 30.0)]))
    for max_length in (0.7, 2.0, 6.0):
        seg = flatten_curve(curve, tolerance=10.0, max_length=max_length)
        assert seg.lengths.max() <= max_length * (1 + 1e-12)
        np.testing.assert_allclose(seg.lengths.sum(), 17.0 + 9.5 + np.hypot(14.0, 20.5), rtol=1e-12)


def test_polyline_is_connected_and_runs_from_start_to_end():
    for curve in random_curves(seed=13):
        seg = flatten_curve(curve, 0.1, 3.0)
        np.testing.assert_allclose(seg.p[0], curve.control_points[0], rtol=0, atol=1e-12)
        np.testing.assert_allclose(seg.q[-1], curve.control_points[-1], rtol=0, atol=1e-12)
        np.testing.assert_allclose(seg.q[:-1], seg.p[1:], rtol=0, atol=1e-9)
        assert not seg.on_border.any()
        np.testing.assert_array_equal(seg.flux, 0.0)


def test_colour_stop_positions_are_polyline_vertices():
    for curve in random_curves(seed=14):
        seg = flatten_curve(curve, 0.1, 3.0)
        vertices = np.vstack([seg.p, seg.q[-1:]])
        for stop in curve.left + curve.right:
            target = curve.point_at(np.array([stop.position]))[0]
            assert np.hypot(*(vertices - target).T).min() <= 1e-9, stop


def test_segment_colours_are_mean_and_jump_at_the_midpoint_parameter():
    # a straight chain with x strictly increasing: the parameter of a point is a function of x
    corners = np.array([[0.0, 0.0], [10.0, 5.0], [25.0, 5.0], [40.0, -10.0]])
    left = [(0.35, (1.0, 0.0, 0.2)), (1.5, (0.0, 1.0, 0.4)), (2.8, (0.5, 0.5, 1.0))]
    right = [(0.0, (0.2, 0.2, 0.2)), (1.25, (0.9, 0.1, 0.0)), (2.0, (0.0, 0.0, 0.6))]
    curve = DiffusionCurve(
        straight_chain(corners),
        left=tuple(ColorStop(s, c) for s, c in left),
        right=tuple(ColorStop(s, c) for s, c in right),
    )
    seg = flatten_curve(curve, 0.05, 1.5)
    s_mid = np.interp(seg.midpoints[:, 0], corners[:, 0], np.arange(4.0))
    expected_left = np.array([lerp(left, s) for s in s_mid])
    expected_right = np.array([lerp(right, s) for s in s_mid])
    np.testing.assert_allclose(seg.jump, expected_left - expected_right, rtol=0, atol=1e-12)
    np.testing.assert_allclose(seg.mean, 0.5 * (expected_left + expected_right), rtol=0, atol=1e-12)


# --- clip_to_canvas ---------------------------------------------------------------------------

W, H = 64.0, 40.0


def random_segments(seed: int, count: int = 300) -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    low, high = [-0.5 * W, -0.5 * H], [1.5 * W, 1.5 * H]
    return rng.uniform(low, high, (count, 2)), rng.uniform(low, high, (count, 2))


def exact_clipped_length(p: np.ndarray, q: np.ndarray) -> float:
    return shapely.LineString([p, q]).intersection(shapely.box(0.0, 0.0, W, H)).length


def test_clipped_end_points_lie_in_the_canvas():
    clipped = clip_to_canvas(make_segments(*random_segments(seed=21)), W, H)
    assert len(clipped) > 0
    for points in (clipped.p, clipped.q):
        assert (points >= -1e-9).all()
        assert (points[:, 0] <= W + 1e-9).all() and (points[:, 1] <= H + 1e-9).all()


def test_clipped_length_equals_the_exact_intersection():
    p, q = random_segments(seed=22)
    clipped = clip_to_canvas(labelled_segments(p, q), W, H)
    expected = np.array([exact_clipped_length(a, b) for a, b in zip(p, q)])
    np.testing.assert_allclose(clipped.lengths.sum(), expected.sum(), rtol=1e-12)
    # per segment, identified by its label; colours travel with the clipped part
    owner = np.rint(clipped.jump[:, 0]).astype(int)
    assert len(np.unique(owner)) == len(owner), "a straight segment clips to at most one part"
    np.testing.assert_allclose(clipped.lengths, expected[owner], rtol=1e-9, atol=1e-9)
    np.testing.assert_array_equal(np.flatnonzero(expected > 1e-9), np.sort(owner))
    original = labelled_segments(p, q)
    np.testing.assert_array_equal(clipped.jump, original.jump[owner])
    np.testing.assert_array_equal(clipped.mean, original.mean[owner])


def test_clipped_part_keeps_the_direction_and_line_of_its_segment():
    p, q = random_segments(seed=23)
    clipped = clip_to_canvas(labelled_segments(p, q), W, H)
    owner = np.rint(clipped.jump[:, 0]).astype(int)
    d = q[owner] - p[owner]
    piece = clipped.q - clipped.p
    assert ((piece * d).sum(axis=1) > 0).all()
    for points in (clipped.p, clipped.q):
        w = points - p[owner]
        cross = d[:, 0] * w[:, 1] - d[:, 1] * w[:, 0]
        assert np.abs(cross / np.hypot(*d.T)).max() <= 1e-9


def test_segments_entirely_outside_vanish():
    p = [[-10.0, 5.0], [70.0, -3.0], [10.0, -0.5], [20.0, 41.0], [-10.0, 5.0], [60.0, 50.0]]
    q = [[-1.0, 30.0], [90.0, 60.0], [50.0, -0.5], [30.0, 45.0], [5.0, -10.0], [70.0, 35.0]]
    assert len(clip_to_canvas(make_segments(p, q), W, H)) == 0


@pytest.mark.parametrize(
    "p, q",
    [
        ((0.0, 10.0), (0.0, 50.0)),  # left edge (partly outside)
        ((0.0, 10.0), (0.0, 30.0)),  # left edge, inside
        ((W, 5.0), (W, 30.0)),  # right edge
        ((3.0, 0.0), (40.0, 0.0)),  # top edge
        ((50.0, H), (-8.0, H)),  # bottom edge, reversed, partly outside
    ],
)
def test_parts_along_the_canvas_edge_are_dropped(p, q):
    assert len(clip_to_canvas(make_segments(p, q), W, H)) == 0


def test_segments_near_or_touching_the_edge_are_kept():
    p = [[0.5, 10.0], [0.0, 10.0]]
    q = [[0.5, 30.0], [5.0, 35.0]]
    clipped = clip_to_canvas(make_segments(p, q), W, H)
    np.testing.assert_allclose(np.sort(clipped.lengths), np.sort([20.0, np.hypot(5.0, 25.0)]), rtol=1e-12)


# --- canvas_border ----------------------------------------------------------------------------


@pytest.mark.parametrize("width, height, spacing", [(64, 40, 1.0), (37, 23, 4.0), (10, 10, 3.0), (5, 200, 7.5)])
def test_canvas_border_is_closed_with_the_canvas_on_its_left(width, height, spacing):
    border = canvas_border(width, height, spacing)
    assert border.on_border.all()
    np.testing.assert_allclose(border.q, np.roll(border.p, -1, axis=0), rtol=0, atol=1e-12)
    np.testing.assert_allclose(border.lengths.sum(), 2 * (width + height), rtol=1e-12)
    assert border.lengths.max() <= spacing * (1 + 1e-12)
    # every vertex is on the canvas edge
    on_edge = np.isclose(border.p[:, 0], 0) | np.isclose(border.p[:, 0], width)
    on_edge |= np.isclose(border.p[:, 1], 0) | np.isclose(border.p[:, 1], height)
    assert on_edge.all()
    # left normal n = (t_y, -t_x) points into the canvas
    t = (border.q - border.p) / border.lengths[:, None]
    inside = border.midpoints + 0.01 * np.column_stack([t[:, 1], -t[:, 0]])
    assert ((inside[:, 0] > 0) & (inside[:, 0] < width) & (inside[:, 1] > 0) & (inside[:, 1] < height)).all()
    np.testing.assert_array_equal(border.jump, 0.0)
    np.testing.assert_array_equal(border.flux, 0.0)


# --- cut_at_cells -----------------------------------------------------------------------------


def lines_crossed(a: np.ndarray, b: np.ndarray, cell: float) -> int:
    """Lattice lines k * cell strictly between coordinates a and b (both axes)."""
    count = 0
    for axis in (0, 1):
        lo, hi = sorted((a[axis] / cell, b[axis] / cell))
        count += sum(1 for k in range(int(np.floor(lo)) - 1, int(np.ceil(hi)) + 2) if lo < k < hi)
    return count


def assert_each_piece_in_one_cell(seg: Segments, cell: float) -> None:
    corner = np.floor(seg.midpoints / cell) * cell
    for points in (seg.p, seg.q):
        assert (points >= corner - 1e-9).all()
        assert (points <= corner + cell + 1e-9).all()


@pytest.mark.parametrize("cell", [8.0, 5.3])
def test_cut_pieces_lie_in_one_cell_and_preserve_length_and_colours(cell):
    p, q = random_segments(seed=31, count=150)
    original = labelled_segments(p, q)
    cut = cut_at_cells(original, cell)
    assert_each_piece_in_one_cell(cut, cell)
    owner = np.rint(cut.jump[:, 0]).astype(int)
    np.testing.assert_array_equal(cut.jump, original.jump[owner])
    np.testing.assert_array_equal(cut.mean, original.mean[owner])
    np.testing.assert_array_equal(cut.on_border, original.on_border[owner])
    total = np.bincount(owner, weights=cut.lengths, minlength=len(p))
    np.testing.assert_allclose(total, original.lengths, rtol=1e-12)
    expected_pieces = [1 + lines_crossed(a, b, cell) for a, b in zip(p, q)]
    np.testing.assert_array_equal(np.bincount(owner, minlength=len(p)), expected_pieces)
    # each piece lies on its segment and points the same way
    d = q[owner] - p[owner]
    assert (((cut.q - cut.p) * d).sum(axis=1) > 0).all()
    for points in (cut.p, cut.q):
        w = points - p[owner]
        assert np.abs((d[:, 0] * w[:, 1] - d[:, 1] * w[:, 0]) / np.hypot(*d.T)).max() <= 1e-9


def test_cut_pieces_tile_their_segment_in_order():
    p, q = random_segments(seed=32, count=40)
    cut = cut_at_cells(labelled_segments(p, q), 8.0)
    owner = np.rint(cut.jump[:, 0]).astype(int)
    for i in range(len(p)):
        pieces = np.flatnonzero(owner == i)
        np.testing.assert_allclose(cut.p[pieces[0]], p[i], rtol=0, atol=1e-9)
        np.testing.assert_allclose(cut.q[pieces[-1]], q[i], rtol=0, atol=1e-9)
        np.testing.assert_allclose(cut.q[pieces[:-1]], cut.p[pieces[1:]], rtol=0, atol=1e-9)


def test_cutting_segments_on_lattice_lines():
    cell = 8.0
    p = [[8.0, 3.0], [16.0, 0.0], [0.0, 0.0], [3.0, 8.0]]
    q = [[24.0, 3.0], [16.0, 20.0], [8.0, 8.0], [5.0, 8.0]]
    cut = cut_at_cells(labelled_segments(p, q), cell)
    assert_each_piece_in_one_cell(cut, cell)
    owner = np.rint(cut.jump[:, 0]).astype(int)
    # split at x = 16; at y = 8 and 16; a cell diagonal and a piece on a lattice line stay whole
    np.testing.assert_array_equal(np.bincount(owner, minlength=4), [2, 3, 1, 1])
    np.testing.assert_allclose(np.sort(cut.lengths[owner == 1]), [4.0, 8.0, 8.0], rtol=1e-12)


def test_a_segment_passing_a_hair_beside_a_lattice_corner_leaves_no_sliver():
    """It crosses x = 8 and y = 8 2e-10 px apart: the sliver between would carry an unknown whose column of the
    system is nearly zero (issue 26: such a piece where a curve crossed the canvas centre).  A segment that short
    of its own stays whole."""
    from fmr_editor.engine.geometry.discretise import MIN_PIECE

    p = [[6.0, 6.0 + 2e-10], [0.5, 3.0], [8.0 - 1e-9, 5.0], [2.0, 8.0 - 5e-7]]
    q = [[10.0, 10.0 + 2e-10], [7.5, 3.0 + 1e-7], [8.0 + 1e-9, 5.0], [2.0 + 3.0, 8.0 + 3e-7]]
    original = labelled_segments(p, q)
    cut = cut_at_cells(original, 8.0)
    owner = np.rint(cut.jump[:, 0]).astype(int)
    np.testing.assert_array_equal(np.bincount(owner, minlength=4), [2, 1, 1, 2])  # the last crosses at a slant
    assert cut.lengths[owner != 2].min() > MIN_PIECE
    np.testing.assert_allclose(np.bincount(owner, weights=cut.lengths), original.lengths, rtol=1e-12)


# --- boundary_segments ------------------------------------------------------------------------


def test_boundary_segments_put_curves_first_then_the_border():
    width, height, cell = 64, 48, 8.0
    doc = Document(width, height, [uniform_curve(circle_points(40.0, 20.0, 30.0), 1.0, 0.25)])
    curves = curve_segments(doc)
    assembled = boundary_segments(curves, doc, cell)
    flags = assembled.on_border
    m = int((~flags).sum())
    assert 0 < m < len(assembled)
    np.testing.assert_array_equal(flags, np.arange(len(assembled)) >= m)
    assert_each_piece_in_one_cell(assembled, cell)
    curve_part, border_part = assembled.take(~flags), assembled.take(flags)
    np.testing.assert_allclose(curve_part.lengths.sum(), curves.lengths.sum(), rtol=1e-12)
    np.testing.assert_allclose(curve_part.jump, np.full((m, 3), 0.75), rtol=0, atol=1e-15)
    np.testing.assert_allclose(curve_part.mean, np.full((m, 3), 0.625), rtol=0, atol=1e-15)
    np.testing.assert_allclose(border_part.lengths.sum(), 2 * (width + height), rtol=1e-12)
    for points in (border_part.p, border_part.q):
        on_edge = np.isclose(points[:, 0], 0) | np.isclose(points[:, 0], width)
        on_edge |= np.isclose(points[:, 1], 0) | np.isclose(points[:, 1], height)
        assert on_edge.all()
    np.testing.assert_array_equal(border_part.jump, 0.0)
    np.testing.assert_array_equal(assembled.flux, 0.0)


def test_the_speed_bound_holds_for_pieces_taken_in_chunks():
    """``_max_speed`` takes pieces a chunk at a time (memory); any chunking gives the same bound, and the bound
    is at least the speed sampled finely and at most a hair above it."""
    pieces = np.random.default_rng(3).normal(0, 40, (50, 4, 2))
    bound = _max_speed(pieces)
    np.testing.assert_array_equal(_max_speed(pieces, chunk=7), bound)
    t = np.linspace(0, 1, 10_001)[:, None, None]
    d = 3 * np.diff(pieces, axis=1)
    speed = np.hypot(*((1 - t) ** 2 * d[:, 0] + 2 * (1 - t) * t * d[:, 1] + t**2 * d[:, 2]).T).max(axis=1)
    assert np.all(bound >= speed) and np.all(bound <= speed * (1 + 1e-3))


def test_curves_flattened_together_equal_each_flattened_alone():
    """``flatten_curves`` (every piece at once) against the plain one-curve-at-a-time reference, bit for bit:
    random curves with stops, a curve whose pieces have zero length, a stop on a sample, a curve twice."""
    curves = random_curves(seed=5, count=8)
    point = DiffusionCurve(np.zeros((7, 2)), left=(ColorStop(0.5, (1.0, 0.0, 0.0)),))
    on_sample = DiffusionCurve(straight_chain([(0.0, 0.0), (8.0, 0.0)]), right=(ColorStop(0.5, (0.2, 0.4, 0.6)),))
    curves = [curves[0], point, *curves[1:], on_sample, curves[0]]
    for tolerance, max_length in [(0.05, 2.0), (1.0, 0.5)]:
        together = flatten_curves(curves, tolerance, max_length)
        assert len(together) == len(curves)
        for curve, flat in zip(curves, together):
            alone = flatten_curve_reference(curve, tolerance, max_length)
            for name in ("p", "q", "jump", "mean", "on_border", "flux", "origin"):
                np.testing.assert_array_equal(getattr(flat, name), getattr(alone, name))
    assert flatten_curves([], 0.05, 2.0) == []
    assert len(flatten_curves([point], 0.05, 2.0)[0]) == 0


def test_stop_colours_of_many_curves_are_numpy_interp_of_each():
    """``stop_colors`` (every curve at once) against ``DiffusionCurve.left_colors_at`` (``numpy.interp``), bit for
    bit: samples before, between, on and beyond stops, two stops at one position, a curve without stops."""
    rng = np.random.default_rng(8)
    sides, owner, s = [], [], []
    for index, count in enumerate([3, 0, 1, 4, 2]):
        positions = np.sort(rng.uniform(0, 4, count))
        if count == 4:
            positions[2] = positions[1]  # a sharp change
        sides.append(tuple(ColorStop(float(x), tuple(rng.uniform(0, 1, 3))) for x in positions))
        samples = np.sort(np.r_[rng.uniform(-0.5, 4.5, 40), positions, 0.0, 4.0])
        owner.append(np.full(len(samples), index))
        s.append(samples)
    owner, s = np.concatenate(owner), np.concatenate(s)
    shuffled = rng.permutation(len(s))  # the samples in any order (recolouring reads segments as they lie)
    colours = np.empty((len(s), 3))
    colours[shuffled] = stop_colors(sides, owner[shuffled], s[shuffled])
    for index, side in enumerate(sides):
        curve = DiffusionCurve(straight_chain([(0.0, 0.0), (1.0, 0.0), (2.0, 0.0), (3.0, 0.0), (4.0, 0.0)]),
                               left=side)
        np.testing.assert_array_equal(colours[owner == index], curve.left_colors_at(s[owner == index]))


def test_recoloured_segments_take_the_colours_flattening_gives():
    curve = random_curves(seed=9, count=1)[0]
    flat = flatten_curve(curve, 0.05, 2.0)
    jump, mean = curve_colors(flat, curve)
    np.testing.assert_array_equal(jump, flat.jump)
    np.testing.assert_array_equal(mean, flat.mean)
