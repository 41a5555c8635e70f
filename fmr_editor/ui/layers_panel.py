"""The Layers panel: the stack top first, as in Krita and Inkscape.

Each row has an eye (show or hide), the name (double click renames) and a
mark for a mask; dragging a row reorders the stack.  Selecting a row makes
that layer the tools' target (not an undo step, as in Krita).  Below the
list: the active layer's opacity and buttons for the window's Layer actions
(``layer_commands``).  Every change is one named undo step through the history.
"""

from __future__ import annotations

from collections.abc import Callable

from PySide6.QtCore import Qt, QTimer, Signal
from PySide6.QtGui import QColor, QIcon, QPainter, QPen, QPixmap
from PySide6.QtWidgets import (
    QAbstractItemView,
    QHBoxLayout,
    QLabel,
    QListWidget,
    QListWidgetItem,
    QMenu,
    QSlider,
    QToolButton,
    QVBoxLayout,
    QWidget,
)

from ..model import Document, layer_edits
from ..model.history import History
from .refusals import reporting

#: Buttons under the list: (window action, short text); the mask button's menu holds MASK_ACTIONS.
BUTTONS = (("new_layer", "+"), ("duplicate_layer", "Dup"), ("delete_layer", "\u2212"), ("mask", "Mask"),
           ("adjust_colors", "Adjust\u2026"))
MASK_ACTIONS = ("add_mask", "add_hiding_mask", "delete_mask", "invert_mask", "disable_mask", "edit_mask", None,
                "merge_down", "flatten")


