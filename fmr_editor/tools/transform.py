"""The clone transform: move, scale and turn a clone layer with handles on the canvas.

The active clone layer shows its box (the bounding box of its region in the
source, placed with it): dragging inside the box moves the clone, a corner
scales it about the box's centre, the round handle above the box turns it
(Shift: by 15 degrees; Shift while moving: along 45 degrees; arrows nudge by
one pixel, ten with Shift).  Every frame of a drag is the exact seamless
blend (``engine.LiveStack``).

All changes from the first drag (or from Edit > Paste Seamless, which starts
here) until Return are one undo step, "Transform Clone" (or "Paste
Seamless"); Esc or Undo drops them all, switching tools keeps them.  A click
outside the box keeps them too, and a click inside another clone layer's
region makes that layer active.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import shapely

from ..model import Document, EditRefused, layer_edits
from ..model.clone import Clone, Similarity
from ..model.clone_edits import place_clone
from .base import Tool
from .context import ToolContext
from .events import ARROWS, ENTER, ESCAPE, RETURN, PointerEvent
from .moving import constrain
from .overlay import Markers, Polyline, Segments

#: Distance of the turning handle above the box, screen pixels.
TURN_HANDLE_PX = 28.0
#: Steps of a turn with Shift held, degrees.
TURN_STEP = 15.0
#: Smallest and largest scale a corner drag gives.
SCALES = (0.02, 50.0)


@dataclass(frozen=True)
class Handles:
    """Where a clone's handles are, in document pixels.

    Attributes
    ----------
    box : numpy.ndarray
        ``(4, 2)`` the region's bounding box in the source, placed: top left,
        top right, bottom right, bottom left as the source has them.
    centre : numpy.ndarray
        ``(2,)`` the box's centre (scaling and turning keep it in place).
    turn : numpy.ndarray
        ``(2,)`` the turning handle, above the middle of the box's top side.
    """

    box: np.ndarray
    centre: np.ndarray
    turn: np.ndarray

    @classmethod
    def of(cls, clone: Clone, zoom: float) -> Handles:
        region = np.asarray(clone.region)
        (x0, y0), (x1, y1) = region.min(axis=0), region.max(axis=0)
        box = clone.similarity.apply(np.array([[x0, y0], [x1, y0], [x1, y1], [x0, y1]]))
        centre = box.mean(axis=0)
        top = 0.5 * (box[0] + box[1])
        up = top - centre
        up /= max(float(np.hypot(*up)), 1e-12)
        return cls(box, centre, top + up * TURN_HANDLE_PX / zoom)

    def grabbed(self, position: tuple[float, float], reach: float) -> str | None:
        """What a press at ``position`` takes: ``"turn"``, ``"scale"``, ``"move"`` or None (outside)."""
        p = np.asarray(position)
        if np.hypot(*(p - self.turn)) <= reach:
            return "turn"
        inside = shapely.contains_xy(shapely.Polygon(self.box), *p)
        small = np.hypot(*(self.box[2] - self.box[0])) < 4 * reach  # mostly corners: a press inside moves it
        if (np.hypot(*(self.box - p).T) <= reach).any() and not (small and inside):
            return "scale"
        return "move" if inside else None


@dataclass(frozen=True)
class Grab:
    """A drag of the handles in progress: what it does and where it started."""

    kind: str
    origin: tuple[float, float]
    similarity: Similarity
    centre: np.ndarray

    def similarity_at(self, event: PointerEvent) -> Similarity:
        """The clone's placement for the pointer at ``event``."""
        p, o, c = np.asarray(event.position), np.asarray(self.origin), self.centre
        if self.kind == "move":
            delta = tuple(p - o)
            return self.similarity.moved(*(constrain(delta) if event.shift else delta))
        if self.kind == "scale":
            factor = np.hypot(*(p - c)) / max(float(np.hypot(*(o - c))), 1e-9)
            scale = min(max(self.similarity.scale * factor, SCALES[0]), SCALES[1])
            return self.similarity.about(c, scale / self.similarity.scale)
        degrees = math.degrees(math.atan2(*(p - c)[::-1]) - math.atan2(*(o - c)[::-1]))
        if event.shift:
            total = round((self.similarity.degrees + degrees) / TURN_STEP) * TURN_STEP
            degrees = total - self.similarity.degrees
        return self.similarity.about(c, 1.0, degrees)


