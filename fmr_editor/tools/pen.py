"""The pen: draw a diffusion curve of cubic Bezier pieces, anchor by anchor.

- A click places a corner anchor; a press and drag places a smooth anchor
  whose outgoing handle follows the pointer and whose incoming handle mirrors
  it (Alt while dragging leaves the incoming side a corner; Shift keeps the
  handle at a multiple of 45 degrees).
- The pieces next to a corner get handles a third of the way along them, so
  straight pieces are evenly parametrised and every handle can be grabbed.
- Enter, a double click, or switching tools ends the curve (two anchors at
  least); a click on the first anchor closes it.  Pressing the last anchor
  again adds no anchor: dragging from it pulls out its outgoing handle.  Esc drops the curve being
  drawn; BackSpace or Delete removes its last anchor.
- The finished curve is one undo step "Draw Curve" and gets the foreground
  colour on its left side and the background colour on its right; on a clear
  layer above the bottom one (a new, empty layer, or one with alpha) the
  foreground colour on both sides, and a closed curve is opaque inside and
  clear outside.  It is then selected.  Nothing reaches the document before it
  is finished.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from ..model import ColorStop, DiffusionCurve, EditRefused, edits
from ..model.layer import CLONE_HOLDS_NOTHING
from .base import Tool
from .context import Selection, ToolContext
from .events import BACKSPACE, DELETE, ENTER, ESCAPE, RETURN, PointerEvent
from .hit import is_closed, polyline
from .moving import constrain
from .overlay import Markers, Polyline, Segments


@dataclass
class Anchor:
    """An anchor being drawn; a handle of None is retracted (a corner on that side)."""

    position: np.ndarray
    handle_in: np.ndarray | None = None
    handle_out: np.ndarray | None = None


def control_points(anchors: list[Anchor]) -> np.ndarray:
    """The ``(3k + 1, 2)`` control points through ``anchors`` (at least two).

    A retracted handle goes a third of the way toward the piece's other
    handle (or anchor, when that is retracted too).
    """
    out = [anchors[0].position]
    for a, b in zip(anchors[:-1], anchors[1:]):
        far_a = b.handle_in if b.handle_in is not None else b.position
        far_b = a.handle_out if a.handle_out is not None else a.position
        first = a.handle_out if a.handle_out is not None else a.position + (far_a - a.position) / 3
        second = b.handle_in if b.handle_in is not None else b.position + (far_b - b.position) / 3
        out += [first, second, b.position]
    return np.array(out, dtype=np.float64)


def _colour_stops(context: ToolContext, curve: DiffusionCurve) -> tuple[tuple[ColorStop], tuple[ColorStop]]:
    """The new curve's left and right stops: the foreground colour on the left and the background colour on the
    right (of a closed curve on a mask: inside and outside, whichever way it was drawn, so that a white shape
    on a Hide All mask shows its inside); on a clear layer above the bottom one (empty, or with alpha
    already), the foreground colour on both sides, a closed curve opaque inside and clear outside, so that it
    covers exactly its inside, and an open one with the options' stroke alphas."""
    options, document = context.options, context.document
    foreground = tuple(float(v) for v in options.color)
    background = tuple(float(v) for v in options.secondary_color)
    layer = document.layer
    if document.editing_mask and is_closed(curve) and not curve.inside_on_left():
        return (ColorStop(0.0, background),), (ColorStop(0.0, foreground),)
    if document.editing_mask or document.active == 0 or not (layer.empty or layer.translucent):
        return (ColorStop(0.0, foreground),), (ColorStop(0.0, background),)
    left, right = options.stroke_left_alpha, options.stroke_right_alpha
    if is_closed(curve):
        left, right = (1.0, 0.0) if curve.inside_on_left() else (0.0, 1.0)
    return (ColorStop(0.0, foreground, left),), (ColorStop(0.0, foreground, right),)


