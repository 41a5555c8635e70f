"""The FMR against closed-form solutions of the diffusion problem (docs/design.md section 2)."""

from __future__ import annotations

import numpy as np
import pytest
from shapes import circle_points, straight_chain, uniform_curve

from fmr_editor.engine import Settings, build, evaluate_points
from fmr_editor.model import ColorStop, DiffusionCurve, Document

TOLERANCE = 1e-3


def grid(width: float, height: float, step: float) -> np.ndarray:
    xs, ys = np.meshgrid(np.arange(step / 2, width, step), np.arange(step / 2, height, step))
    return np.stack([xs.ravel(), ys.ravel()], axis=1)


@pytest.mark.parametrize("levels", [3, 5])
def test_closed_circle_gives_one_inside_and_zero_outside(levels):
    cx, cy, radius = 70.0, 60.0, 35.0
    doc = Document(140, 120, [uniform_curve(circle_points(cx, cy, radius), 1.0, 0.0)])
    rep = build(doc, Settings(levels=levels))
    points = grid(140, 120, 1.7)
    distance = np.hypot(points[:, 0] - cx, points[:, 1] - cy)
    far = np.abs(distance - radius) >= 3.0
    expected = (distance < radius).astype(float)
    u = evaluate_points(rep, points[far])
    assert np.abs(u - expected[far, None]).max() <= TOLERANCE


def test_sides_follow_the_walking_direction():
    """Reversing the curve swaps which side is the viewer's left."""
    doc = Document(100, 100, [uniform_curve(circle_points(50, 50, 30, inside_on_left=False), 1.0, 0.0)])
    u = evaluate_points(build(doc), np.array([[50.0, 50.0], [5.0, 5.0]]))
    np.testing.assert_allclose(u[:, 0], [0.0, 1.0], atol=TOLERANCE)


def test_closed_curve_carrying_a_harmonic_function_reproduces_it():
    cx, cy, radius = 64.0, 64.0, 40.0

    def harmonic(points: np.ndarray) -> np.ndarray:
        dx, dy = (points[:, 0] - cx) / radius, (points[:, 1] - cy) / radius
        return 0.5 + 0.25 * dx + 0.3 * (dx * dx - dy * dy) - 0.2 * dx * dy

    shape = DiffusionCurve(circle_points(cx, cy, radius))
    s = np.linspace(0.0, shape.piece_count, 4 * 256 + 1)
    values = harmonic(shape.point_at(s))
    left = tuple(ColorStop(pos, (v, v, v)) for pos, v in zip(s, values))
    curve = DiffusionCurve(shape.control_points, left=left, right=(ColorStop(0.0, (0.0,) * 3),))
    rep = build(Document(128, 128, [curve]))
    points = grid(128, 128, 1.3)
    distance = np.hypot(points[:, 0] - cx, points[:, 1] - cy)
    inside, outside = distance <= radius - 3.0, distance >= radius + 3.0
    u = evaluate_points(rep, points)[:, 0]
    assert np.abs(u[inside] - harmonic(points[inside])).max() <= TOLERANCE
    assert np.abs(u[outside]).max() <= TOLERANCE


def test_two_lines_across_a_reflecting_canvas_give_a_linear_ramp():
    width, height, a, b = 128, 100, 40.0, 90.0
    lines = [straight_chain([(x, -10.0), (x, 110.0)]) for x in (a, b)]
    doc = Document(width, height, [uniform_curve(lines[0], 1.0, 1.0), uniform_curve(lines[1], 0.0, 0.0)])
    rep = build(doc)
    points = grid(width, height, 1.1)
    keep = (np.abs(points[:, 0] - a) >= 3.0) & (np.abs(points[:, 0] - b) >= 3.0)
    expected = np.clip((b - points[keep, 0]) / (b - a), 0.0, 1.0)
    u = evaluate_points(rep, points[keep])
    assert np.abs(u - expected[:, None]).max() <= TOLERANCE


def test_empty_document_is_black():
    image_points = grid(64, 48, 4.0)
    u = evaluate_points(build(Document(64, 48)), image_points)
    assert np.abs(u).max() <= 1e-12


def test_error_next_to_the_canvas_edge_converges_with_border_spacing():
    """Half a pixel from the edge, halving the border segments cuts the ramp's error at least 3x."""
    width, height, a, b = 128, 100, 40.0, 90.0
    lines = [straight_chain([(x, -10.0), (x, 110.0)]) for x in (a, b)]
    doc = Document(width, height, [uniform_curve(lines[0], 1.0, 1.0), uniform_curve(lines[1], 0.0, 0.0)])
    xs = np.arange(44.0, 87.0, 0.37)
    points = np.stack([xs, np.full_like(xs, 0.5)], axis=1)
    errors = [
        np.abs(evaluate_points(build(doc, Settings(border_spacing=spacing)), points)[:, 0] - (b - xs) / (b - a)).max()
        for spacing in (4.0, 2.0, 1.0)
    ]
    assert errors[0] >= 3 * errors[1] >= 9 * errors[2]
    assert errors[2] <= TOLERANCE
