"""One side of a curve as a gradient bar with a handle per colour stop."""

from __future__ import annotations

from PySide6.QtCore import QPointF, QRectF, QSize, Qt, Signal
from PySide6.QtGui import QBrush, QColor, QLinearGradient, QPainter, QPen, QPixmap, QPolygonF
from PySide6.QtWidgets import QSizePolicy, QWidget

from ..model import ColorStop

#: Layout in pixels: margin left and right (half a handle), bar height, handle size.
MARGIN = 7
BAR = 18
HANDLE = 12
#: How far the pointer moves before a press on a handle becomes a drag.
DRAG_THRESHOLD = 3


def qcolor(rgb, alpha: float = 1.0) -> QColor:
    """An sRGB float triple (and an alpha) as a QColor."""
    r, g, b, a = (int(round(min(max(float(v), 0.0), 1.0) * 255)) for v in (*rgb, alpha))
    return QColor(r, g, b, a)


def checkerboard(square: int = 5) -> QBrush:
    """The grey checkerboard that shows through what is not opaque, as on the canvas."""
    tile = QPixmap(2 * square, 2 * square)
    tile.fill(QColor(204, 204, 204))
    painter = QPainter(tile)
    for x, y in ((0, 0), (square, square)):
        painter.fillRect(x, y, square, square, QColor(153, 153, 153))
    painter.end()
    return QBrush(tile)


class GradientBar(QWidget):
    """The colours along one side of a curve, with draggable stop handles below.

    Positions are in piece units ``[0, length]``.  The widget edits nothing
    itself: it reports what the pointer does.

    Signals
    -------
    pressed(int, bool)
        A handle (stop index) was pressed; whether Shift was held.
    dragged(float)
        The pressed handle was dragged to this position.
    released()
        The pointer was released (after a press on a handle).
    cancelled()
        Esc during a drag.
    double_clicked(int)
        A double click on a handle.
    add_requested(float)
        A double click on the bar away from the handles.
    """

    pressed = Signal(int, bool)
    dragged = Signal(float)
    released = Signal()
    cancelled = Signal()
    double_clicked = Signal(int)
    add_requested = Signal(float)

    def __init__(self, parent=None) -> None:
        super().__init__(parent)
        self.stops: tuple[ColorStop, ...] = ()
        self.length = 1.0
        self.selected: frozenset[int] = frozenset()
        self.empty_color = QColor(0, 0, 0)
        self._press: QPointF | None = None
        self._dragging = False
        self.setFocusPolicy(Qt.FocusPolicy.ClickFocus)
        self.setSizePolicy(QSizePolicy.Policy.Expanding, QSizePolicy.Policy.Fixed)
        self.setMinimumWidth(120)

    def sizeHint(self) -> QSize:
        return QSize(220, BAR + HANDLE + 6)

    def set_stops(self, stops: tuple[ColorStop, ...], length: float, selected=()) -> None:
        """Show ``stops`` of a side ``length`` pieces long; ``selected`` are stop indices."""
        self.stops, self.length, self.selected = tuple(stops), max(float(length), 1e-9), frozenset(selected)
        self.update()

    # -- geometry -----------------------------------------------------------------------------------
    def x_of(self, s: float) -> float:
        """Widget x of position ``s``."""
        return MARGIN + (self.width() - 2 * MARGIN) * s / self.length

    def s_of(self, x: float) -> float:
        """Position (clamped to ``[0, length]``) under widget x."""
        span = max(self.width() - 2 * MARGIN, 1)
        return min(max((x - MARGIN) / span * self.length, 0.0), self.length)

    def handle_at(self, x: float, y: float) -> int | None:
        """Index of the stop whose handle (or bar column) is under ``(x, y)``; the selected one first."""
        best, distance = None, HANDLE / 2 + 1
        for i, stop in enumerate(self.stops):
            d = abs(self.x_of(stop.position) - x)
            if d < distance or (d == distance and i in self.selected):
                best, distance = i, d
        return best if y >= BAR - 4 or best is not None and distance <= 3 else None

    # -- painting ------------------------------------------------------------------------------------
    def paintEvent(self, event) -> None:
        painter = QPainter(self)
        painter.setRenderHint(QPainter.RenderHint.Antialiasing)
        bar = QRectF(MARGIN, 1, self.width() - 2 * MARGIN, BAR)
        if not self.isEnabled():
            painter.fillRect(bar, self.palette().window())  # no curve shown: an empty bar, not a black side
        elif self.stops:
            if any(stop.alpha < 1.0 for stop in self.stops):
                painter.fillRect(bar, checkerboard())  # showing through where the side is not opaque
            gradient = QLinearGradient(bar.left(), 0, bar.right(), 0)
            for stop in self.stops:
                gradient.setColorAt(min(max(stop.position / self.length, 0.0), 1.0), qcolor(stop.color, stop.alpha))
            painter.fillRect(bar, QBrush(gradient))
        else:
            painter.fillRect(bar, self.empty_color)  # a side without stops: black (a curve without blur: sharp)
        painter.setPen(QPen(self.palette().mid().color(), 1))
        painter.drawRect(bar)
        for i, stop in enumerate(self.stops):
            self._handle(painter, self.x_of(stop.position), qcolor(stop.color), i in self.selected)
        painter.end()

    def _handle(self, painter: QPainter, x: float, color: QColor, selected: bool) -> None:
        top = BAR + 1
        tip = QPolygonF([QPointF(x, top), QPointF(x - HANDLE / 2, top + HANDLE / 2),
                         QPointF(x - HANDLE / 2, top + HANDLE), QPointF(x + HANDLE / 2, top + HANDLE),
                         QPointF(x + HANDLE / 2, top + HANDLE / 2)])
        painter.setBrush(QBrush(color))
        outline = self.palette().highlight().color() if selected else QColor(30, 30, 30)
        painter.setPen(QPen(outline, 2.5 if selected else 1.0))
        painter.drawPolygon(tip)

    # -- pointer -------------------------------------------------------------------------------------
    def mousePressEvent(self, event) -> None:
        if event.button() != Qt.MouseButton.LeftButton:
            return
        position = event.position()
        index = self.handle_at(position.x(), position.y())
        if index is None:
            return
        self._press, self._dragging = position, False
        self.pressed.emit(index, bool(event.modifiers() & Qt.KeyboardModifier.ShiftModifier))

    def mouseMoveEvent(self, event) -> None:
        if self._press is None:
            return
        position = event.position()
        if not self._dragging and abs(position.x() - self._press.x()) < DRAG_THRESHOLD:
            return
        self._dragging = True
        self.dragged.emit(self.s_of(position.x()))

    def mouseReleaseEvent(self, event) -> None:
        if event.button() == Qt.MouseButton.LeftButton and self._press is not None:
            self._press, self._dragging = None, False
            self.released.emit()

    def mouseDoubleClickEvent(self, event) -> None:
        if event.button() != Qt.MouseButton.LeftButton:
            return
        position = event.position()
        index = self.handle_at(position.x(), position.y())
        if index is not None:
            self.double_clicked.emit(index)
        elif 0 <= position.y() <= BAR + HANDLE:
            self.add_requested.emit(self.s_of(position.x()))

    def keyPressEvent(self, event) -> None:
        if event.key() == Qt.Key.Key_Escape and self._press is not None:
            self._press, self._dragging = None, False
            self.cancelled.emit()
        else:
            super().keyPressEvent(event)