class PenTool(Tool):
    """Draw Bezier curves."""

    name = "pen"
    title = "Pen"
    hint = ("Click for a corner, drag for a smooth anchor; Return or double click ends the curve; "
            "click the first anchor to close it")
    shortcut = "P"
    summary = "Draw diffusion curves: corners and smooth anchors"
    cursor = "pen"

    def __init__(self, context: ToolContext) -> None:
        super().__init__(context)
        self.anchors: list[Anchor] = []
        self.dragging: Anchor | None = None  # the anchor whose handles the held pointer sets
        self.pressed_at: tuple[float, float] | None = None
        self.closing = False
        self.reshaping = False  # dragging the last anchor's outgoing handle out again
        self.moved = False  # the held pointer has passed the drag threshold

    @property
    def busy(self) -> bool:
        return bool(self.anchors)

    # -- events ------------------------------------------------------------------------------
    def press(self, event: PointerEvent) -> None:
        self.pointer = event.position
        if event.button != "left" or self.dragging is not None:
            return
        if event.clicks == 2:  # the first click of the double click placed the last anchor
            self.finish()
            return
        if not self.anchors and self.context.document.layer.clone is not None:  # at once, not once it is drawn
            raise EditRefused(CLONE_HOLDS_NOTHING)
        if not self.anchors:  # a new curve: the one selected before is not what the panels should show
            self.context.selection = Selection()
        p = np.array(event.position)
        self.pressed_at, self.moved = event.position, False
        if self.anchors and self.near(self.anchors[-1], p):  # no zero-length piece: reshape the last anchor
            self.reshaping = True
            self.dragging = self.anchors[-1]
            return
        if len(self.anchors) >= 2 and self.near(self.anchors[0], p):
            self.closing = True
            self.dragging = Anchor(self.anchors[0].position.copy())
        else:
            self.dragging = Anchor(p)
        self.anchors.append(self.dragging)

    def near(self, anchor: Anchor, p: np.ndarray) -> bool:
        return bool(np.hypot(*(p - anchor.position)) <= self.context.tolerance)

    def move(self, event: PointerEvent) -> None:
        self.pointer = event.position
        anchor = self.dragging
        if anchor is None or not (self.moved or self.context.moved_far(self.pressed_at, event.position)):
            return
        self.moved = True
        offset = np.array(event.position) - anchor.position
        if event.shift:
            offset = np.array(constrain(tuple(offset)))
        if self.closing:  # the drag shapes the closing joint: first anchor's out handle, mirrored in
            self.anchors[0].handle_out = anchor.position + offset
            anchor.handle_in = anchor.position - offset
            return
        anchor.handle_out = anchor.position + offset
        if self.reshaping:
            return
        anchor.handle_in = None if event.alt else anchor.position - offset

    def release(self, event: PointerEvent) -> None:
        self.pointer = event.position
        if self.dragging is None or event.button not in ("left", "none"):
            return
        self.dragging, self.reshaping, self.moved = None, False, False
        if self.closing:
            self.finish()

    def key(self, name: str, modifiers: frozenset[str] = frozenset()) -> bool:
        if not self.anchors:
            return False
        if name == ESCAPE:
            self.cancel()
        elif name in (RETURN, ENTER):
            self.finish()
        elif name in (BACKSPACE, DELETE) and self.dragging is None:
            self.anchors.pop()
        else:
            return False
        return True

    def cancel(self) -> None:
        """Drop the curve being drawn."""
        self.anchors, self.dragging, self.closing, self.reshaping = [], None, False, False

    def finish(self) -> None:
        """Add the curve being drawn (two anchors at least) as the step "Draw Curve"."""
        anchors = self.anchors
        self.cancel()
        if len(anchors) < 2:
            return
        context = self.context
        curve = DiffusionCurve(control_points(anchors))
        left, right = _colour_stops(context, curve)
        context.history.apply(edits.add_curve(context.document, replace(curve, left=left, right=right)), "Draw Curve")
        context.selection = Selection.of(curves=[context.document.curves[-1].id])

    # -- drawing -----------------------------------------------------------------------------
    def draw(self) -> list:
        anchors = list(self.anchors)
        if not anchors:
            return []
        out: list = []
        if self.dragging is None and self.pointer is not None:  # the piece the next click would add
            preview = anchors + [Anchor(np.array(self.pointer))]
            points = control_points(preview)[-4:]
            out.append(Polyline(polyline(DiffusionCurve(points)), "preview"))
        if len(anchors) >= 2:
            out.append(Polyline(polyline(DiffusionCurve(control_points(anchors))), "selected"))
        last_one = np.arange(len(anchors)) == len(anchors) - 1
        out.append(Markers.of([a.position for a in anchors], "anchor", last_one))
        last = anchors[-1]
        handles = [h for h in (last.handle_in, last.handle_out) if h is not None]
        if handles:
            out.append(Segments(np.array([(last.position, h) for h in handles]), "handle"))
            out.append(Markers.of(handles, "handle"))
        return out
