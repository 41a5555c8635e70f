"""The stops panel: the colour stops of the selected curve, left and right, and its blur stops, as bars.

- Pressing a handle selects its stop (Shift adds or removes it); dragging
  moves the stop along its side: one undo step "Move Stop" (Esc cancels).
- A double click on a handle, or the side's colour button, opens a colour
  dialog for the selected stops of that side; every change shows at once
  and the dialog is one undo step ("Change Stop Colour"; Cancel undoes it).
- A double click on the bar away from the handles adds a stop there with
  the colour the side has there ("Add Stop"); the side's remove button (or
  Delete while the bar has focus) removes its selected stops.
- The third bar holds the blur stops, white where sharp and darker as the
  blur grows (``BLUR_SHOWN`` px and more: darkest); they move, add and go
  as colour stops do, and the spin box beside the bar sets the selected
  ones' blur, in document pixels of deviation ("Change Blur", one step while
  it is edited).
"""

from __future__ import annotations

from PySide6.QtCore import QEvent, Qt, Signal
from PySide6.QtGui import QColor, QIcon, QPixmap
from PySide6.QtWidgets import QDoubleSpinBox, QGridLayout, QLabel, QToolButton, QVBoxLayout, QWidget

from ..model import BlurStop, ColorStop, edits
from ..tools import Selection, ToolContext, delete_selection, recolor_stops, set_blur_stops
from ..tools.stops import find_stop, stop_value
from .colors import live_color_dialog
from .gradient_bar import GradientBar, qcolor

SIDES = ("left", "right")
#: A blur stop of this many pixels or more shows darkest on the blur bar.
BLUR_SHOWN = 10.0


def blur_grey(blur: float) -> tuple[float, float, float]:
    """How the blur bar shows ``blur``: white for sharp, darker up to ``BLUR_SHOWN``."""
    grey = 1.0 - 0.85 * min(max(blur, 0.0) / BLUR_SHOWN, 1.0)
    return (grey, grey, grey)


def swatch(color: QColor | None, size: int = 16) -> QIcon:
    """A square icon filled with ``color`` (a crossed box for None)."""
    pixmap = QPixmap(size, size)
    pixmap.fill(color if color is not None else QColor(0, 0, 0, 0))
    return QIcon(pixmap)


