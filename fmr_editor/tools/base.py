"""The tool protocol and drags: a press, moves and a release that end in one commit or cancel.

A tool turns pointer events into edits.  While the pointer is held it
delegates to a ``Drag``; a drag that edits opens a history transaction once
the pointer has moved past the drag threshold (or at once when the press
itself edits), previews a document computed from the state before the drag
on every move, and commits on release, so each drag is exactly one undo step
and Esc (``cancel``) restores the document from before it.
"""

from __future__ import annotations

from ..model import Document
from .context import ToolContext
from .events import ESCAPE, PointerEvent


class Drag:
    """A gesture in progress; the default changes nothing."""

    def __init__(self, context: ToolContext, event: PointerEvent) -> None:
        self.context = context
        self.origin = event.position
        self.position = event.position

    def move(self, event: PointerEvent) -> None:
        self.position = event.position

    def release(self, event: PointerEvent) -> None:
        """End the gesture, keeping what it did."""

    def cancel(self) -> None:
        """End the gesture, undoing what it did."""

    def overlay(self) -> list:
        return []


class EditDrag(Drag):
    """A drag that edits the document as one undo step named ``label``.

    Parameters
    ----------
    context : ToolContext
    event : PointerEvent
        The press.
    label : str
        The step's name ("Move Stop").
    pressed : Document, optional
        A document the press itself makes (e.g. a stop added under the
        pointer): the transaction opens at once and shows it, and a release
        without moving records it.

    Notes
    -----
    ``start`` is the document before the drag; subclasses implement
    ``edited(event)``, the document to show for the pointer at ``event``.
    """

    def __init__(self, context: ToolContext, event: PointerEvent, label: str,
                 pressed: Document | None = None) -> None:
        super().__init__(context, event)
        self.label = label
        self.start = context.document
        self.selection = context.selection  # restored by cancel
        self.base = pressed if pressed is not None else self.start
        self.open = False
        if pressed is not None:
            self._begin()
            context.history.preview(pressed)

    def _begin(self) -> None:
        self.context.history.begin(self.label)
        self.open = True

    def edited(self, event: PointerEvent) -> Document:
        raise NotImplementedError

    def move(self, event: PointerEvent) -> None:
        super().move(event)
        if not self.open:
            if not self.context.moved_far(self.origin, event.position):
                return
            self._begin()
        self.context.history.preview(self.edited(event))

    def release(self, event: PointerEvent) -> None:
        if self.open:
            self.open = False
            self.context.history.commit()
            self.committed()

    def committed(self) -> None:
        """Called after a commit (e.g. to point the selection at the moved item)."""

    def cancel(self) -> None:
        if self.open:
            self.open = False
            self.context.history.cancel()
            self.context.selection = self.selection.within(self.context.document)


class Tool:
    """Base of every tool: routes pointer events to the drag in progress.

    Subclasses set ``name`` (registry key), ``title`` (for menus), ``shortcut``
    (a key hint) and ``cursor`` (a hint for the view: ``"arrow"``,
    ``"crosshair"``, ``"pen"``, ``"picker"``), and implement ``start(event)``
    (the drag a left press begins, or None), and optionally ``hover``,
    ``on_key`` and ``draw``.

    Parameters
    ----------
    context : ToolContext
    """

    name = ""
    title = ""
    shortcut = ""
    cursor = "arrow"
    #: A few words on what the tool is for (its tooltip).
    summary = ""
    #: One line for the status bar: what the tool does and how.
    hint = ""

    def __init__(self, context: ToolContext) -> None:
        self.context = context
        self.drag: Drag | None = None
        self.pointer: tuple[float, float] | None = None  # last known pointer position

    @property
    def busy(self) -> bool:
        """True while a gesture (or a tool's own work, e.g. a path) is in progress."""
        return self.drag is not None

    # -- events ------------------------------------------------------------------------------
    def press(self, event: PointerEvent) -> None:
        """A button went down.  Only the left button starts anything."""
        self.pointer = event.position
        if event.button == "left" and self.drag is None:
            self.drag = self.start(event)

    def move(self, event: PointerEvent) -> None:
        """The pointer moved (with or without a button held)."""
        self.pointer = event.position
        if self.drag is not None:
            self.drag.move(event)
        else:
            self.hover(event)

    def release(self, event: PointerEvent) -> None:
        """A button went up: the drag ends and is kept."""
        self.pointer = event.position
        if self.drag is not None and event.button in ("left", "none"):
            drag, self.drag = self.drag, None
            drag.release(event)

    def key(self, name: str, modifiers: frozenset[str] = frozenset()) -> bool:
        """A key was pressed; returns True when the tool used it.

        Escape during a drag cancels it (the document returns to the state
        before the drag); other keys go to ``on_key``.
        """
        if name == ESCAPE and self.busy:
            self.cancel()
            return True
        return self.on_key(name, frozenset(modifiers))

    def cancel(self) -> None:
        """Abandon whatever is in progress (Esc, focus lost); the document is as before it."""
        if self.drag is not None:
            drag, self.drag = self.drag, None
            drag.cancel()

    def finish(self) -> None:
        """End what is in progress keeping it (switching tools); by default the same as ``cancel``."""
        self.cancel()

    def overlay(self) -> list:
        """Drawable primitives (``tools.overlay``) for the view, in document pixels."""
        return self.draw() + (self.drag.overlay() if self.drag is not None else [])

    # -- for subclasses ----------------------------------------------------------------------
    def start(self, event: PointerEvent) -> Drag | None:
        return None

    def hover(self, event: PointerEvent) -> None:
        """The pointer moved with no drag in progress."""

    def on_key(self, name: str, modifiers: frozenset[str]) -> bool:
        return False

    def draw(self) -> list:
        return []
