"""The lasso: select a region of the canvas, freehand or corner by corner, for Copy.

- Dragging draws the outline freehand; releasing closes it.
- Clicks place corners one by one (a line follows the pointer from the last
  one); Return, Enter, a double click or a click on the first corner closes
  the polygon.  BackSpace or Delete removes the last corner.
- Esc drops the outline being drawn, or else clears the selection.
- The closed outline becomes ``ToolContext.region``: what it encloses on
  the canvas (it may be drawn across the canvas edge), without holes.  An
  outline that crosses itself, or that the canvas edge cuts, may enclose
  several areas: the largest is kept, and the status bar says so.
- Delete and BackSpace do not delete through a selection (that is the
  Select tool's): with no outline drawn, they only say so.

Choosing a region is not an undo step (nor is any selection in this editor).
"""

from __future__ import annotations

import numpy as np
import shapely

from ..model import EditRefused
from .base import Tool
from .context import ToolContext
from .events import BACKSPACE, DELETE, ENTER, ESCAPE, RETURN, PointerEvent
from .overlay import Markers, Polyline

#: Corners of a selection closer than this to the line through their neighbours are dropped, document pixels.
SIMPLIFY = 0.05


def enclosed_region(outline: np.ndarray, width: float, height: float) -> tuple[np.ndarray, int]:
    """The largest area ``outline`` encloses on a ``width x height`` canvas, as one simple polygon.

    Parameters
    ----------
    outline : numpy.ndarray
        ``(k, 2)`` a closed outline's corners in document pixels (it may cross
        itself and the canvas edge).

    Returns
    -------
    region : numpy.ndarray
        ``(m, 2)`` its corners, without the closing repeat.
    parts : int
        How many separate areas it enclosed (the others are dropped).

    Raises
    ------
    EditRefused
        When it encloses no area on the canvas.
    """
    outline = np.asarray(outline, dtype=np.float64)
    if len(outline) < 3:
        raise EditRefused("a selection needs at least three corners")
    shape = shapely.make_valid(shapely.Polygon(outline))
    shape = shapely.intersection(shape, shapely.box(0.0, 0.0, width, height))
    parts = [part for part in getattr(shape, "geoms", [shape]) if part.geom_type == "Polygon" and part.area > 0]
    if not parts:
        raise EditRefused("the selection encloses no area on the canvas")
    largest = shapely.simplify(max(parts, key=lambda part: part.area), SIMPLIFY)
    return np.asarray(largest.exterior.coords)[:-1], len(parts)


class LassoTool(Tool):
    """Select a region, freehand or by corners."""

    name = "lasso"
    title = "Lasso"
    hint = ("Drag to select freehand, or click corners; Return or a click on the first corner closes the selection; "
            "Esc clears it; Ctrl+C copies the active layer inside it")
    shortcut = "L"
    summary = "Select a region to copy, paste or clone seamlessly"
    cursor = "crosshair"

    def __init__(self, context: ToolContext) -> None:
        super().__init__(context)
        self.outline: list[tuple[float, float]] = []  # corners (or freehand points) being drawn
        self.pressed_at: tuple[float, float] | None = None
        self.freehand = False  # the held pointer has passed the drag threshold

    @property
    def busy(self) -> bool:
        return bool(self.outline)

    # -- events ------------------------------------------------------------------------------
    def press(self, event: PointerEvent) -> None:
        self.pointer = event.position
        if event.button != "left":
            return
        if event.clicks == 2:  # the first click of the double click placed the last corner
            self.finish()
            return
        if len(self.outline) >= 3 and self._near(self.outline[0], event.position):
            self.finish()
            return
        self.pressed_at, self.freehand = event.position, False
        self.outline.append(event.position)

    def move(self, event: PointerEvent) -> None:
        self.pointer = event.position
        if self.pressed_at is None:
            return
        self.freehand = self.freehand or self.context.moved_far(self.pressed_at, event.position)
        if self.freehand and not self._near(self.outline[-1], event.position, 0.5):
            self.outline.append(event.position)

    def release(self, event: PointerEvent) -> None:
        self.pointer = event.position
        if self.pressed_at is None or event.button not in ("left", "none"):
            return
        freehand, self.pressed_at, self.freehand = self.freehand, None, False
        if freehand:
            self.outline.append(event.position)
            self.finish()

    def _near(self, corner: tuple[float, float], position: tuple[float, float], screen_px: float | None = None) -> bool:
        reach = self.context.tolerance if screen_px is None else screen_px / self.context.zoom
        return bool(np.hypot(corner[0] - position[0], corner[1] - position[1]) <= reach)

    def key(self, name: str, modifiers: frozenset[str] = frozenset()) -> bool:
        if name == ESCAPE:
            if self.outline:
                self.cancel()
                return True
            if self.context.region is not None:
                self.context.region = None
                return True
            return False
        if not self.outline:
            if name in (BACKSPACE, DELETE) and self.context.region is not None:
                self.context.say("The lasso's selection is for Copy: Delete removes what the Select tool (V) selected")
                return True
            return False
        if name in (RETURN, ENTER):
            self.finish()
        elif name in (BACKSPACE, DELETE) and self.pressed_at is None:
            self.outline.pop()
        else:
            return False
        return True

    def cancel(self) -> None:
        """Drop the outline being drawn (the selection stays as it was)."""
        self.outline, self.pressed_at, self.freehand = [], None, False

    def finish(self) -> None:
        """Close the outline being drawn: what it encloses on the canvas becomes the selection."""
        outline = self.outline
        self.cancel()
        if not outline:
            return
        context = self.context
        document = context.document
        try:
            region, parts = enclosed_region(np.array(outline), document.width, document.height)
        except EditRefused as error:
            context.say(f"No selection: {error}")
            return
        context.region = region
        context.say(f"The outline encloses {parts} separate areas on the canvas (where it crosses itself or the "
                    "canvas edge cuts it): the largest is selected" if parts > 1 else "")

    # -- drawing -----------------------------------------------------------------------------
    def draw(self) -> list:
        if not self.outline:
            return []
        out: list = [Polyline(np.array(self.outline), "ants")]
        if self.pressed_at is None and self.pointer is not None:  # the side the next click adds
            out.append(Polyline(np.array([self.outline[-1], self.pointer]), "preview"))
        if not self.freehand:
            first = np.arange(len(self.outline)) == 0
            out.append(Markers.of(self.outline, "anchor", first))
        return out
