"""The window's Copy, Paste and Paste Seamless, between any of its open documents.

``ClipCommands`` sees the window through ``editing.Editing``.  Copy takes the active
layer's items with the lasso's region (``model.clone_edits.copy_region``)
into the window's clipboard; Paste Seamless adds a clone layer above the
active layer of the active document and hands it to the Transform Clone
tool, whose handles place it until Return keeps it as the step "Paste
Seamless"; Paste adds the copied curves and points as they are to the
active layer ("Paste").  A pasted region lands where it was copied from
when it fits the canvas, else in the middle of the canvas.
"""

from __future__ import annotations

from PySide6.QtWidgets import QWidget

from ..model import Document
from ..model.clone_edits import Copied, copy_region, paste_curves, paste_position, paste_seamless
from ..tools import Selection
from .editing import Editing
from .refusals import reporting


class ClipCommands:
    """Edit > Copy, Paste and Paste Seamless, on the document in front.

    Parameters
    ----------
    editing : Editing
        The window.
    actions : dict of str to QAction
        The window's actions (Copy, Paste and Paste Seamless are enabled here).
    canvas : QWidget
        Takes the keyboard during a placement (Return and Esc go to the tool through it).

    Attributes
    ----------
    clipboard : Copied or None
        What Copy took last, for any open document to paste.
    """

    def __init__(self, editing: Editing, actions: dict, canvas: QWidget) -> None:
        self.editing, self.actions, self.canvas = editing, actions, canvas
        self.clipboard: Copied | None = None

    def copy(self) -> None:
        """Copy the active layer inside the lasso's region (Ctrl+C)."""
        workspace, say = self.editing.workspace, self.editing.say
        if workspace is None or self.editing.busy:
            return
        region = workspace.context.region
        if region is None:
            say("Nothing to copy: select a region with the Lasso (L) first")
            return
        with reporting(say, "Cannot copy") as outcome:
            self.clipboard = copy_region(workspace.history.document, region)
        if outcome.failed:
            return
        say(f"Copied {self.clipboard.name} inside the selection")
        self.update_actions()

    def _pasting(self) -> tuple[Document, Copied] | None:
        """The active document and the clipboard, when a paste can go ahead (``settle_edits``)."""
        if self.clipboard is None or not self.editing.settle_edits():
            return None
        self.canvas.setFocus()  # Return and Esc go to the tool through the canvas
        return self.editing.workspace.history.document, self.clipboard

    def paste_seamless(self) -> None:
        """Add the clipboard as a clone layer above the active layer, placed with handles (Ctrl+Shift+V)."""
        pasting = self._pasting()
        if pasting is None:
            return
        document, copied = pasting
        with reporting(self.editing.say, "Cannot paste") as outcome:
            pasted = paste_seamless(document, copied, paste_position(copied, document))
        if outcome.failed:
            return
        self.editing.set_tool("clone")
        self.editing.tool.paste(pasted)
        self.editing.say(f"Place the clone of {copied.name}")  # the tool's hint says how
        self.editing.after_tool()

    def paste(self) -> None:
        """Add the clipboard's curves and points as they are to the active layer, selected (Ctrl+V)."""
        pasting = self._pasting()
        if pasting is None:
            return
        document, copied = pasting
        with reporting(self.editing.say, "Cannot paste") as outcome:
            pasted = paste_curves(document, copied, paste_position(copied, document).offset)
        if outcome.failed:
            return
        context = self.editing.workspace.context
        context.history.apply(pasted, "Paste")
        new_curves = [c.id for c in pasted.curves[len(document.curves):]]
        new_points = [p.id for p in pasted.points[len(document.points):]]
        context.selection = Selection.of(curves=new_curves, points=new_points)
        self.editing.say(f"Pasted {len(new_curves)} curves and {len(new_points)} points into "
                         f"{pasted.layer.name}; they are selected (V moves them)")
        self.editing.after_tool()

    def update_actions(self) -> None:
        open_and_free = self.editing.workspace is not None and not self.editing.busy
        self.actions["copy"].setEnabled(open_and_free)
        for name in ("paste", "paste_seamless"):
            self.actions[name].setEnabled(open_and_free and self.clipboard is not None)
