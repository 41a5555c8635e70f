"""Drawable primitives a tool hands to the view, in document pixels (plain data, no Qt).

The view draws them on top of the image at a fixed screen size: marker sizes
and line widths are the view's choice; ``role`` and ``kind`` say what each
primitive shows so the view can style it.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass

import numpy as np

from ..model import Document
from ..model.curve import Color
from .context import Selection
from .hit import polyline, stop_markers

ROLES = ("selected", "hover", "preview", "handle", "rubber-band", "brush")


@dataclass(frozen=True, eq=False)
class Polyline:
    """A line through ``points`` ``(n, 2)``; ``role`` is one of ``ROLES``."""

    points: np.ndarray
    role: str = "selected"
    closed: bool = False


@dataclass(frozen=True)
class Marker:
    """A fixed-size mark at ``position``.

    Attributes
    ----------
    kind : str
        ``"anchor"`` (square), ``"handle"`` (round), ``"stop"`` (filled with
        ``color``), ``"point"`` (a diffusion point's centre), ``"sample"``
        (the eyedropper's pick, filled with ``color``).
    selected : bool
    color : tuple of float or None
        The stop's or point's colour.
    """

    position: tuple[float, float]
    kind: str
    selected: bool = False
    color: Color | None = None


@dataclass(frozen=True)
class Rectangle:
    """An axis-aligned rectangle between two corners (the rubber band)."""

    corner: tuple[float, float]
    opposite: tuple[float, float]
    role: str = "rubber-band"


@dataclass(frozen=True)
class Circle:
    """A circle of ``radius`` document pixels (a brush outline, a point's radius)."""

    centre: tuple[float, float]
    radius: float
    role: str = "brush"


def _xy(p) -> tuple[float, float]:
    return (float(p[0]), float(p[1]))


def curve_marks(document: Document, curves: Iterable[int], selection: Selection, offset: float,
                nodes: bool = True, stops: bool = True, role: str = "selected") -> list:
    """Outline, control polygon, anchors, handles and stop markers of ``curves``.

    Parameters
    ----------
    offset : float
        Stop markers' distance from the curve, document pixels.
    nodes, stops : bool
        Whether to show control points and stop markers.
    role : str
        The outline's role ("selected" or "hover").
    """
    out: list = []
    for c in sorted(curves):
        curve = document.curves[c]
        out.append(Polyline(polyline(curve), role))
        if nodes:
            control = curve.control_points
            for i in range(0, len(control) - 1, 3):  # handle lines: anchor to its handles
                out.append(Polyline(control[i : i + 2].copy(), "handle"))
                out.append(Polyline(control[i + 2 : i + 4].copy(), "handle"))
            out += [
                Marker(_xy(p), "handle" if i % 3 else "anchor", (c, i) in selection.control_points)
                for i, p in enumerate(control)
            ]
        if stops:
            out += [
                Marker(_xy(position), "stop", (c, side, i) in selection.stops, getattr(curve, side)[i].color)
                for side, i, position in stop_markers(curve, offset)
            ]
    return out


def point_marks(document: Document, selection: Selection) -> list:
    """Centres of all diffusion points, and the radius of the selected ones."""
    out: list = []
    for i, point in enumerate(document.points):
        chosen = i in selection.points
        out.append(Marker(point.position, "point", chosen, point.color))
        if chosen:
            out.append(Circle(point.position, point.radius, "selected"))
    return out
