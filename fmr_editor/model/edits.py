"""Edits: functions from a document to the edited document.

Each returns a new ``Document`` and leaves its argument alone; tools and
scripts compose them and hand the result to a ``History``.  Indices count
from 0; ``side`` is ``"left"`` or ``"right"``.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import replace

import numpy as np

from .curve import Color, ColorStop, DiffusionCurve
from .document import Document
from .point import DiffusionPoint

SIDES = ("left", "right")


def _side(side: str) -> str:
    if side not in SIDES:
        raise ValueError(f"side must be 'left' or 'right', got {side!r}")
    return side


def replace_curve(document: Document, index: int, curve: DiffusionCurve) -> Document:
    """``document`` with curve ``index`` replaced by ``curve``."""
    curves = list(document.curves)
    curves[index] = curve
    return document.with_curves(curves)


def add_curve(document: Document, curve: DiffusionCurve) -> Document:
    """``document`` with ``curve`` drawn on top of the others."""
    return document.with_curves(document.curves + (curve,))


def remove_curves(document: Document, indices: Iterable[int]) -> Document:
    """``document`` without the curves at ``indices``."""
    drop = set(indices)
    return document.with_curves(c for i, c in enumerate(document.curves) if i not in drop)


def move_control_point(document: Document, curve: int, point: int, position: tuple[float, float]) -> Document:
    """``document`` with control point ``point`` of curve ``curve`` at ``position``."""
    old = document.curves[curve]
    points = np.array(old.control_points)
    points[point] = position
    return replace_curve(document, curve, replace(old, control_points=points))


def set_stop_color(document: Document, curve: int, side: str, stop: int, color: Color) -> Document:
    """``document`` with stop ``stop`` on ``side`` of curve ``curve`` coloured ``color``."""
    old = document.curves[curve]
    stops = list(getattr(old, _side(side)))
    stops[stop] = ColorStop(stops[stop].position, tuple(color))
    return replace_curve(document, curve, replace(old, **{side: tuple(stops)}))


def add_stop(document: Document, curve: int, side: str, stop: ColorStop) -> Document:
    """``document`` with ``stop`` added on ``side`` of curve ``curve``."""
    old = document.curves[curve]
    return replace_curve(document, curve, replace(old, **{side: getattr(old, _side(side)) + (stop,)}))


def remove_stop(document: Document, curve: int, side: str, stop: int) -> Document:
    """``document`` without stop ``stop`` on ``side`` of curve ``curve``."""
    old = document.curves[curve]
    stops = getattr(old, _side(side))
    return replace_curve(document, curve, replace(old, **{side: stops[:stop] + stops[stop + 1 :]}))


def add_points(document: Document, points: Iterable[DiffusionPoint]) -> Document:
    """``document`` with ``points`` added."""
    return document.with_points(document.points + tuple(points))


def remove_points(document: Document, indices: Iterable[int]) -> Document:
    """``document`` without the points at ``indices``."""
    drop = set(indices)
    return document.with_points(p for i, p in enumerate(document.points) if i not in drop)
