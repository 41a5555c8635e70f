"""The tools' overlay (outlines, anchors, stops, brush) drawn over the canvas.

``Overlay`` is a transparent child of the canvas that lets every mouse event
through and paints the active tool's ``overlay()`` primitives
(``tools.overlay``) with QPainter at a fixed screen size, placed by the
canvas's view.  It is the window's adapter to the canvas, which draws only
the image.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from PySide6.QtCore import QEvent, QLineF, QObject, QPointF, QRectF, Qt, QTimer
from PySide6.QtGui import QBrush, QColor, QPainter, QPen, QPolygonF
from PySide6.QtWidgets import QWidget

from ..tools.overlay import Circle, Markers, Polyline, Rectangle, Segments

ACCENT = QColor(30, 120, 255)
HOVER = QColor(120, 190, 255)
HALO = QColor(255, 255, 255, 170)
#: The marching ants: dash and gap length in screen pixels, and how often they step on.
ANTS_DASH = 4.0
ANTS_STEP_MS = 120
#: Marker sizes in screen pixels.
SIZES = {"anchor": 7.0, "handle": 6.0, "stop": 10.0, "point": 7.0, "sample": 14.0}


def _color(rgb) -> QColor:
    r, g, b = (int(round(min(max(float(v), 0.0), 1.0) * 255)) for v in rgb)
    return QColor(r, g, b)


def _pen(color: QColor, width: float, style=Qt.PenStyle.SolidLine) -> QPen:
    pen = QPen(color, width, style)
    pen.setCosmetic(True)
    return pen


class Overlay(QWidget):
    """Paints ``primitives()`` over ``canvas`` and follows its size.

    Parameters
    ----------
    canvas : ui.canvas.Canvas
        Gives the view (``canvas.view``) and is the parent.
    primitives : callable
        Returns the primitives to draw (the active tool's ``overlay()``).
    """

    def __init__(self, canvas, primitives: Callable[[], list]) -> None:
        super().__init__(canvas)
        self._canvas = canvas
        self._primitives = primitives
        self.setAttribute(Qt.WidgetAttribute.WA_TransparentForMouseEvents)
        self.setAttribute(Qt.WidgetAttribute.WA_NoSystemBackground)
        self.setFocusPolicy(Qt.FocusPolicy.NoFocus)
        self.setGeometry(canvas.rect())
        canvas.installEventFilter(self)
        canvas.view_changed.connect(self.update)
        self.ants_phase = 0  # dash offset of the marching ants, stepped while any are shown
        self._ants = QTimer(self)
        self._ants.setInterval(ANTS_STEP_MS)
        self._ants.timeout.connect(self._march)

    def _march(self) -> None:
        self.ants_phase = (self.ants_phase + 1) % int(2 * ANTS_DASH)
        self.update()

    def eventFilter(self, watched: QObject, event: QEvent) -> bool:
        if watched is self._canvas and event.type() == QEvent.Type.Resize:
            self.setGeometry(self._canvas.rect())
        return False

    # -- painting ---------------------------------------------------------------------------------
    def _window(self, points: np.ndarray) -> np.ndarray:
        view = self._canvas.view
        return np.asarray(points, dtype=np.float64).reshape(-1, 2) * view.scale + (view.offset_x, view.offset_y)

    def paintEvent(self, event) -> None:
        if self._canvas.representation is None:
            return
        try:
            primitives = self._primitives()
        except (IndexError, KeyError):  # a stale selection during a document switch: draw nothing this time
            return
        ants = any(isinstance(item, Polyline) and item.role == "ants" for item in primitives)
        if ants != self._ants.isActive():
            self._ants.start() if ants else self._ants.stop()
        painter = QPainter(self)
        painter.setRenderHint(QPainter.RenderHint.Antialiasing)
        for item in primitives:
            if isinstance(item, Polyline):
                self._polyline(painter, item)
            elif isinstance(item, Segments):
                self._segments(painter, item)
            elif isinstance(item, Markers):
                self._markers(painter, item)
            elif isinstance(item, Rectangle):
                self._rectangle(painter, item)
            elif isinstance(item, Circle):
                self._circle(painter, item)
        painter.end()

    def _polyline(self, painter: QPainter, item: Polyline) -> None:
        points = self._window(item.points)
        if len(points) < 2:
            return
        polygon = QPolygonF([QPointF(x, y) for x, y in points])
        if item.role == "ants":
            self._ants_line(painter, polygon, item.closed)
            return
        color, width, style = {
            "hover": (HOVER, 1.5, Qt.PenStyle.SolidLine),
            "preview": (ACCENT, 1.0, Qt.PenStyle.DashLine),
        }.get(item.role, (ACCENT, 1.5, Qt.PenStyle.SolidLine))
        for pen in (_pen(HALO, width + 2.0), _pen(color, width, style)):
            painter.setPen(pen)
            painter.drawPolygon(polygon) if item.closed else painter.drawPolyline(polygon)

    def _ants_line(self, painter: QPainter, polygon: QPolygonF, closed: bool) -> None:
        """Black dashes marching over white, as every editor draws a selection."""
        dashes = _pen(QColor(0, 0, 0), 1.0, Qt.PenStyle.CustomDashLine)
        dashes.setDashPattern([ANTS_DASH, ANTS_DASH])
        dashes.setDashOffset(self.ants_phase)
        painter.setBrush(Qt.BrushStyle.NoBrush)
        for pen in (_pen(QColor(255, 255, 255), 1.0), dashes):
            painter.setPen(pen)
            painter.drawPolygon(polygon) if closed else painter.drawPolyline(polygon)

    def _segments(self, painter: QPainter, item: Segments) -> None:
        ends = self._window(item.ends.reshape(-1, 2)).reshape(-1, 4)
        painter.setPen(_pen(QColor(90, 90, 90), 1.0))
        painter.drawLines([QLineF(*row) for row in ends])

    def _markers(self, painter: QPainter, item: Markers) -> None:
        size = SIZES.get(item.kind, 7.0)
        half = size / 2
        for k, (x, y) in enumerate(self._window(item.positions)):
            chosen = bool(item.selected[k]) if len(item.selected) > k else False
            rect = QRectF(x - half, y - half, size, size)
            if item.colors is not None:
                fill = _color(item.colors[k])
            else:
                fill = ACCENT if chosen else QColor(255, 255, 255)
            painter.setBrush(QBrush(fill))
            painter.setPen(_pen(ACCENT if chosen and item.colors is not None else QColor(20, 20, 20),
                                2.5 if chosen and item.colors is not None else 1.0))
            if item.kind == "anchor" or item.kind == "sample":
                painter.drawRect(rect)
            else:
                painter.drawEllipse(rect)
                if item.kind == "stop":  # a white ring so that dark stops show on dark images
                    painter.setBrush(Qt.BrushStyle.NoBrush)
                    painter.setPen(_pen(QColor(255, 255, 255), 1.0))
                    painter.drawEllipse(rect.adjusted(1.5, 1.5, -1.5, -1.5))

    def _rectangle(self, painter: QPainter, item: Rectangle) -> None:
        (x0, y0), (x1, y1) = self._window(np.array([item.corner, item.opposite]))
        painter.setBrush(QBrush(QColor(30, 120, 255, 30)))
        painter.setPen(_pen(ACCENT, 1.0, Qt.PenStyle.DashLine))
        painter.drawRect(QRectF(QPointF(min(x0, x1), min(y0, y1)), QPointF(max(x0, x1), max(y0, y1))))

    def _circle(self, painter: QPainter, item: Circle) -> None:
        (x, y), = self._window(np.array([item.centre]))
        r = item.radius * self._canvas.view.scale
        painter.setBrush(Qt.BrushStyle.NoBrush)
        for pen in (_pen(QColor(0, 0, 0, 160), 2.0), _pen(QColor(255, 255, 255, 200), 1.0, Qt.PenStyle.DashLine)):
            painter.setPen(pen)
            painter.drawEllipse(QPointF(x, y), r, r)
