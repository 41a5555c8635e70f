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
from .context import Selection, ToolContext

ROLES = ("selected", "hover", "preview", "handle", "rubber-band", "brush", "ants")
"""What a primitive shows; ``"ants"`` is a region's outline (the lasso's selection), drawn as marching ants."""


@dataclass(frozen=True, eq=False)
class Polyline:
    """A line through ``points`` ``(n, 2)``; ``role`` is one of ``ROLES``."""

    points: np.ndarray
    role: str = "selected"
    closed: bool = False


@dataclass(frozen=True, eq=False)
class Segments:
    """Separate line segments ``(n, 2, 2)`` (e.g. handle lines from anchors to handles)."""

    ends: np.ndarray
    role: str = "handle"


@dataclass(frozen=True, eq=False)
class Markers:
    """Fixed-size marks of one kind at ``positions``.

    Attributes
    ----------
    positions : numpy.ndarray
        ``(n, 2)`` document pixels.
    kind : str
        ``"anchor"`` (square), ``"handle"`` (round), ``"stop"`` (filled with
        its colour), ``"point"`` (a diffusion point's centre), ``"sample"``
        (the eyedropper's pick, filled with its colour).
    selected : numpy.ndarray
        ``(n,)`` booleans.
    colors : numpy.ndarray or None
        ``(n, 3)`` fill colours (stops, points, samples).
    """

    positions: np.ndarray
    kind: str
    selected: np.ndarray
    colors: np.ndarray | None = None

    @classmethod
    def of(cls, positions, kind: str, selected=None, colors=None) -> Markers:
        """Markers from sequences; none selected unless ``selected`` says so."""
        positions = np.asarray(positions, dtype=np.float64).reshape(-1, 2)
        chosen = np.zeros(len(positions), bool) if selected is None else np.asarray(selected, bool)
        return cls(positions, kind, chosen, None if colors is None else np.asarray(colors, np.float64).reshape(-1, 3))


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


def curve_marks(context: ToolContext, curves: Iterable[int], nodes: bool = True, stops: bool = True,
                role: str = "selected") -> list:
    """Outlines, handle lines, anchors, handles and stop markers of ``curves``.

    Parameters
    ----------
    context : ToolContext
        The document, the selection (drawn selected) and the stop markers' offset.
    curves : iterable of int
    nodes, stops : bool
        Whether to show control points and stop markers.
    role : str
        The outlines' role ("selected" or "hover").
    """
    shown = context.curve_set(curves)
    document, selection = context.document, context.selection
    out: list = [Polyline(line, role) for line in shown.outlines().values()]
    if nodes and shown.ids:
        points, owner, index = shown.control_points()
        handle = index % 3 != 0
        own_anchor = np.flatnonzero(handle) - index[handle] + 3 * ((index[handle] + 1) // 3)
        out.append(Segments(np.stack([points[own_anchor], points[handle]], axis=1), "handle"))
        chosen = np.array([(int(c), int(i)) in selection.control_points for c, i in zip(owner, index)], bool)
        out.append(Markers(points[handle], "handle", chosen[handle]))
        out.append(Markers(points[~handle], "anchor", chosen[~handle]))
    markers = shown.stop_markers(context.marker_offset) if stops else []
    if markers:
        out.append(Markers.of(
            [m[3] for m in markers], "stop", [m[:3] in selection.stops for m in markers],
            [getattr(document.curve(c), side)[i].color for c, side, i, _ in markers],
        ))
    return out


def point_marks(document: Document, selection: Selection) -> list:
    """Centres of all diffusion points, and the radius of the selected ones."""
    if not document.points:
        return []
    points, chosen = document.points, selection.points
    out: list = [Markers.of([p.position for p in points], "point", [p.id in chosen for p in points],
                            [p.color for p in points])]
    out += [Circle(p.position, p.radius, "selected") for p in points if p.id in chosen]
    return out


def region_marks(context: ToolContext) -> list:
    """The lasso's selection (``ToolContext.region``) as marching ants."""
    return [Polyline(context.region, "ants", closed=True)] if context.region is not None else []
