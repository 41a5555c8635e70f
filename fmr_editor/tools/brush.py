"""The diffusion-point brush: a drag paints a stroke of Gaussian dabs.

A press places a dab; dragging places further dabs every ``brush_spacing``
document pixels along the pointer's path (spacing carries over between
pointer moves, so dabs stay evenly spaced however the events arrive).  Each
dab is a ``DiffusionPoint`` of the options' radius and amplitude, fixed at
the press.  What a dab does depends on the mode:

- **Paint** (``brush_mode = "paint"``, the default): the dab goes, white, into
  the mask of a fill layer of the brush colour just above the active layer
  (``layer_edits.with_fill_layer``, made on demand), so the colour covers what
  lies below, as paint does;
- **Glow** (``"glow"``): the dab adds ``amplitude x colour`` to the active
  layer, so overlapping dabs add up towards white; on an empty layer above the
  bottom one (clear: there is no picture to add light to, and points would
  make it an opaque black one) it paints as Paint does;
- while the active layer's **mask** is edited, a dab adds to the mask (a light
  brush colour) or subtracts from it (a dark one).

With Alt, a stroke on a mask or in Glow mode erases the dabs under it (the
mask's, or the active layer's points).

The whole stroke is one undo step ("Paint Stroke", "Glow Stroke"); Esc during
it removes the stroke, and a stroke that changes nothing (every dab farther
than ``REACH`` radii outside the canvas, or an erasing one that meets no dab)
makes no step.
"""

from __future__ import annotations

import math

from ..model import DiffusionPoint, Document, edits, layer_edits
from ..model.layer import MASK_LUMA
from .base import EditDrag, Tool
from .context import ToolContext
from .events import PointerEvent
from .overlay import Circle

#: A dab reaches the canvas when its centre lies within this many radii of it (beyond, its Gaussian is below
#: exp(-9) = 1.2e-4 of its amplitude: under 1/255 for any amplitude up to 30).
REACH = 3.0


class Stroke(EditDrag):
    """The dabs of one drag, shown as they are placed."""

    def __init__(self, context: ToolContext, event: PointerEvent) -> None:
        options, document = context.options, context.document
        self.spacing = max(float(options.brush_spacing), 1e-3)
        radius, color, amplitude = options.brush_radius, options.brush_color, options.brush_amplitude
        self.fill: int | None = None  # the fill layer painted into (Paint mode)
        self.erasing = event.alt and (document.editing_mask or options.brush_mode == "glow")
        if self.erasing and not document.editing_mask:
            label = "Erase Points"
        elif document.editing_mask:
            label = "Erase Mask" if self.erasing else "Paint Mask"
            sign = 1.0 if float(MASK_LUMA @ color) >= 0.5 else -1.0
            color, amplitude = (1.0, 1.0, 1.0), sign * abs(amplitude)
        elif options.brush_mode == "paint" or (document.active > 0 and document.layer.empty):
            label = "Paint Stroke"
            self.base_document, self.fill = layer_edits.with_fill_layer(document, color)
            color, amplitude = (1.0, 1.0, 1.0), abs(amplitude)
        else:
            label = "Glow Stroke"
        self.dab = lambda x, y: DiffusionPoint((x, y), radius, color, amplitude)
        self.dabs = [self.dab(*event.position)]
        self.last = event.position  # the pointer's previous position
        self.travelled = 0.0  # distance along the path since the last dab
        self.reach = radius  # how near a dab's centre an erasing stroke passes to remove it
        super().__init__(context, event, label, pressed=self._painted(document))

    def _painted(self, start: Document) -> Document:
        """``start`` with the stroke's dabs in place (or, erasing, without the mask dabs they reach)."""
        if self.fill is not None:
            return layer_edits.add_mask_points(self.base_document, self.fill, self.dabs)
        if self.erasing:
            hit = {point.id for point in start.points for dab in self.dabs
                   if math.dist(point.position, dab.position) <= self.reach}
            return edits.remove_points(start, hit)
        return edits.add_points(start, self.dabs)

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
        return self._painted(self.start)

    def release(self, event: PointerEvent) -> None:
        if self._changes_nothing():
            self.cancel()
        else:
            super().release(event)

    def _changes_nothing(self) -> bool:
        if self.erasing:
            return self._painted(self.start).points == self.start.points
        return not any(self._reaches_canvas(dab) for dab in self.dabs)

    def _reaches_canvas(self, dab: DiffusionPoint) -> bool:
        (x, y), width, height = dab.position, self.start.width, self.start.height
        return math.hypot(max(-x, 0.0, x - width), max(-y, 0.0, y - height)) <= REACH * dab.radius


class BrushTool(Tool):
    """Paint diffusion points."""

    name = "brush"
    title = "Point Brush"
    hint = ("Drag to paint dabs (Paint covers what is below, Glow adds up towards white); "
            "on a mask light adds, dark subtracts; Alt erases on a mask and in Glow")
    shortcut = "B"
    summary = "Paint diffusion points: soft Gaussian dabs of colour"
    cursor = "crosshair"

    def start(self, event: PointerEvent) -> Stroke:
        return Stroke(self.context, event)

    def draw(self) -> list:
        if self.pointer is None:
            return []
        return [Circle(self.pointer, float(self.context.options.brush_radius), "brush")]
