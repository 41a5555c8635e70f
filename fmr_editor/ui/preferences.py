"""Edit > Preferences: the brush's starting settings, the autosave delay and each document's undo memory.

``Preferences`` is read from and written to the window's ``QSettings`` (under
``preferences/``), so they hold from one start of the editor to the next; a
value missing or unreadable there takes its default.
"""

from __future__ import annotations

from dataclasses import dataclass, fields

from PySide6.QtCore import QSettings
from PySide6.QtWidgets import (
    QComboBox,
    QDialog,
    QDialogButtonBox,
    QDoubleSpinBox,
    QFormLayout,
    QGroupBox,
    QSpinBox,
    QVBoxLayout,
    QWidget,
)

from ..engine import DEFAULT_MEMORY
from ..tools import ToolOptions
from .autosave import AUTOSAVE_SECONDS
from .options_panel import BRUSH_FIELDS, BRUSH_MODES, brush_spins

MIB = 2**20
#: Bounds of the autosave delay, seconds, and of a document's undo memory, MiB.
AUTOSAVE_RANGE = (5, 3600)
MEMORY_RANGE = (16, 65536)
_DEFAULT_BRUSH = ToolOptions()


@dataclass(frozen=True)
class Preferences:
    """What the user may set once for every document.

    Attributes
    ----------
    brush_radius, brush_amplitude, brush_spacing : float
        The Point Brush's settings when the editor starts (``ToolOptions``).
    brush_mode : str
        ``"paint"`` or ``"glow"``.
    autosave_seconds : int
        Seconds of unsaved changes before a document is autosaved.
    undo_memory_mib : int
        Memory each open document may keep for fast undo (older steps are rebuilt when visited), MiB.
    """

    brush_radius: float = _DEFAULT_BRUSH.brush_radius
    brush_amplitude: float = _DEFAULT_BRUSH.brush_amplitude
    brush_spacing: float = _DEFAULT_BRUSH.brush_spacing
    brush_mode: str = _DEFAULT_BRUSH.brush_mode
    autosave_seconds: int = int(AUTOSAVE_SECONDS)
    undo_memory_mib: int = DEFAULT_MEMORY // MIB

    @classmethod
    def load(cls, settings: QSettings) -> Preferences:
        """The preferences kept in ``settings`` (defaults for what is missing, unreadable or out of range)."""
        limits = {name: (low, high) for name, _, low, high, *_ in BRUSH_FIELDS}
        limits.update(autosave_seconds=AUTOSAVE_RANGE, undo_memory_mib=MEMORY_RANGE)
        values = {}
        for field in fields(cls):
            raw = settings.value(f"preferences/{field.name}")
            if raw is None:
                continue
            try:
                value = type(field.default)(raw)
            except (TypeError, ValueError):
                continue
            low, high = limits.get(field.name, (None, None))
            if (low is not None and not low <= value <= high) or (field.name == "brush_mode" and value not in
                                                                   BRUSH_MODES):
                continue
            values[field.name] = value
        return cls(**values)

    def save(self, settings: QSettings) -> None:
        for field in fields(self):
            settings.setValue(f"preferences/{field.name}", getattr(self, field.name))

    def apply_brush(self, options: ToolOptions) -> None:
        """Set the brush settings of ``options`` to these."""
        for name in ("brush_radius", "brush_amplitude", "brush_spacing", "brush_mode"):
            setattr(options, name, getattr(self, name))

    @property
    def undo_memory(self) -> int:
        """``undo_memory_mib`` in bytes."""
        return self.undo_memory_mib * MIB


def _group(title: str, form: QFormLayout, parent: QWidget) -> QGroupBox:
    """``form`` under the heading ``title``."""
    group = QGroupBox(title, parent)
    group.setLayout(form)
    return group


class PreferencesDialog(QDialog):
    """Edits a ``Preferences``; ``chosen`` is the result once accepted."""

    def __init__(self, preferences: Preferences, parent=None) -> None:
        super().__init__(parent)
        self.setWindowTitle("Preferences")
        layout = QVBoxLayout(self)
        brush = QFormLayout()
        layout.addWidget(_group("Point Brush", brush, self))
        self.spins: dict[str, QDoubleSpinBox | QSpinBox] = {}
        for name, label, spin in brush_spins(self):
            self.spins[name] = spin
            brush.addRow(label, spin)
        self.mode = QComboBox(self)
        for value, label in BRUSH_MODES.items():
            self.mode.addItem(label, value)
        self.mode.setToolTip("The Point Brush's mode, kept from one start of the editor to the next")
        brush.addRow("Mode", self.mode)
        documents = QFormLayout()
        layout.addWidget(_group("Every document", documents, self))
        for name, label, (low, high), suffix, tip in (
                ("autosave_seconds", "Autosave after", AUTOSAVE_RANGE, " s",
                 "Seconds of unsaved changes before a document is saved to the recovery folder"),
                ("undo_memory_mib", "Undo memory", MEMORY_RANGE, " MiB",
                 "Memory each open document keeps for instant undo; older steps are solved again when visited")):
            spin = QSpinBox(self)
            spin.setRange(low, high)
            spin.setSuffix(suffix)
            spin.setToolTip(tip)
            self.spins[name] = spin
            documents.addRow(label, spin)
        buttons = QDialogButtonBox(QDialogButtonBox.StandardButton.Ok | QDialogButtonBox.StandardButton.Cancel
                                   | QDialogButtonBox.StandardButton.RestoreDefaults, parent=self)
        buttons.accepted.connect(self.accept)
        buttons.rejected.connect(self.reject)
        buttons.button(QDialogButtonBox.StandardButton.RestoreDefaults).clicked.connect(
            lambda: self.show_values(Preferences()))
        layout.addWidget(buttons)
        self.show_values(preferences)

    def show_values(self, preferences: Preferences) -> None:
        for name, spin in self.spins.items():
            spin.setValue(getattr(preferences, name))
        self.mode.setCurrentIndex(self.mode.findData(preferences.brush_mode))

    @property
    def chosen(self) -> Preferences:
        """The preferences as the dialog shows them."""
        values = {name: spin.value() for name, spin in self.spins.items()}
        return Preferences(brush_mode=self.mode.currentData(), **values)