class StopsPanel(QWidget):
    """Edits the stops of the selected curve (the curve of the selected stops, else the first selected).

    ``bind`` shows a document's tool context, whose document the panel then
    follows by itself; call ``refresh`` after the selection changed.

    Signals
    -------
    changed()
        The panel changed the selection or the document (the canvas redraws its overlay).
    """

    changed = Signal()

    def __init__(self, parent=None) -> None:
        super().__init__(parent)
        self.context: ToolContext | None = None
        self.curve: int | None = None
        self.dialog = None  # the open colour dialog, if any
        self._drag: dict | None = None
        self._shown: tuple | None = None
        self.title = QLabel("Select a curve to edit its colour stops.")
        self.title.setWordWrap(True)
        self.bars: dict[str, GradientBar] = {}
        self.color_buttons: dict[str, QToolButton] = {}
        self.remove_buttons: dict[str, QToolButton] = {}
        grid = QGridLayout()
        for row, side in enumerate(SIDES):
            bar, remove = self._bar(side)
            color = QToolButton(self)
            color.setToolTip(f"Colour of the selected {side} stops (with none selected: of the stop nearest "
                             "the middle of the curve)")
            color.clicked.connect(lambda _=False, side=side: self.edit_color(side))
            grid.addWidget(QLabel(side.capitalize()), 2 * row, 0, 1, 3)
            grid.addWidget(bar, 2 * row + 1, 0)
            grid.addWidget(color, 2 * row + 1, 1, Qt.AlignmentFlag.AlignTop)
            grid.addWidget(remove, 2 * row + 1, 2, Qt.AlignmentFlag.AlignTop)
            self.color_buttons[side] = color
        self._blur_row(grid, 2 * len(SIDES))
        layout = QVBoxLayout(self)
        layout.addWidget(self.title)
        layout.addLayout(grid)
        layout.addStretch(1)
        self.refresh()

    def _bar(self, side: str) -> tuple[GradientBar, QToolButton]:
        """The bar of ``side``'s stops, wired to the panel, and its remove button (kept in ``bars`` and
        ``remove_buttons``)."""
        bar = GradientBar(self)
        bar.setObjectName(f"{side}-stops")
        bar.pressed.connect(lambda i, shift: self._pressed(side, i, shift))
        bar.dragged.connect(self._dragged)
        bar.released.connect(self._released)
        bar.cancelled.connect(self._cancel_drag)
        bar.double_clicked.connect(lambda i: self._double_clicked(side, i))
        bar.add_requested.connect(lambda s: self.add_stop(side, s))
        bar.installEventFilter(self)
        remove = QToolButton(self)
        remove.setText("\u2212")
        remove.setToolTip(f"Remove the selected {side} stops")
        remove.clicked.connect(lambda _=False: self.remove_stops(side))
        self.bars[side], self.remove_buttons[side] = bar, remove
        return bar, remove

    def _blur_row(self, grid: QGridLayout, row: int) -> None:
        bar, remove = self._bar("blur")
        bar.empty_color = QColor(255, 255, 255)  # no blur stops: sharp
        bar.setToolTip("Blur along the curve: white is sharp, darker is softer (View > Show Blur shows it)")
        self.blur_value = QDoubleSpinBox(self)
        self.blur_value.setRange(0.0, 200.0)
        self.blur_value.setDecimals(1)
        self.blur_value.setSingleStep(0.5)
        self.blur_value.setSuffix(" px")
        self.blur_value.setToolTip("Blur of the selected blur stops: the deviation of the Gaussian that softens "
                                   "the picture there, in document pixels")
        self.blur_value.valueChanged.connect(self._blur_changed)
        grid.addWidget(QLabel("Blur"), row, 0, 1, 3)
        grid.addWidget(bar, row + 1, 0)
        grid.addWidget(remove, row + 1, 2, Qt.AlignmentFlag.AlignTop)
        grid.addWidget(self.blur_value, row + 2, 0, Qt.AlignmentFlag.AlignLeft)  # under the bar: the dock stays narrow

    # -- state ---------------------------------------------------------------------------------------
    def bind(self, context: ToolContext | None) -> None:
        """Edit the stops of ``context``'s document and selection, following the document's changes (a change
        of the selection alone is the caller's to show, with ``refresh``: selections are not observed)."""
        if self.context is not None:
            self.context.history.unsubscribe(self._changed)
        self.context, self._drag, self._shown = context, None, None
        if context is not None:
            context.history.subscribe(self._changed)
        self.refresh()

    def _changed(self, before, after) -> None:
        self.refresh()

    def chosen_curve(self) -> int | None:
        """The curve shown (its id): that of the (first) selected stop, else the first selected curve."""
        context = self.context
        if context is None:
            return None
        document = context.document
        selection = context.selection.within(document)
        if selection.stops:
            return min(selection.stops, key=lambda stop: (document.curve_index(stop[0]), stop[1:]))[0]
        curves = selection.active_curves()
        return min(curves, key=document.curve_index) if curves else None

    def selected(self, side: str) -> list[int]:
        """Indices of the selected stops on ``side`` of the shown curve."""
        if self.context is None or self.curve is None:
            return []
        return sorted(i for c, s, i in self.context.selection.stops if c == self.curve and s == side)

    def refresh(self) -> None:
        """Show the chosen curve's stops as they are now (cheap when nothing changed)."""
        context = self.context
        self.curve = curve_id = self.chosen_curve()
        curve = context.document.curve(curve_id) if curve_id is not None else None
        state = (curve_id, curve, context.selection if context is not None else None)
        if state == self._shown:
            return
        self._shown = state
        pieces = "" if curve is None else f"{curve.piece_count} piece{'s' if curve.piece_count != 1 else ''}"
        self.title.setText("Select a curve to edit its colour stops." if curve is None
                           else f"Curve {context.document.curve_index(curve_id) + 1}: {pieces}")
        for side in SIDES:
            bar = self.bars[side]
            stops = getattr(curve, side) if curve is not None else ()
            chosen = self.selected(side)
            bar.set_stops(stops, curve.piece_count if curve is not None else 1.0, chosen)
            bar.setEnabled(curve is not None)
            color = qcolor(stops[chosen[0]].color) if chosen else None
            self.color_buttons[side].setIcon(swatch(color))
            self.color_buttons[side].setEnabled(bool(stops))
            self.remove_buttons[side].setEnabled(bool(chosen))
        blurs = curve.blur if curve is not None else ()
        chosen = self.selected("blur")
        bar = self.bars["blur"]
        bar.set_stops(tuple(ColorStop(stop.position, blur_grey(stop.blur)) for stop in blurs),
                      curve.piece_count if curve is not None else 1.0, chosen)
        bar.setEnabled(curve is not None)
        self.remove_buttons["blur"].setEnabled(bool(chosen))
        self.blur_value.setEnabled(bool(chosen))
        self.blur_value.blockSignals(True)  # showing the value is no edit
        self.blur_value.setValue(blurs[chosen[0]].blur if chosen else 0.0)
        self.blur_value.blockSignals(False)

    def _done(self) -> None:
        self.refresh()
        self.changed.emit()

    # -- moving ----------------------------------------------------------------------------------------
    def _pressed(self, side: str, index: int, shift: bool) -> None:
        context = self.context
        if context is None or self.curve is None:
            return
        stop = (self.curve, side, index)
        chosen = Selection.of(stops=[stop])
        context.selection = context.selection ^ chosen if shift else chosen
        self._drag = None
        if stop in context.selection.stops:
            curve = context.document.curve(self.curve)
            self._drag = {"side": side, "index": index, "base": context.document, "open": False,
                          "value": stop_value(getattr(curve, side)[index]), "length": curve.piece_count}
        self._done()

    def _dragged(self, s: float) -> None:
        drag, context = self._drag, self.context
        if drag is None or context is None:
            return
        if not drag["open"]:
            try:
                context.history.begin("Move Stop")
            except RuntimeError:  # another drag (on the canvas) is in progress
                self._drag = None
                return
            drag["open"] = True
        s = min(max(float(s), 0.0), float(drag["length"]))
        document = edits.move_stop(drag["base"], self.curve, drag["side"], drag["index"], s)
        index = find_stop(document, self.curve, drag["side"], s, drag["value"])
        context.history.preview(document)
        context.selection = Selection.of(stops=[(self.curve, drag["side"], index)])
        self._done()

    def _released(self) -> None:
        drag, self._drag = self._drag, None
        if drag is not None and drag["open"]:
            self.context.history.commit()
            self._done()

    def _cancel_drag(self) -> None:
        drag, self._drag = self._drag, None
        if drag is not None and drag["open"]:
            self.context.history.cancel()
            self.context.selection = Selection.of(stops=[(self.curve, drag["side"], drag["index"])])
            self._done()

    # -- colours, adding and removing --------------------------------------------------------------
    def _double_clicked(self, side: str, index: int) -> None:
        if self.context is None or self.curve is None:
            return
        self.context.selection = Selection.of(stops=[(self.curve, side, index)])
        self._done()
        if side == "blur":
            self.blur_value.setFocus()
            self.blur_value.selectAll()
        else:
            self.edit_color(side)

    def edit_color(self, side: str) -> None:
        """Open a colour dialog for the selected stops of ``side`` (live; one undo step); with none selected, for
        the stop nearest the middle of the curve, which is selected."""
        context, chosen = self.context, self.selected(side)
        if context is None or self.curve is None:
            return
        if not chosen:
            shown = context.document.curve(self.curve)
            stops = getattr(shown, side)
            if not stops:
                return
            middle = min(range(len(stops)), key=lambda i: abs(stops[i].position - shown.piece_count / 2))
            context.selection = Selection.of(stops=[(self.curve, side, middle)])
            self._done()
            chosen = [middle]
        curve = self.curve
        stops = [(curve, side, i) for i in chosen]
        current = getattr(context.document.curve(curve), side)[chosen[0]]

        def apply(color, alpha, key) -> None:
            context.selection = Selection.of(stops=stops)
            if recolor_stops(context, color, merge_key=key, alpha=alpha):
                self._done()

        self.dialog = live_color_dialog(self.window(), context.history, current.color, apply, "Stop Colour",
                                        alpha=current.alpha)
        self.dialog.finished.connect(self._dialog_closed)

    def _dialog_closed(self) -> None:
        self.dialog = None
        self._done()

    def add_stop(self, side: str, s: float) -> None:
        """Add a stop at ``s`` on ``side`` with the colour (the blur) the side has there ("Add Stop")."""
        context = self.context
        if context is None or self.curve is None:
            return
        curve = context.document.curve(self.curve)
        s = min(max(float(s), 0.0), float(curve.piece_count))
        if side == "blur":
            value = float(curve.blur_at([s])[0])
            new = BlurStop(s, value)
        else:
            value = tuple(float(v) for v in getattr(curve, f"{side}_colors_at")([s])[0])
            new = ColorStop(s, value)
        document = edits.add_stop(context.document, self.curve, side, new)
        context.history.apply(document, "Add Stop")
        context.selection = Selection.of(stops=[(self.curve, side, find_stop(document, self.curve, side, s, value))])
        self._done()

    def _blur_changed(self, value: float) -> None:
        """The spin box's value: the selected blur stops' blur (edits in a row on the same stops: one step)."""
        context, chosen = self.context, self.selected("blur")
        if context is None or not chosen:
            return
        context.selection = Selection.of(stops=[(self.curve, "blur", i) for i in chosen])
        if set_blur_stops(context, value, merge_key=("blur", self.curve, tuple(chosen))):
            self._done()

    def remove_stops(self, side: str) -> None:
        """Remove the selected stops of ``side`` (one step)."""
        context = self.context
        if context is None or not self.selected(side):
            return
        context.selection = Selection.of(stops=[(self.curve, side, i) for i in self.selected(side)])
        delete_selection(context)
        self._done()

    def eventFilter(self, watched, event) -> bool:
        """Delete and BackSpace on a focused bar remove its selected stops (before the menu's Delete)."""
        kind = event.type()
        if kind in (QEvent.Type.ShortcutOverride, QEvent.Type.KeyPress) \
                and event.key() in (Qt.Key.Key_Delete, Qt.Key.Key_Backspace):
            side = next((side for side, bar in self.bars.items() if watched is bar), None)
            if side is not None and self.selected(side):
                if kind == QEvent.Type.KeyPress:
                    self.remove_stops(side)
                event.accept()
                return True
        return False
