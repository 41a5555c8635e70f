"""The eyedropper: sets the foreground colour (Alt: the background) from the rendered image.

Pressing samples the colour under the pointer (``ToolContext.sample``);
dragging keeps sampling; Esc during the drag puts the colour back.  The
document does not change.
"""

from __future__ import annotations

from .base import Drag, Tool
from .context import ToolContext
from .events import PointerEvent
from .overlay import Markers


class Sampling(Drag):
    """Sample while the pointer is held."""

    def __init__(self, context: ToolContext, event: PointerEvent) -> None:
        super().__init__(context, event)
        self.attribute = "secondary_color" if event.alt else "color"
        self.before = getattr(context.options, self.attribute)
        self.take(event.position)

    def take(self, position) -> None:
        color = tuple(float(v) for v in self.context.sample(*position))
        setattr(self.context.options, self.attribute, color)

    def move(self, event: PointerEvent) -> None:
        super().move(event)
        self.take(event.position)

    def cancel(self) -> None:
        setattr(self.context.options, self.attribute, self.before)

    def overlay(self) -> list:
        return [Markers.of([self.position], "sample", colors=[getattr(self.context.options, self.attribute)])]


class EyedropperTool(Tool):
    """Pick colours from the image."""

    name = "eyedropper"
    title = "Eyedropper"
    hint = "Click to take the foreground colour from the image; Alt+click for the background colour"
    shortcut = "I"
    summary = "Take a colour from the image"
    cursor = "picker"

    def start(self, event: PointerEvent) -> Sampling:
        return Sampling(self.context, event)
