"""Return in a panel's number box hands the keys back to the canvas, whose tools' shortcuts are single keys."""

from __future__ import annotations

from collections.abc import Iterable

from PySide6.QtCore import QEvent, QObject, Qt
from PySide6.QtWidgets import QWidget

_RETURN = (Qt.Key.Key_Return, Qt.Key.Key_Enter)


class ReturnToCanvas(QObject):
    """An event filter: Return or Enter in a watched widget focuses ``canvas`` (the widget, losing the focus, takes
    what was typed in it), so that V, B or X choose a tool again instead of going into the box unseen."""

    def __init__(self, canvas: QWidget, parent: QObject | None = None) -> None:
        super().__init__(parent)
        self._canvas = canvas

    def watch(self, widgets: Iterable[QWidget]) -> None:
        for widget in widgets:
            widget.installEventFilter(self)

    def eventFilter(self, watched: QObject, event: QEvent) -> bool:  # noqa: N802 - Qt's name
        if event.type() == QEvent.Type.KeyPress and event.key() in _RETURN:
            self._canvas.activateWindow()  # from a floating panel too
            self._canvas.setFocus()
            return True
        return False