class LayersPanel(QWidget):
    """The document's layers; ``bind`` shows a document's history, which the panel then follows by itself.

    Parameters
    ----------
    actions : dict of str to QAction
        The window's Layer actions (``menus.ACTIONS``), shown as the panel's buttons.
    settle : callable, optional
        ``settle() -> bool``, called before each change: makes way for it
        (the window's tool finishes its work) or says it cannot be done now.
    parent : QWidget, optional

    Signals
    -------
    failed(str)
        An action could not be done (the message says why).
    """

    failed = Signal(str)

    def __init__(self, actions: dict, settle: Callable[[], bool] = lambda: True, parent=None) -> None:
        super().__init__(parent)
        self._settle = settle
        self.list = QListWidget(self)
        self.list.setObjectName("layers")
        self.list.setDragDropMode(QAbstractItemView.DragDropMode.InternalMove)
        self.list.setEditTriggers(QAbstractItemView.EditTrigger.DoubleClicked)
        self.opacity = QSlider(Qt.Orientation.Horizontal, self)
        self.opacity.setRange(0, 100)
        self.opacity.setToolTip("Opacity of the active layer")
        self.opacity_label = QLabel("100%", self)
        # as wide as "100%" whatever it says, so that the slider keeps its length under the pointer
        self.opacity_label.setFixedWidth(self.opacity_label.fontMetrics().horizontalAdvance("100%"))
        self.opacity_label.setAlignment(Qt.AlignmentFlag.AlignRight | Qt.AlignmentFlag.AlignVCenter)
        self.mask_menu = QMenu(self)
        for name in MASK_ACTIONS:
            if name is None:
                self.mask_menu.addSeparator()
            else:
                self.mask_menu.addAction(actions[name])
        self.buttons = {name: self._button(actions.get(name), text) for name, text in BUTTONS}
        self.buttons["mask"].setToolTip("Layer mask")
        self.buttons["mask"].setMenu(self.mask_menu)
        self.buttons["mask"].setPopupMode(QToolButton.ToolButtonPopupMode.InstantPopup)
        for action in self.mask_menu.actions():  # the button is enabled while its menu has something to do
            action.changed.connect(self._enable_mask_button)
        self._enable_mask_button()
        opacity_row = QHBoxLayout()
        opacity_row.addWidget(QLabel("Opacity", self))
        opacity_row.addWidget(self.opacity, 1)
        opacity_row.addWidget(self.opacity_label)
        button_row = QHBoxLayout()
        for button in self.buttons.values():
            button_row.addWidget(button)
        button_row.addStretch(1)
        layout = QVBoxLayout(self)
        layout.setContentsMargins(0, 0, 0, 0)
        layout.addWidget(self.list, 1)
        layout.addLayout(opacity_row)
        layout.addLayout(button_row)
        self._history: History | None = None
        self._shown: tuple | None = None  # _summary of the document shown
        self._connect()

    def _button(self, action, text: str) -> QToolButton:
        """A small button for ``action`` (short text, the action's name as tooltip, its enabled state)."""
        button = QToolButton(self)
        button.setText(text)
        if action is not None:
            button.setToolTip(action.text().replace("&", ""))
            button.clicked.connect(action.trigger)
            action.changed.connect(lambda: button.setEnabled(action.isEnabled()))
        return button

    def _enable_mask_button(self) -> None:
        self.buttons["mask"].setEnabled(any(action.isEnabled() for action in self.mask_menu.actions()
                                            if not action.isSeparator()))

    def _connect(self) -> None:
        self.list.currentRowChanged.connect(self._select)
        self.list.itemChanged.connect(self._item_changed)
        self.list.model().rowsMoved.connect(self._moved)
        self.opacity.valueChanged.connect(self._set_opacity)

    # -- the history -----------------------------------------------------------------------------
    def bind(self, history: History | None) -> None:
        """Show and follow the layers of ``history``'s document (None: no document)."""
        if self._history is not None:
            self._history.unsubscribe(self._changed)
        self._history, self._shown = history, None
        if history is None:
            self.list.blockSignals(True)
            self.list.clear()
            self.list.blockSignals(False)
        else:
            history.subscribe(self._changed)
        self.refresh()

    def _changed(self, before, after) -> None:
        self.refresh()

    @property
    def document(self) -> Document | None:
        return self._history.document if self._history is not None else None

    def apply(self, edit: Callable[[Document], Document], label: str, merge_key=None) -> None:
        """``edit`` of the current document as one step ``label``; why it was not done goes to ``failed``."""
        history = self._history
        if history is not None and self._settle() and not history.in_transaction:
            with reporting(self.failed.emit):
                history.apply(edit(history.document), label, merge_key)
        self._shown = None  # what the list shows may be the user's change, refused
        self.refresh()

    def retarget(self, choose: Callable[[Document], Document]) -> None:
        """Make ``choose(document)`` (another active layer or mask editing) current without a step."""
        history = self._history
        if history is not None and self._settle() and not history.in_transaction:
            history.retarget(choose(history.document))
        self._shown = None
        self.refresh()

    # -- showing -------------------------------------------------------------------------------
    def refresh(self) -> None:
        """Show the current document's layers (cheap when what the panel shows of them did not change)."""
        document = self.document
        if document is None or _summary(document) == self._shown:
            return
        self._shown = _summary(document)
        count = len(document.layers)
        self.list.blockSignals(True)  # not the model's: the view must hear of the rows
        try:
            self.list.clear()
            for index in reversed(range(count)):
                self.list.addItem(self._item(document, index))
            self.list.setCurrentRow(count - 1 - document.active)
        finally:
            self.list.blockSignals(False)
        layer = document.layer
        self.opacity.blockSignals(True)
        self.opacity.setValue(round(layer.opacity * 100))
        self.opacity.blockSignals(False)
        self.opacity_label.setText(f"{round(layer.opacity * 100)}%")

    @staticmethod
    def _item(document: Document, index: int) -> QListWidgetItem:
        layer = document.layers[index]
        marks = ["a seamless clone: Transform Clone (T) moves, scales and turns it"] if layer.clone is not None else []
        if layer.mask is not None:
            marks.append("mask" + ("" if layer.mask.enabled else " (disabled)")
                         + (" inverted" if layer.mask.inverted else ""))
        if not layer.transform.is_identity:
            marks.append("colours adjusted")
        if layer.opacity < 1.0:
            marks.append(f"opacity {round(layer.opacity * 100)}%")
        editing = index == document.active and document.editing_mask
        item = QListWidgetItem(layer.name)
        item.setToolTip(", ".join(marks + (["the tools edit its mask"] if editing else [])))
        if layer.mask is not None:
            item.setIcon(_mask_icon(layer.mask.enabled, editing))
        item.setFlags(item.flags() | Qt.ItemFlag.ItemIsEditable | Qt.ItemFlag.ItemIsUserCheckable
                      | Qt.ItemFlag.ItemIsDragEnabled)
        item.setCheckState(Qt.CheckState.Checked if layer.visible else Qt.CheckState.Unchecked)
        item.setData(Qt.ItemDataRole.UserRole, index)
        return item

    # -- the user's actions ---------------------------------------------------------------------
    def _index(self, row: int) -> int:
        return len(self.document.layers) - 1 - row

    def _select(self, row: int) -> None:
        document = self.document
        if document is None or row < 0 or self._index(row) == document.active:
            return
        index = self._index(row)
        self.retarget(lambda d: layer_edits.select_layer(d, index))

    def _item_changed(self, item: QListWidgetItem) -> None:
        document = self.document
        index = item.data(Qt.ItemDataRole.UserRole)
        if document is None or index is None:
            return
        layer = document.layers[index]
        visible = item.checkState() == Qt.CheckState.Checked
        name = item.text()
        if visible != layer.visible:
            self.apply(lambda d: layer_edits.set_visible(d, index, visible), "Show Layer" if visible else "Hide Layer")
        elif name != layer.name and name.strip():
            self.apply(lambda d: layer_edits.rename_layer(d, index, name.strip()), "Rename Layer")
        else:
            self._shown = None
            self.refresh()

    def _moved(self, _parent, start: int, _end: int, _destination, row: int) -> None:
        """A row dragged from ``start`` to before ``row`` (rows are the stack reversed).

        The step is taken once the view has finished the move (the list is rebuilt from the document).
        """
        to_row = row - 1 if row > start else row
        source, target = self._index(start), self._index(to_row)
        QTimer.singleShot(0, lambda: self._move(source, target))

    def _move(self, source: int, target: int) -> None:
        if source != target:
            self.apply(lambda d: layer_edits.move_layer(d, source, target), "Move Layer")
        else:
            self._shown = None
            self.refresh()

    def _set_opacity(self, value: int) -> None:
        document = self.document
        if document is None:
            return
        self.opacity_label.setText(f"{value}%")
        self.apply(lambda d: layer_edits.set_opacity(d, None, value / 100), "Layer Opacity",
                   merge_key=("opacity", document.layer.id))


