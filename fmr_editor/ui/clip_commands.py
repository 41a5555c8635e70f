"""The window's Copy, Paste and Paste Seamless, between any of its open documents.

``ClipCommands`` is mixed into ``MainWindow``.  Copy takes the active
layer's items with the lasso's region (``model.clone_edits.copy_region``)
into the window's clipboard; Paste Seamless adds a clone layer above the
active layer of the active document and hands it to the Transform Clone
tool, whose handles place it until Return keeps it as the step "Paste
Seamless"; Paste adds the copied curves and points as they are ("Paste").
A pasted region lands where it was copied from when it fits the canvas,
else in the middle of the canvas.
"""

from __future__ import annotations

import numpy as np
import shapely

from ..model import Document
from ..model.clone import Similarity
from ..model.clone_edits import Copied, copy_region, paste_plain, paste_seamless
from ..tools import Selection


def landing(copied: Copied, document: Document) -> Similarity:
    """Where a paste of ``copied`` goes in ``document``: in place when it fits the canvas, else centred."""
    low, high = copied.region.min(axis=0), copied.region.max(axis=0)
    if (low >= 0).all() and high[0] <= document.width and high[1] <= document.height:
        return Similarity()
    centroid = shapely.Polygon(copied.region).centroid
    return Similarity(offset=(document.width / 2 - centroid.x, document.height / 2 - centroid.y))


class ClipCommands:
    """Edit > Copy, Paste and Paste Seamless of ``MainWindow`` (needs its ``workspace``, tools and status)."""

    clipboard: Copied | None = None

    def copy(self) -> None:
        """Copy the active layer inside the lasso's region (Ctrl+C)."""
        workspace = self.workspace
        if workspace is None or self._busy:
            return
        region = workspace.context.region
        if region is None:
            self.status_label.setText("Nothing to copy: select a region with the Lasso (L) first")
            return
        try:
            self.clipboard = copy_region(workspace.history.document, region)
        except ValueError as error:
            self.status_label.setText(f"Cannot copy: {error}")
            return
        self.status_label.setText(f"Copied {self.clipboard.name} inside the selection")
        self._update_actions()

    def _pasting(self) -> tuple[Document, Copied] | None:
        """The active document and the clipboard, when a paste can go ahead (any tool's work finished)."""
        workspace, copied = self.workspace, self.clipboard
        if workspace is None or copied is None or self._busy:
            return None
        self.tool.finish()
        return workspace.history.document, copied

    def paste_seamless(self) -> None:
        """Add the clipboard as a clone layer above the active layer, placed with handles (Ctrl+Shift+V)."""
        pasting = self._pasting()
        if pasting is None:
            return
        document, copied = pasting
        try:
            pasted = paste_seamless(document, copied, landing(copied, document))
        except ValueError as error:
            self.status_label.setText(f"Cannot paste: {error}")
            return
        self.set_tool("clone")
        self.tool.paste(pasted)
        self.status_label.setText("Place the clone: drag to move, corners scale, the round handle turns; "
                                  "Return keeps it, Esc drops it")
        self._after_tool()

    def paste(self) -> None:
        """Add the clipboard's curves and points as they are, in a layer above the active one (Ctrl+V)."""
        pasting = self._pasting()
        if pasting is None:
            return
        document, copied = pasting
        offset = landing(copied, document).offset
        pasted = paste_plain(document, copied, offset)
        context = self.workspace.context
        context.history.apply(pasted, "Paste")
        layer = context.document.layer
        context.selection = Selection.of(curves=[c.id for c in layer.curves], points=[p.id for p in layer.points])
        self.status_label.setText(f"Pasted {len(layer.curves)} curves and {len(layer.points)} points "
                                  f"as {layer.name}")
        self._after_tool()

    def _update_clip_actions(self) -> None:
        open_and_free = self.workspace is not None and not self._busy
        self.actions["copy"].setEnabled(open_and_free)
        for name in ("paste", "paste_seamless"):
            self.actions[name].setEnabled(open_and_free and self.clipboard is not None)


def canvas_region(document: Document) -> np.ndarray:
    """The whole canvas of ``document`` as a region (Select All)."""
    w, h = float(document.width), float(document.height)
    return np.array([[0.0, 0.0], [w, 0.0], [w, h], [0.0, h]])
