"""Curves with known geometry for tests."""

from __future__ import annotations

import numpy as np

from fmr_editor.model import ColorStop, DiffusionCurve, Document

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


def scattered_document(size: int = 128, circles: int = 5, seed: int = 2) -> Document:
    """Random circles with colour stops plus one open chain: a small but varied boundary system."""
    rng = np.random.default_rng(seed)
    curves = []
    for _ in range(circles):
        stops = tuple(ColorStop(s, tuple(rng.random(3))) for s in (0.0, 2.0, 4.0))
        centre = rng.uniform(0.2 * size, 0.8 * size, 2)
        curves.append(DiffusionCurve(circle_points(*centre, rng.uniform(0.05, 0.15) * size), left=stops,
                                     right=stops[::-1]))
    chain = [(0.04 * size, 0.94 * size), (0.47 * size, 0.7 * size), (0.96 * size, 0.86 * size)]
    curves.append(DiffusionCurve(straight_chain(chain), left=stops, right=stops))
    return Document(size, size, curves)


RED, BLUE = (1.0, 0.0, 0.0), (0.0, 0.0, 1.0)


def line_document() -> Document:
    """A 128x128 canvas with one straight, linearly parametrised curve from (16, 64) to (112, 64): red on its
    left (above), blue on its right."""
    curve = DiffusionCurve(straight_chain([(16.0, 64.0), (112.0, 64.0)]),
                           left=(ColorStop(0.0, RED),), right=(ColorStop(0.0, BLUE),))
    return Document(128, 128, (curve,))
