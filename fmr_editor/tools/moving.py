"""Moving the selection: what moves along with what, and the drag that moves it.

As in Illustrator and Inkscape: moving an anchor moves its two handles with
it; the first and last anchor of a closed curve move together; dragging one
handle of a smooth anchor (its handles opposite each other) turns the other
handle to stay opposite, keeping its length, unless Alt is held (which makes
the anchor a corner); Shift keeps a move horizontal, vertical or diagonal.
"""

from __future__ import annotations

import math

import numpy as np

from ..model import Document, edits
from .base import EditDrag
from .context import Selection, ToolContext
from .events import PointerEvent
from .hit import is_closed

SMOOTH_COS = math.cos(math.radians(2.0))  # handles this close to opposite count as smooth


def moving_control_points(document: Document, selection: Selection) -> set[tuple[int, int]]:
    """The control points a move of ``selection`` carries (curves moved whole excluded)."""
    out = set()
    for c, i in selection.control_points:
        if c in selection.curves:
            continue
        curve = document.curve(c)
        n = len(curve.control_points)
        out.add((c, i))
        if i % 3 == 0:
            out.update((c, j) for j in (i - 1, i + 1) if 0 <= j < n)
            if is_closed(curve) and i in (0, n - 1):
                out.update((c, j) for j in (0, 1, n - 2, n - 1))
    return out


def translate_selection(document: Document, selection: Selection, delta) -> Document:
    """``document`` with everything ``selection`` names moved by ``delta``."""
    return edits.translate(document, delta, selection.curves,
                           moving_control_points(document, selection), selection.points)


def move_label(document: Document, selection: Selection) -> str:
    """The undo step's name for moving ``selection``: "Move Curve", "Move Anchors", "Move"..."""
    anchors = [(c, i) for c, i in selection.control_points if i % 3 == 0 and c not in selection.curves]
    handles = [(c, i) for c, i in selection.control_points if i % 3 and c not in selection.curves]
    kinds = [(n, noun) for n, noun in ((len(selection.curves), "Curve"), (len(selection.points), "Point"),
                                       (len(anchors), "Anchor"), (len(handles), "Handle")) if n]
    if len(kinds) != 1:
        return "Move"
    n, noun = kinds[0]
    return f"Move {noun}" + ("s" if n > 1 else "")


def constrain(delta: tuple[float, float]) -> tuple[float, float]:
    """``delta`` turned to the nearest multiple of 45 degrees (Shift while dragging)."""
    dx, dy = delta
    length = math.hypot(dx, dy)
    if length == 0:
        return (0.0, 0.0)
    angle = round(math.atan2(dy, dx) / (math.pi / 4)) * (math.pi / 4)
    along = dx * math.cos(angle) + dy * math.sin(angle)  # projection onto that direction
    return (along * math.cos(angle), along * math.sin(angle))


def smooth_partner(document: Document, c: int, i: int) -> tuple[int, int] | None:
    """``(anchor, opposite handle)`` when handle ``i`` of the curve ``c`` (an id) belongs to a smooth anchor."""
    curve = document.curve(c)
    control = curve.control_points
    n = len(control)
    if i % 3 == 0:
        return None
    anchor = i - 1 if i % 3 == 1 else i + 1
    opposite = 2 * anchor - i
    if not 0 <= opposite < n:
        if not is_closed(curve):
            return None
        opposite = n - 2 if opposite < 0 else 1  # across the joint of a closed curve
    u, v = control[i] - control[anchor], control[opposite] - control[anchor]
    lu, lv = np.hypot(*u), np.hypot(*v)
    if lu < 1e-9 or lv < 1e-9 or -float(np.dot(u, v)) / (lu * lv) < SMOOTH_COS:
        return None
    return anchor, opposite


class MoveDrag(EditDrag):
    """Drag the selection by the pointer's travel (one step, e.g. "Move Anchor")."""

    def __init__(self, context: ToolContext, event: PointerEvent) -> None:
        selection = context.selection
        super().__init__(context, event, move_label(context.document, selection))
        carried = sorted(moving_control_points(self.start, selection))
        single = carried[0] if len(carried) == 1 and not (selection.curves or selection.points) else None
        self.smooth = None
        if single is not None and (partner := smooth_partner(self.start, *single)) is not None:
            self.smooth = (single, partner)

    def edited(self, event: PointerEvent) -> Document:
        delta = (event.position[0] - self.origin[0], event.position[1] - self.origin[1])
        if event.shift:
            delta = constrain(delta)
        document = translate_selection(self.start, self.selection, delta)
        if self.smooth is not None and not event.alt:
            (c, i), (anchor, opposite) = self.smooth
            control = document.curve(c).control_points
            u = control[i] - control[anchor]
            length = np.hypot(*(self.start.curve(c).control_points[opposite] - control[anchor]))
            if np.hypot(*u) > 1e-9:
                turned = control[anchor] - length * u / np.hypot(*u)
                document = edits.move_control_point(document, c, opposite, tuple(turned))
        return document
