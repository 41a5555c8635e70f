"""The colour-stop tool: click beside a curve to add a stop on that side, drag stops along it.

- A click within reach of a curve adds a stop with the foreground colour at
  the nearest point, on the side of the curve the pointer is on; dragging
  before releasing places it (one step "Add Stop").
- Pressing a stop's marker selects it (Shift toggles); dragging moves it
  along its curve (one step "Move Stop").
- A double click on a stop (or the double click that adds one) asks for its
  colour (``ToolContext.choose_color``): one step "Change Stop Colour".
- Delete or BackSpace removes the selected stops; a click away from curves
  clears the selection.  Stops of the curve under the pointer and of the
  selected curves are shown.
"""

from __future__ import annotations

from ..model import BlurStop, ColorStop, Document, edits
from .actions import delete_selection
from .base import Drag, EditDrag, Tool
from .context import Selection, ToolContext
from .events import BACKSPACE, DELETE, PointerEvent
from .hit import CurveIndex, nearest_stop, stop_marker
from .overlay import Markers, curve_marks


def find_stop(document: Document, curve: int, side: str, position: float, value) -> int:
    """Index of the stop on ``side`` of the curve ``curve`` (an id) at ``position`` with ``value``: its colour
    (its blur, on side ``"blur"``).

    Equal stops are interchangeable.
    """
    stops = getattr(document.curve(curve), side)
    return next(i for i, stop in enumerate(stops) if stop.position == position and stop_value(stop) == value)


def stop_value(stop):
    """What a stop holds besides its position: a colour stop's colour, a blur stop's blur."""
    return stop.blur if isinstance(stop, BlurStop) else stop.color


class StopDrag(EditDrag):
    """Drag stop ``(curve, side, index)`` of ``base`` along its curve; the selection follows it."""

    def __init__(self, context: ToolContext, event: PointerEvent, stop: tuple[int, str, int],
                 label: str = "Move Stop", pressed: Document | None = None) -> None:
        super().__init__(context, event, label, pressed)
        self.curve, self.side, self.index = stop
        self.stop = getattr(self.base.curve(self.curve), self.side)[self.index]
        self.track = CurveIndex([self.base.curve(self.curve)])

    def edited(self, event: PointerEvent) -> Document:
        s = self.track.nearest(event.position).s
        document = edits.move_stop(self.base, self.curve, self.side, self.index, s)
        index = find_stop(document, self.curve, self.side, s, self.stop.color)  # the stops were sorted again
        self.context.selection = Selection.of(stops=[(self.curve, self.side, index)])
        return document


def pick_stop_color(context: ToolContext, stop: tuple[int, str, int]) -> bool:
    """Select ``stop`` and ask ``context.choose_color`` for its colour; one step when the user picks one.

    A ui whose dialog applies its changes itself (live, as one merged step)
    answers None here.
    """
    context.selection = Selection.of(stops=[stop])
    if context.choose_color is None:
        return False
    c, side, i = stop
    color = context.choose_color(getattr(context.document.curve(c), side)[i].color)
    if color is None:
        return False
    edited = edits.set_stop_color(context.document, c, side, i, tuple(float(v) for v in color))
    context.history.apply(edited, "Change Stop Colour")
    return True


def stop_under(context: ToolContext, position, curves) -> tuple[int, str, int] | None:
    """The stop whose marker is under ``position``, among ``curves``."""
    return nearest_stop(context.curve_set(curves).stop_markers(context.marker_offset), position, context.tolerance)


class StopsTool(Tool):
    """Add, move, colour and delete colour stops."""

    name = "stops"
    title = "Colour Stops"
    hint = ("Click beside a curve to add a stop on that side; drag stops along the curve; "
            "double click a stop for its colour")
    shortcut = "G"
    summary = "Add, move and recolour the colour stops on each side of a curve"
    cursor = "crosshair"

    def __init__(self, context: ToolContext) -> None:
        super().__init__(context)
        self.added: tuple[int, str, int] | None = None  # the stop the last click added

    def reach(self) -> float:
        """How far beside a curve a click adds a stop, document pixels."""
        return self.context.tolerance + self.context.marker_offset

    def shown_curves(self, position) -> set[int]:
        """Curves whose stops are shown: the selected ones and the one near ``position``."""
        shown = set(self.context.selection.active_curves())
        if position is not None and (hit := self.context.curve_index().nearest(position, self.reach())):
            shown.add(hit.curve)
        return shown

    def start(self, event: PointerEvent) -> Drag | None:
        context = self.context
        added, self.added = self.added, None
        stop = stop_under(context, event.position, self.shown_curves(event.position))
        if event.clicks == 2 and (stop or added):
            pick_stop_color(context, stop or added)
            return None
        if stop is not None:
            chosen = Selection.of(stops=[stop])
            context.selection = context.selection ^ chosen if event.shift else chosen
            return StopDrag(context, event, stop) if stop in context.selection.stops else None
        hit = context.curve_index().nearest(event.position, self.reach())
        if hit is None:
            if not event.shift:
                context.selection = Selection()
            return None
        new = ColorStop(hit.s, tuple(float(v) for v in context.options.color))
        document = edits.add_stop(context.document, hit.curve, hit.side, new)
        self.added = (hit.curve, hit.side, find_stop(document, hit.curve, hit.side, new.position, new.color))
        drag = StopDrag(context, event, self.added, "Add Stop", pressed=document)
        context.selection = Selection.of(stops=[self.added])
        return drag

    def on_key(self, name: str, modifiers: frozenset[str]) -> bool:
        if name in (DELETE, BACKSPACE) and self.context.selection.stops:
            self.context.selection = Selection(stops=self.context.selection.stops)  # this tool deletes stops only
            return delete_selection(self.context)
        return False

    def draw(self) -> list:
        context = self.context
        document = context.document
        out = curve_marks(context, self.shown_curves(self.pointer), nodes=False)
        if self.drag is None and self.pointer is not None:
            stop = stop_under(context, self.pointer, self.shown_curves(self.pointer))
            hit = context.curve_index().nearest(self.pointer, self.reach())
            if stop is None and hit is not None:  # where a click would add a stop
                where = stop_marker(document.curve(hit.curve), hit.side, hit.s, context.marker_offset)
                out.append(Markers.of([where], "stop", colors=[context.options.color]))
        return out
