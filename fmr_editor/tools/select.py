"""The selection tool: pick, rubber-band, move and delete curves, nodes, stops and points.

A press picks the topmost thing under the pointer, smallest first: a control
point (anchor or handle) or stop marker of a shown curve, a diffusion point's
centre, then a curve.  Shown curves are the selected ones and those with a
selected part; their anchors, handles and stops are drawn.

- Click selects; Shift+click adds or removes; a click on a selected item
  keeps the selection, so that dragging moves all of it.
- Dragging moves the selection (one step: "Move Curve", "Move Anchors"...);
  a stop's marker drags along its curve ("Move Stop").  Shift constrains a
  move to 45 degrees; see ``moving`` for handles and Alt.
- Dragging from empty canvas draws a rubber band selecting the diffusion
  points inside, the curves lying wholly inside and, of shown curves, the
  control points inside; Shift adds to the selection.  A click on empty
  canvas clears the selection.
- Double click: on a curve adds an anchor there ("Add Anchor"), on a stop
  asks for its colour.
- Delete/BackSpace removes the selection; arrow keys nudge it by one
  document pixel (ten with Shift); Esc cancels a drag, or else clears the
  selection.
"""

from __future__ import annotations

import numpy as np

from ..model import edits
from .actions import delete_selection, nudge
from .base import Drag, Tool
from .context import Selection, ToolContext
from .events import ARROWS, BACKSPACE, DELETE, ESCAPE, PointerEvent
from .hit import inside, nearest_control_point, nearest_point, polyline
from .moving import MoveDrag
from .overlay import Polyline, Rectangle, curve_marks, point_marks
from .stops import StopDrag, pick_stop_color, stop_under


class RubberBand(Drag):
    """Select what lies inside the rectangle from the press to the pointer."""

    def __init__(self, context: ToolContext, event: PointerEvent) -> None:
        super().__init__(context, event)
        self.add = event.shift
        self.dragged = False

    def move(self, event: PointerEvent) -> None:
        super().move(event)
        self.dragged = self.dragged or self.context.moved_far(self.origin, event.position)

    def release(self, event: PointerEvent) -> None:
        self.position = event.position
        context = self.context
        if not (self.dragged or context.moved_far(self.origin, event.position)):
            if not self.add:  # a click on empty canvas
                context.selection = Selection()
            return
        found = banded(context, self.origin, self.position)
        context.selection = context.selection | found if self.add else found

    def overlay(self) -> list:
        return [Rectangle(self.origin, self.position)] if self.dragged else []


def banded(context: ToolContext, corner, opposite) -> Selection:
    """What a rubber band from ``corner`` to ``opposite`` selects."""
    document = context.document
    points = [p.id for p, ok in zip(document.points, inside(corner, opposite, [p.position for p in document.points]))
              if ok]
    curves = [c.id for c in document.curves if _wholly_inside(c, corner, opposite)]
    shown = context.selection.active_curves() - set(curves)
    control = [
        (c, int(i))
        for c in shown
        for i in np.flatnonzero(inside(corner, opposite, document.curve(c).control_points))
    ]
    return Selection.of(curves, control, (), points)


def _wholly_inside(curve, corner, opposite) -> bool:
    """Whether ``curve`` lies inside the rectangle (its hull first, then its outline)."""
    control = curve.control_points
    if inside(corner, opposite, control).all():  # the curve lies in its control points' hull
        return True
    if not inside(corner, opposite, control[::3]).all():  # anchors lie on the curve
        return False
    return bool(inside(corner, opposite, polyline(curve, 8)).all())


class SelectTool(Tool):
    """Select, move and delete."""

    name = "select"
    title = "Select"
    hint = ("Click to select (Shift adds), drag to move; drag on empty canvas to select an area; "
            "double click a curve to add an anchor")
    shortcut = "V"
    summary = "Select and move curves, points and anchors"
    cursor = "arrow"

    def under(self, position) -> tuple[str, object] | None:
        """What a press at ``position`` picks: ``(kind, key)`` or None."""
        context = self.context
        document, shown, tolerance = context.document, context.selection.active_curves(), context.tolerance
        if (node := nearest_control_point(document, shown, position, tolerance)) is not None:
            return "node", node
        if (stop := stop_under(context, position, shown)) is not None:
            return "stop", stop
        if (point := nearest_point(document, position, tolerance)) is not None:
            return "point", point
        if (hit := context.curve_index().nearest(position, tolerance)) is not None:
            return "curve", hit
        return None

    def start(self, event: PointerEvent) -> Drag | None:
        context = self.context
        found = self.under(event.position)
        if found is None:
            return RubberBand(context, event)
        kind, key = found
        if event.clicks == 2 and kind in ("curve", "stop"):
            self.double_click(kind, key)
            return None
        chosen = {
            "node": lambda: Selection.of(control_points=[key]),
            "stop": lambda: Selection.of(stops=[key]),
            "point": lambda: Selection.of(points=[key]),
            "curve": lambda: Selection.of(curves=[key.curve]),
        }[kind]()
        if event.shift:
            context.selection = context.selection ^ chosen
        elif not chosen <= context.selection:
            context.selection = chosen
        if not chosen <= context.selection:
            return None  # Shift+click took it out
        if kind == "stop":
            return StopDrag(context, event, key)
        return MoveDrag(context, event)

    def double_click(self, kind: str, key) -> None:
        context = self.context
        if kind == "stop":
            pick_stop_color(context, key)
            return
        document = edits.insert_anchor(context.document, key.curve, key.s)
        if document is not context.document:
            context.history.apply(document, "Add Anchor")
            index = 3 * (int(np.floor(key.s)) + 1)
            context.selection = Selection.of(control_points=[(key.curve, index)])

    def on_key(self, name: str, modifiers: frozenset[str]) -> bool:
        context = self.context
        if name in (DELETE, BACKSPACE):
            return delete_selection(context)
        if name in ARROWS:
            step = 10.0 if "shift" in modifiers else 1.0
            dx, dy = ARROWS[name]
            return nudge(context, (dx * step, dy * step))
        if name == ESCAPE and not context.selection.empty:
            context.selection = Selection()
            return True
        return False

    def draw(self) -> list:
        context = self.context
        document = context.document
        out = point_marks(document, context.selection)
        out += curve_marks(context, context.selection.active_curves())
        if self.drag is None and self.pointer is not None:
            found = self.under(self.pointer)
            if found is not None and found[0] == "curve" and found[1].curve not in context.selection.active_curves():
                out.insert(0, Polyline(polyline(document.curve(found[1].curve)), "hover"))
        return out
