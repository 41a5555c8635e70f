"""Curves with known geometry for tests."""

from __future__ import annotations

import numpy as np

from fmr_editor.model import ColorStop, DiffusionCurve

KAPPA = 4.0 / 3.0 * (np.sqrt(2.0) - 1.0)


def circle_points(cx: float, cy: float, radius: float, inside_on_left: bool = True) -> np.ndarray:
    """Four cubic pieces approximating a circle (13 control points).

    With y down, walking with the inside on the viewer's left means angles
    decreasing in document coordinates.
    """
    sign = -1.0 if inside_on_left else 1.0
    angles = sign * np.arange(5) * np.pi / 2
    points = []
    for a0, a1 in zip(angles[:-1], angles[1:]):
        p0 = np.array([np.cos(a0), np.sin(a0)])
        p3 = np.array([np.cos(a1), np.sin(a1)])
        d0 = sign * np.array([-np.sin(a0), np.cos(a0)])
        d1 = sign * np.array([-np.sin(a1), np.cos(a1)])
        points += [p0, p0 + KAPPA * d0, p3 - KAPPA * d1]
    points.append(points[0])
    return np.array([cx, cy]) + radius * np.array(points)


def straight_chain(points: list[tuple[float, float]]) -> np.ndarray:
    """A chain of straight cubic pieces through ``points``, linearly parametrised."""
    points = np.asarray(points, dtype=np.float64)
    out = [points[0]]
    for a, b in zip(points[:-1], points[1:]):
        out += [a + (b - a) / 3, a + 2 * (b - a) / 3, b]
    return np.array(out)


def uniform_curve(control_points: np.ndarray, left: float, right: float) -> DiffusionCurve:
    """A curve with one grey level on each side."""
    return DiffusionCurve(
        control_points,
        left=(ColorStop(0.0, (left,) * 3),),
        right=(ColorStop(0.0, (right,) * 3),),
    )
