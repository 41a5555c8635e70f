"""The history panel: every step by name; a click goes back (or forward) to it."""

from __future__ import annotations

from PySide6.QtGui import QBrush, QColor, QFont
from PySide6.QtWidgets import QListWidget, QListWidgetItem, QVBoxLayout, QWidget

from ..model.history import History


class HistoryPanel(QWidget):
    """A list of the history's steps; the current one bold and selected, undone ones grey.

    Clicking a row (or moving to it with the keyboard) makes that step
    current (``History.jump``).  ``bind`` shows a document's history, which
    the panel then follows by itself.

    Parameters
    ----------
    parent : QWidget, optional
    """

    def __init__(self, parent=None) -> None:
        super().__init__(parent)
        self.list = QListWidget(self)
        self.list.setObjectName("history")
        layout = QVBoxLayout(self)
        layout.setContentsMargins(0, 0, 0, 0)
        layout.addWidget(self.list)
        self._history: History | None = None
        self._first = ""
        self._shown: tuple | None = None
        self.list.currentRowChanged.connect(self._jump)

    def bind(self, history: History | None, first: str) -> None:
        """Show and follow ``history`` (None: no document); ``first`` names its starting state ("Open ribbon.xml")."""
        if self._history is not None:
            self._history.unsubscribe(self._changed)
            self._history.unsubscribe_steps(self.refresh)
        self._history, self._first, self._shown = history, first, None
        if history is None:
            self.list.blockSignals(True)
            self.list.clear()
            self.list.blockSignals(False)
        else:
            history.subscribe(self._changed)
            history.subscribe_steps(self.refresh)
        self.refresh()

    def _changed(self, before, after) -> None:
        self.refresh()

    def refresh(self) -> None:
        """Show the history's steps as they are now (cheap when nothing changed)."""
        history = self._history
        if history is None:
            return
        state = (history.labels, history.index)
        if state == self._shown:
            return
        self._shown = state
        labels, index = state
        self.list.blockSignals(True)
        try:
            self.list.clear()
            for row, label in enumerate(labels):
                item = QListWidgetItem(label if row else self._first)
                if row == index:
                    font = QFont(item.font())
                    font.setBold(True)
                    item.setFont(font)
                elif row > index:
                    item.setForeground(QBrush(QColor(140, 140, 140)))
                self.list.addItem(item)
            self.list.setCurrentRow(index)
            self.list.scrollToItem(self.list.item(index), QListWidget.ScrollHint.EnsureVisible)
        finally:
            self.list.blockSignals(False)

    def _jump(self, row: int) -> None:
        history = self._history
        if history is None or row < 0 or row == history.index:
            return
        try:
            history.jump(row)
        except RuntimeError:  # a drag is in progress: stay where we are
            self._shown = None
            self.refresh()

    def sizeHint(self):
        hint = super().sizeHint()
        hint.setWidth(200)
        return hint