def clone_under(document: Document, position: tuple[float, float]) -> int | None:
    """The index of the topmost visible clone layer whose placed region holds ``position``."""
    for index in range(len(document.layers) - 1, -1, -1):
        layer = document.layers[index]
        if layer.clone is not None and layer.visible and shapely.contains_xy(
                shapely.Polygon(layer.clone.placed_region), *position):
            return index
    return None


class CloneTool(Tool):
    """Move, scale and turn the active clone layer."""

    name = "clone"
    title = "Transform Clone"
    hint = ("Drag inside the box to move the clone, a corner to scale it, the round handle to turn it; "
            "Return keeps the change, Esc drops it; click a clone to choose it")
    shortcut = "T"
    summary = "Move, scale and turn a pasted clone"
    cursor = "arrow"

    def __init__(self, context: ToolContext) -> None:
        super().__init__(context)
        self.label: str | None = None  # the open transaction's step name
        self.grab: Grab | None = None

    @property
    def busy(self) -> bool:
        return self.label is not None or self.grab is not None

    @property
    def clone(self) -> Clone | None:
        """The active layer's clone (None when it is not a clone layer)."""
        return self.context.document.layer.clone

    def paste(self, document: Document, label: str = "Paste Seamless") -> None:
        """Show ``document`` (with a new clone layer, active) as the step ``label`` that Return keeps."""
        self.finish()
        self.context.history.begin(label)
        self.label = label
        self.context.history.preview(document)

    # -- events ------------------------------------------------------------------------------
    def press(self, event: PointerEvent) -> None:
        self.pointer = event.position
        if event.button != "left" or self.grab is not None:
            return
        clone, context = self.clone, self.context
        handles = Handles.of(clone, context.zoom) if clone is not None else None
        kind = handles.grabbed(event.position, context.tolerance) if handles is not None else None
        if kind is not None:
            self.grab = Grab(kind, event.position, clone.similarity, handles.centre)
            return
        self.finish()
        index = clone_under(context.document, event.position)
        if index is not None and index != context.document.active:
            context.history.retarget(layer_edits.select_layer(context.document, index))
        elif index is None:
            context.say("Click inside a clone to transform it (Edit > Paste Seamless makes one)")

    def move(self, event: PointerEvent) -> None:
        self.pointer = event.position
        grab = self.grab
        if grab is None or (self.label is None and not self.context.moved_far(grab.origin, event.position)):
            return
        self._place(grab.similarity_at(event))

    def release(self, event: PointerEvent) -> None:
        self.pointer = event.position
        if event.button in ("left", "none"):
            self.grab = None

    def key(self, name: str, modifiers: frozenset[str] = frozenset()) -> bool:
        if name == ESCAPE and self.busy:
            self.cancel()
        elif name in (RETURN, ENTER) and self.label is not None:
            self.finish()
        elif name in ARROWS and self.clone is not None and self.grab is None:
            step = 10.0 if "shift" in modifiers else 1.0
            self._place(self.clone.similarity.moved(*(step * np.asarray(ARROWS[name]))))
        else:
            return False
        return True

    def _place(self, similarity: Similarity) -> None:
        """Preview the active clone placed by ``similarity`` (opening the step); a placement off the canvas is
        refused with a message, the last one staying."""
        context = self.context
        try:
            placed = place_clone(context.document, context.document.active, similarity)
        except EditRefused as error:
            context.say(f"Cannot place the clone there: {error}")
            return
        if self.label is None:
            self.label = "Transform Clone"
            context.history.begin(self.label)
        context.history.preview(placed)

    def cancel(self) -> None:
        """Drop every change since the step began (a pasted clone disappears)."""
        self.grab = None
        if self.label is not None:
            self.label = None
            self.context.history.cancel()

    def finish(self) -> None:
        """Keep the changes as one step."""
        self.grab = None
        if self.label is not None:
            self.label = None
            self.context.history.commit()

    # -- drawing -----------------------------------------------------------------------------
    def draw(self) -> list:
        clone = self.clone
        if clone is None:
            return []
        handles = Handles.of(clone, self.context.zoom)
        top = 0.5 * (handles.box[0] + handles.box[1])
        return [
            Polyline(clone.placed_region, "preview", closed=True),
            Polyline(handles.box, "selected", closed=True),
            Segments(np.array([[top, handles.turn]]), "handle"),
            Markers.of(handles.box, "anchor"),
            Markers.of([handles.turn], "handle"),
        ]
