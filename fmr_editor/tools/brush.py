"""The diffusion-point brush: a drag paints a stroke of Gaussian dabs.

A press places a dab; dragging places further dabs every ``brush_spacing``
document pixels along the pointer's path (spacing carries over between
pointer moves, so dabs stay evenly spaced however the events arrive).  Each
dab is a ``DiffusionPoint`` with the options' brush colour, radius and amplitude,
fixed at the press.  The whole stroke is one undo step "Paint"; Esc during
it removes the stroke.
"""

from __future__ import annotations

import math

from ..model import DiffusionPoint, Document, edits
from .base import EditDrag, Tool
from .context import ToolContext
from .events import PointerEvent
from .overlay import Circle


class Stroke(EditDrag):
    """The dabs of one drag, shown as they are placed."""

    def __init__(self, context: ToolContext, event: PointerEvent) -> None:
        options = context.options
        self.spacing = max(float(options.brush_spacing), 1e-3)
        radius, color, amplitude = options.brush_radius, options.brush_color, options.brush_amplitude
        self.dab = lambda x, y: DiffusionPoint((x, y), radius, color, amplitude)
        self.dabs = [self.dab(*event.position)]
        self.last = event.position  # the pointer's previous position
        self.travelled = 0.0  # distance along the path since the last dab
        super().__init__(context, event, "Paint", pressed=edits.add_points(context.document, self.dabs))

    def move(self, event: PointerEvent) -> None:
        self.position = event.position
        (x0, y0), (x1, y1) = self.last, event.position
        length = math.hypot(x1 - x0, y1 - y0)
        self.last = event.position
        if length == 0:
            return
        before = len(self.dabs)
        along = self.spacing - self.travelled  # distance into this move of the next dab
        while along <= length:
            f = along / length
            self.dabs.append(self.dab(x0 + f * (x1 - x0), y0 + f * (y1 - y0)))
            along += self.spacing
        self.travelled = length - (along - self.spacing)
        if len(self.dabs) > before:
            self.context.history.preview(self.edited(event))

    def edited(self, event: PointerEvent) -> Document:
        return edits.add_points(self.start, self.dabs)


class BrushTool(Tool):
    """Paint diffusion points."""

    name = "brush"
    title = "Point Brush"
    hint = "Drag to paint dabs: each adds amplitude x brush colour, so overlapping dabs add up (towards white); a negative amplitude takes colour away"
    shortcut = "B"
    cursor = "crosshair"

    def start(self, event: PointerEvent) -> Stroke:
        return Stroke(self.context, event)

    def draw(self) -> list:
        if self.pointer is None:
            return []
        return [Circle(self.pointer, float(self.context.options.brush_radius), "brush")]
