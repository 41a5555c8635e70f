"""The window's Copy, Paste and Paste Seamless, between any of its open documents.

``ClipCommands`` is mixed into ``MainWindow``.  Copy takes the active
layer's items with the lasso's region (``model.clone_edits.copy_region``)
into the window's clipboard; Paste Seamless adds a clone layer above the
active layer of the active document and hands it to the Transform Clone
tool, whose handles place it until Return keeps it as the step "Paste
Seamless"; Paste adds the copied curves and points as they are to the
active layer ("Paste").  A pasted region lands where it was copied from
when it fits the canvas, else in the middle of the canvas.
"""

from __future__ import annotations

from ..model import Document
from ..model.clone_edits import Copied, copy_region, paste_curves, paste_position, paste_seamless
from ..tools import Selection
from .refusals import reporting


class ClipCommands:
    """Edit > Copy, Paste and Paste Seamless of ``MainWindow`` (needs its ``workspace``, tools and status)."""

    clipboard: Copied | None = None

    def copy(self) -> None:
        """Copy the active layer inside the lasso's region (Ctrl+C)."""
        workspace = self.workspace
        if workspace is None or self.busy:
            return
        region = workspace.context.region
        if region is None:
            self.status_label.setText("Nothing to copy: select a region with the Lasso (L) first")
            return
        with reporting(self.status_label.setText, "Cannot copy") as outcome:
            self.clipboard = copy_region(workspace.history.document, region)
        if outcome.failed:
            return
        self.status_label.setText(f"Copied {self.clipboard.name} inside the selection")
        self._update_actions()

    def _pasting(self) -> tuple[Document, Copied] | None:
        """The active document and the clipboard, when a paste can go ahead (``settle_edits``)."""
        if self.clipboard is None or not self.settle_edits():
            return None
        self.canvas.setFocus()  # Return and Esc go to the tool through the canvas
        return self.workspace.history.document, self.clipboard

    def paste_seamless(self) -> None:
        """Add the clipboard as a clone layer above the active layer, placed with handles (Ctrl+Shift+V)."""
        pasting = self._pasting()
        if pasting is None:
            return
        document, copied = pasting
        with reporting(self.status_label.setText, "Cannot paste") as outcome:
            pasted = paste_seamless(document, copied, paste_position(copied, document))
        if outcome.failed:
            return
        self.set_tool("clone")
        self.tool.paste(pasted)
        self.status_label.setText(f"Place the clone of {copied.name}")  # the tool's hint says how
        self._after_tool()

    def paste(self) -> None:
        """Add the clipboard's curves and points as they are to the active layer, selected (Ctrl+V)."""
        pasting = self._pasting()
        if pasting is None:
            return
        document, copied = pasting
        with reporting(self.status_label.setText, "Cannot paste") as outcome:
            pasted = paste_curves(document, copied, paste_position(copied, document).offset)
        if outcome.failed:
            return
        context = self.workspace.context
        context.history.apply(pasted, "Paste")
        new_curves = [c.id for c in pasted.curves[len(document.curves):]]
        new_points = [p.id for p in pasted.points[len(document.points):]]
        context.selection = Selection.of(curves=new_curves, points=new_points)
        self.status_label.setText(f"Pasted {len(new_curves)} curves and {len(new_points)} points into "
                                  f"{pasted.layer.name}; they are selected (V moves them)")
        self._after_tool()

    def _update_clip_actions(self) -> None:
        open_and_free = self.workspace is not None and not self.busy
        self.actions["copy"].setEnabled(open_and_free)
        for name in ("paste", "paste_seamless"):
            self.actions[name].setEnabled(open_and_free and self.clipboard is not None)
