"""The zoom percentage in the status bar: it follows the canvas, and its menu offers the usual steps."""

from __future__ import annotations

from PySide6.QtWidgets import QMenu, QToolButton

from .canvas import Canvas

#: The menu's zoom steps, percent.
STEPS = (25, 50, 100, 200, 400, 800)


class ZoomButton(QToolButton):
    """Shows the canvas's zoom ("100%" at the actual size); a click opens the steps and Fit Canvas."""

    def __init__(self, canvas: Canvas, parent=None) -> None:
        super().__init__(parent)
        self.canvas = canvas
        self.setToolTip("Zoom: 100% shows one document pixel per screen pixel (1); Fit Canvas: Ctrl+0 or 5")
        self.setPopupMode(QToolButton.ToolButtonPopupMode.InstantPopup)
        menu = QMenu(self)
        for percent in STEPS:
            menu.addAction(f"{percent}%", lambda percent=percent: canvas.zoom_to(percent / 100))
        menu.addSeparator()
        menu.addAction("Fit Canvas", canvas.fit)
        self.setMenu(menu)
        canvas.view_changed.connect(self.refresh)
        self.refresh()

    def refresh(self) -> None:
        self.setText(f"{self.canvas.zoom_factor * 100:.0f}%")
