"""The window's Layer commands: new, duplicate, delete, merge down, masks and Colour Adjust.

Each command is one named undo step through the Layers panel, refused with a
message in the status bar when it cannot be done (deleting the last layer,
merging the bottom one).  ``LayerCommands`` sees the window only through
``editing.Editing``.
"""

from __future__ import annotations

from collections.abc import Callable

from PySide6.QtWidgets import QWidget

from ..model import Document, Mask, layer_edits
from ..tools import Selection
from .color_adjust import ColorAdjustDialog
from .editing import Editing
from .layers_panel import LayersPanel
from .menus import LAYER_ACTIONS


class LayerCommands:
    """The Layer menu's commands on the document in front.

    Parameters
    ----------
    editing : Editing
        The window.
    panel : LayersPanel
        Applies each edit (after ``editing.settle_edits``) and says why one was refused.
    actions : dict of str to QAction
        The window's actions; the Layer ones are enabled as the active layer allows.
    parent : QWidget
        The Colour Adjust dialog's parent.

    Attributes
    ----------
    color_dialog : ColorAdjustDialog or None
        The last Colour Adjust dialog opened.
    """

    def __init__(self, editing: Editing, panel: LayersPanel, actions: dict, parent: QWidget) -> None:
        self.editing, self.panel, self.actions, self.parent = editing, panel, actions, parent
        self.color_dialog: ColorAdjustDialog | None = None
        self._actions_state: tuple | None = None  # what the Layer actions show; they are set again when it changes

    def _layer_edit(self, edit: Callable[[Document], Document], label: str) -> None:
        self.panel.apply(edit, label)  # which makes way for it (the window's settle_edits)

    def new_layer(self) -> None:
        self._layer_edit(layer_edits.add_layer, "New Layer")

    def duplicate_layer(self) -> None:
        self._layer_edit(layer_edits.duplicate_layer, "Duplicate Layer")

    def delete_layer(self) -> None:
        self._layer_edit(layer_edits.remove_layer, "Delete Layer")

    def merge_down(self) -> None:
        self._layer_edit(layer_edits.merge_down, "Merge Down")

    def flatten(self) -> None:
        self._layer_edit(layer_edits.flatten, "Flatten Image")

    def add_mask(self) -> None:
        self._layer_edit(layer_edits.add_mask, "Add Mask")

    def add_hiding_mask(self) -> None:
        self._layer_edit(lambda d: layer_edits.add_mask(d, None, Mask(base=0.0)), "Add Mask")

    def delete_mask(self) -> None:
        self._layer_edit(layer_edits.remove_mask, "Delete Mask")

    def invert_mask(self) -> None:
        self._layer_edit(layer_edits.invert_mask, "Invert Mask")

    def toggle_mask(self) -> None:
        workspace = self.editing.workspace
        mask = workspace.history.document.layer.mask if workspace is not None else None
        if mask is not None:
            self._layer_edit(lambda d: layer_edits.set_mask_enabled(d, None, not mask.enabled),
                             "Enable Mask" if not mask.enabled else "Disable Mask")

    def edit_mask(self) -> None:
        """Turn the tools to the active layer's mask, or back to the layer."""
        workspace = self.editing.workspace
        if workspace is None or self.editing.busy:
            return
        if workspace.history.document.layer.mask is not None and self.editing.settle_edits():
            workspace.context.selection = Selection()  # ids of the layer's items mean nothing in its mask
            self.panel.retarget(lambda d: layer_edits.select_layer(d, d.active, not d.editing_mask))
        self.update_actions()

    def adjust_colors(self) -> None:
        """Open the Colour Adjust dialog on the active layer (live preview; OK is one step)."""
        if not self.editing.settle_edits():
            return
        self.color_dialog = ColorAdjustDialog(self.editing.workspace.history, self.parent)
        self.color_dialog.finished.connect(lambda _: self.editing.update_state())
        self.color_dialog.open()

    def update_actions(self) -> None:
        """Enable what the active layer allows; check Edit Mask while the tools act on a mask."""
        actions, workspace = self.actions, self.editing.workspace
        document = workspace.history.document if workspace is not None else None
        free = document is not None and not self.editing.busy
        mask = document.layer.mask if document is not None else None
        state = (free, document is not None and (len(document.layers), document.active, document.editing_mask,
                                                 document.layer.clone is None),
                 mask is not None and mask.enabled, mask is None)
        if state == self._actions_state:  # this runs on every pointer move: setting actions is not free
            return
        self._actions_state = state
        for name in LAYER_ACTIONS:
            actions[name].setEnabled(free)
        if document is None:
            return
        actions["delete_layer"].setEnabled(free and len(document.layers) > 1)
        actions["merge_down"].setEnabled(free and document.active > 0)
        actions["flatten"].setEnabled(free and len(document.layers) > 1)
        clone = document.layer.clone is not None  # a clone layer's mask is its region
        actions["add_mask"].setEnabled(free and mask is None and not clone)
        actions["add_hiding_mask"].setEnabled(free and mask is None and not clone)
        for name in ("delete_mask", "invert_mask", "disable_mask", "edit_mask"):
            actions[name].setEnabled(free and mask is not None)
        actions["disable_mask"].setText("Ena&ble Mask" if mask is not None and not mask.enabled else "Disa&ble Mask")
        actions["edit_mask"].setChecked(document.editing_mask)