def _summary(document: Document) -> tuple:
    """What the panel shows of ``document``: it is rebuilt only when this changes (not on every dab)."""
    layers = tuple((layer.id, layer.name, layer.visible, layer.opacity, layer.transform.is_identity,
                    None if layer.mask is None else (layer.mask.enabled, layer.mask.inverted), layer.clone is None)
                   for layer in document.layers)
    return layers, document.active, document.editing_mask


def _mask_icon(enabled: bool, editing: bool) -> QIcon:
    """A mask's mark: a disc half white, half black (grey when disabled), ringed in red while it is edited."""
    pixmap = QPixmap(16, 16)
    pixmap.fill(Qt.GlobalColor.transparent)
    painter = QPainter(pixmap)
    painter.setRenderHint(QPainter.RenderHint.Antialiasing)
    painter.setPen(QPen(QColor(220, 40, 40) if editing else QColor(90, 90, 90), 2 if editing else 1))
    painter.setBrush(QColor(255, 255, 255) if enabled else QColor(170, 170, 170))
    painter.drawEllipse(2, 2, 12, 12)
    painter.setBrush(QColor(0, 0, 0) if enabled else QColor(120, 120, 120))
    painter.drawPie(2, 2, 12, 12, 90 * 16, 180 * 16)
    painter.end()
    return QIcon(pixmap)
