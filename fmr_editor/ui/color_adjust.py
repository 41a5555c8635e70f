"""The Colour Adjust dialog: hue, saturation, brightness, contrast and invert of the active layer.

The adjustment is a colour transform composed after the layer's own
(``model.color_transform``), or in its place when the user starts from the
layer's own colours; it applies to the layer's cell coefficients, so
no solve runs and the canvas follows each slider at once.  The dialog opens a
history transaction: every change is previewed, OK records one step "Colour
Adjust", Cancel restores the layer as it was.
"""

from __future__ import annotations

from PySide6.QtCore import Qt
from PySide6.QtWidgets import (
    QCheckBox,
    QDialog,
    QDialogButtonBox,
    QFormLayout,
    QHBoxLayout,
    QLabel,
    QSlider,
    QVBoxLayout,
)

from ..model import layer_edits
from ..model.color_transform import IDENTITY, ColorTransform, brightness_contrast, hue_rotation, inversion, saturation
from ..model.history import History

#: Sliders: (name, label, low, high, neutral, unit).
SLIDERS = (
    ("hue", "Hue", -180, 180, 0, "\u00b0"),
    ("saturation", "Saturation", 0, 200, 100, "%"),
    ("brightness", "Brightness", 0, 200, 100, "%"),
    ("contrast", "Contrast", 0, 200, 100, "%"),
)


def adjustment(hue: float = 0.0, saturate: float = 1.0, brightness: float = 1.0, contrast: float = 1.0,
               invert: bool = False) -> ColorTransform:
    """Hue rotation (degrees), then saturation, brightness and contrast (factors), then inversion."""
    transform = hue_rotation(hue).then(saturation(saturate)).then(brightness_contrast(brightness, contrast))
    return transform.then(inversion()) if invert else transform


class ColorAdjustDialog(QDialog):
    """Adjusts the active layer of ``history``'s document, previewed live.

    Parameters
    ----------
    history : History
        Must have no open transaction; the dialog opens one and closes it.
    parent : QWidget, optional
    """

    def __init__(self, history: History, parent=None) -> None:
        super().__init__(parent)
        self.setWindowTitle("Colour Adjust")
        self.history = history
        self.start = history.document
        self.sliders: dict[str, QSlider] = {}
        self.values: dict[str, QLabel] = {}
        form = QFormLayout()
        for name, label, low, high, neutral, unit in SLIDERS:
            slider = QSlider(Qt.Orientation.Horizontal, self)
            slider.setRange(low, high)
            slider.setValue(neutral)
            slider.setMinimumWidth(220)
            value = QLabel(f"{neutral}{unit}", self)
            value.setMinimumWidth(44)
            slider.valueChanged.connect(lambda v, value=value, unit=unit: value.setText(f"{v}{unit}"))
            slider.valueChanged.connect(self._preview)
            row = QHBoxLayout()
            row.addWidget(slider, 1)
            row.addWidget(value)
            form.addRow(label, row)
            self.sliders[name], self.values[name] = slider, value
        self.invert = QCheckBox("Invert", self)
        self.invert.toggled.connect(self._preview)
        form.addRow("", self.invert)
        # a layer adjusted before: the sliders add to that; this takes it away (not from a layer of no curves or
        # points, whose colour is its transform: a Paint layer, an SVG's background)
        layer = self.start.layer
        self.from_own = QCheckBox("Start from the layer's own colours (drop its earlier adjustments)", self)
        self.from_own.setVisible(not layer.transform.is_identity and bool(layer.curves or layer.points))
        self.from_own.toggled.connect(self._preview)
        form.addRow("", self.from_own)
        buttons = QDialogButtonBox(QDialogButtonBox.StandardButton.Ok | QDialogButtonBox.StandardButton.Cancel
                                   | QDialogButtonBox.StandardButton.Reset, self)
        buttons.accepted.connect(self.accept)
        buttons.rejected.connect(self.reject)
        buttons.button(QDialogButtonBox.StandardButton.Reset).clicked.connect(self.reset)
        layout = QVBoxLayout(self)
        layout.addWidget(QLabel(f"Layer: {self.start.layer.name}", self))
        layout.addLayout(form)
        layout.addWidget(buttons)
        history.begin("Colour Adjust")

    @property
    def transform(self) -> ColorTransform:
        """The chosen adjustment (without the layer's own transform)."""
        value = {name: slider.value() for name, slider in self.sliders.items()}
        return adjustment(value["hue"], value["saturation"] / 100, value["brightness"] / 100,
                          value["contrast"] / 100, self.invert.isChecked())

    def set_values(self, hue: int = 0, saturation: int = 100, brightness: int = 100, contrast: int = 100,
                   invert: bool = False) -> None:
        """Set the sliders (degrees and percent) and the invert box, as a user would."""
        for name, value in (("hue", hue), ("saturation", saturation), ("brightness", brightness),
                            ("contrast", contrast)):
            self.sliders[name].setValue(value)
        self.invert.setChecked(invert)

    def reset(self) -> None:
        self.set_values()
        self.from_own.setChecked(False)

    def _preview(self) -> None:
        before = IDENTITY if self.from_own.isChecked() else self.start.layer.transform
        self.history.preview(layer_edits.set_transform(self.start, None, before.then(self.transform)))

    def done(self, result: int) -> None:
        if self.history.in_transaction:
            if result == QDialog.DialogCode.Accepted:
                self.history.commit()
            else:
                self.history.cancel()
        super().done(result)
