"""The window's Layer commands: new, duplicate, delete, merge down, masks and Colour Adjust.

Mixed into ``MainWindow`` (as ``file_commands``): each command is one named
undo step through the Layers panel, refused with a message in the status bar
when it cannot be done (deleting the last layer, merging the bottom one).
"""

from __future__ import annotations

from collections.abc import Callable

from ..model import Document, Mask, layer_edits
from ..tools import Selection
from .color_adjust import ColorAdjustDialog
from .menus import LAYER_ACTIONS


class LayerCommands:
    """Layer menu commands of ``MainWindow`` (needs its ``workspace``, ``layers_panel``, ``actions``)."""

    color_dialog: ColorAdjustDialog | None = None
    _layer_actions_state: tuple | None = None  # what the Layer actions show; they are set again when it changes

    def _layer_edit(self, edit: Callable[[Document], Document], label: str) -> None:
        self.layers_panel.apply(edit, label)  # which makes way for it (the window's _settle_edits)

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
        mask = self.workspace.history.document.layer.mask if self.workspace is not None else None
        if mask is not None:
            self._layer_edit(lambda d: layer_edits.set_mask_enabled(d, None, not mask.enabled),
                             "Enable Mask" if not mask.enabled else "Disable Mask")

    def edit_mask(self) -> None:
        """Turn the tools to the active layer's mask, or back to the layer."""
        if self.workspace is None or self._busy:
            return
        if self.workspace.history.document.layer.mask is not None and self._settle_edits():
            self.workspace.context.selection = Selection()  # ids of the layer's items mean nothing in its mask
            self.layers_panel.retarget(lambda d: layer_edits.select_layer(d, d.active, not d.editing_mask))
        self._update_layer_actions()

    def adjust_colors(self) -> None:
        """Open the Colour Adjust dialog on the active layer (live preview; OK is one step)."""
        if not self._settle_edits():
            return
        self.color_dialog = ColorAdjustDialog(self.workspace.history, self)
        self.color_dialog.finished.connect(lambda _: self._update_state())
        self.color_dialog.open()

    def _update_layer_actions(self) -> None:
        """Enable what the active layer allows; check Edit Mask while the tools act on a mask."""
        actions, workspace = self.actions, self.workspace
        document = workspace.history.document if workspace is not None else None
        free = document is not None and not self._busy
        mask = document.layer.mask if document is not None else None
        state = (free, document is not None and (len(document.layers), document.active, document.editing_mask,
                                                 document.layer.clone is None),
                 mask is not None and mask.enabled, mask is None)
        if state == self._layer_actions_state:  # this runs on every pointer move: setting actions is not free
            return
        self._layer_actions_state = state
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
