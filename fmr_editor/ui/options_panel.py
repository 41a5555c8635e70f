"""The tool options panel: the foreground and background colours, the brush."""

from __future__ import annotations

from PySide6.QtCore import QSize, Signal
from PySide6.QtWidgets import (
    QComboBox,
    QDoubleSpinBox,
    QFormLayout,
    QGroupBox,
    QHBoxLayout,
    QToolButton,
    QVBoxLayout,
    QWidget,
)

from ..tools import ToolOptions
from .colors import pick_color
from .gradient_bar import qcolor
from .stops_panel import swatch

#: Brush settings: attribute, label, minimum, maximum, step, decimals, tooltip.
BRUSH_FIELDS = (
    ("brush_radius", "Radius", 0.5, 2000.0, 1.0, 1, "Gaussian radius of each dab, pixels"),
    ("brush_amplitude", "Amplitude", -4.0, 4.0, 0.05, 2, "Strength of each dab (Glow: negative takes colour away)"),
    ("brush_spacing", "Spacing", 0.5, 2000.0, 1.0, 1, "Distance between dabs along a stroke, pixels"),
)


def brush_spins(parent) -> list[tuple[str, str, QDoubleSpinBox]]:
    """``(attribute, label, spin box)`` for each of ``BRUSH_FIELDS``, with its range, step and tooltip."""
    spins = []
    for name, label, low, high, step, decimals, tip in BRUSH_FIELDS:
        spin = QDoubleSpinBox(parent)
        spin.setRange(low, high)
        spin.setSingleStep(step)
        spin.setDecimals(decimals)
        spin.setToolTip(tip)
        spins.append((name, label, spin))
    return spins


#: The brush's modes (``ToolOptions.brush_mode``) and their names.
BRUSH_MODES = {"paint": "Paint", "glow": "Glow"}


class OptionsPanel(QWidget):
    """Colour swatches and brush settings, editing one ``ToolOptions``.

    Parameters
    ----------
    options : ToolOptions
        Shared with every document's tool context.
    parent : QWidget, optional

    Signals
    -------
    changed()
        An option changed (the overlay shows the brush size, for one).
    """

    changed = Signal()

    def __init__(self, options: ToolOptions, parent=None) -> None:
        super().__init__(parent)
        self.options = options

        self.foreground = self._swatch_button("Foreground colour: new stops, dabs, a new curve's left side", "color")
        self.background = self._swatch_button("Background colour: a new curve's right side", "secondary_color")
        swap = QToolButton(self)
        swap.setText("\u21c4")
        swap.setToolTip("Swap the colours (X)")
        swap.clicked.connect(self.swap_colors)
        reset = QToolButton(self)
        reset.setText("D")
        reset.setToolTip("Black and white (D)")
        reset.clicked.connect(self.default_colors)
        colours = QHBoxLayout()
        for widget in (self.foreground, self.background, swap, reset):
            colours.addWidget(widget)
        colours.addStretch(1)

        brush = QGroupBox("Point brush")
        form = QFormLayout(brush)
        self.brush_swatch = self._swatch_button("Brush colour: what the dabs paint (or, in Glow mode, add)",
                                                "brush_color")
        form.addRow("Colour", self.brush_swatch)
        self.brush_mode = QComboBox(self)
        for mode, label in BRUSH_MODES.items():
            self.brush_mode.addItem(label, mode)
        self.brush_mode.setToolTip("Paint: dabs cover what is below with the brush colour (a fill layer's mask). "
                                   "Glow: dabs add colour and overlapping dabs brighten towards white")
        self.brush_mode.currentIndexChanged.connect(self._set_mode)
        form.addRow("Mode", self.brush_mode)
        self.spins: dict[str, QDoubleSpinBox] = {}
        for name, label, spin in brush_spins(self):
            spin.setValue(float(getattr(options, name)))
            spin.valueChanged.connect(lambda value, name=name: self._set(name, value))
            form.addRow(label, spin)
            self.spins[name] = spin

        pen = QGroupBox("Pen on a clear layer")
        pen.setToolTip("A closed curve covers its inside; an open one's sides take these alphas (0 clear, 1 opaque)")
        pen_form = QFormLayout(pen)
        for name, label in (("stroke_left_alpha", "Open: left alpha"), ("stroke_right_alpha", "Open: right alpha")):
            spin = QDoubleSpinBox(self)
            spin.setRange(0.0, 1.0)
            spin.setSingleStep(0.1)
            spin.setValue(float(getattr(options, name)))
            spin.valueChanged.connect(lambda value, name=name: self._set(name, value))
            pen_form.addRow(label, spin)
            self.spins[name] = spin

        colours_box = QGroupBox("Colours")
        colours_box.setLayout(colours)
        layout = QVBoxLayout(self)
        for box in (colours_box, brush, pen):
            layout.addWidget(box)
        layout.addStretch(1)
        self.refresh()

    def _swatch_button(self, tip: str, attribute: str) -> QToolButton:
        button = QToolButton(self)
        button.setToolTip(tip)
        button.setIconSize(QSize(28, 20))
        button.clicked.connect(lambda _=False: self.choose(attribute))
        return button

    def _set_mode(self, index: int) -> None:
        self.options.brush_mode = self.brush_mode.itemData(index)
        self.changed.emit()

    def _set(self, name: str, value: float) -> None:
        setattr(self.options, name, float(value))
        self.changed.emit()

    def choose(self, attribute: str) -> None:
        """Ask for the foreground (``"color"``), background (``"secondary_color"``) or brush colour."""
        title = {"color": "Foreground Colour", "secondary_color": "Background Colour"}.get(attribute, "Brush Colour")
        chosen = pick_color(self.window(), getattr(self.options, attribute), title)
        if chosen is not None:
            setattr(self.options, attribute, chosen)
            self.refresh()
            self.changed.emit()

    def swap_colors(self) -> None:
        options = self.options
        options.color, options.secondary_color = options.secondary_color, options.color
        self.refresh()
        self.changed.emit()

    def default_colors(self) -> None:
        self.options.color, self.options.secondary_color = (0.0, 0.0, 0.0), (1.0, 1.0, 1.0)
        self.refresh()
        self.changed.emit()

    def refresh(self) -> None:
        """Show the options as they are (the eyedropper changes the colours)."""
        options = self.options
        for button, color in ((self.foreground, options.color), (self.background, options.secondary_color),
                              (self.brush_swatch, options.brush_color)):
            button.setIcon(swatch(qcolor(color), 28))
        mode = self.brush_mode.findData(options.brush_mode)
        if mode != self.brush_mode.currentIndex():
            self.brush_mode.blockSignals(True)
            self.brush_mode.setCurrentIndex(mode)
            self.brush_mode.blockSignals(False)
        for name, spin in self.spins.items():
            value = float(getattr(options, name))
            if spin.value() != value:
                spin.blockSignals(True)
                spin.setValue(value)
                spin.blockSignals(False)
