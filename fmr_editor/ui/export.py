"""Export PNG and SVG: the size and antialiasing dialog, and the export itself (CPU rasteriser).

The export runs on a ``jobs.Job``: ``export_picture`` rasterises the
representation the engine built (``engine.rasterise``, the same pixels as
``fmr-editor render``) with progress, and writes the file atomically: a PNG,
or an SVG of that PNG with the curves kept as hidden paths (``io.svg_export``).
"""

from __future__ import annotations

import os
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from PySide6.QtWidgets import (
    QCheckBox,
    QDialog,
    QDialogButtonBox,
    QFormLayout,
    QHBoxLayout,
    QLineEdit,
    QPushButton,
    QSpinBox,
    QToolButton,
)

from ..engine import Composite, LiveStack, Representation, Settings, check_image_memory, rasterise
from ..io import save_picture
from ..io.png import flattened
from ..model import Document
from .colors import pick_color
from .files import EXPORTS, ask_export_path
from .gradient_bar import qcolor
from .stops_panel import swatch

#: Largest output side, pixels.
MAX_SIDE = 32768
#: Most samples per pixel side.
MAX_SAMPLES = 8


@dataclass(frozen=True)
class ExportOptions:
    """Where and how to export.

    Attributes
    ----------
    path : pathlib.Path
        A ``.svg`` path writes an SVG, any other a PNG.
    width, height : int
        Output size in pixels.
    samples : int
        ``samples x samples`` supersampling per pixel (1: none).
    background : tuple of float, optional
        Lay a picture that is not opaque on this colour; None writes RGBA where it is not.
    """

    path: Path
    width: int
    height: int
    samples: int = 3
    background: tuple[float, float, float] | None = None


def export_picture(options: ExportOptions, document: Document, picture: Composite | Representation | None,
                   settings: Settings = Settings(), progress: Callable[[str, float], None] | None = None) -> Path:
    """Rasterise ``picture`` (``document``'s, built first if None) and write the PNG or SVG; returns the path
    written."""
    check_image_memory(options.width, options.height)
    if picture is None:
        picture = LiveStack(document, settings, progress).composite
    image = rasterise(picture, options.width, options.height, samples=options.samples, progress=progress,
                      coverage=True)  # RGBA where the picture is not opaque
    if options.background is not None:
        image = flattened(image, options.background)
    if progress:
        progress("write", 1.0)
    return save_picture(document, image.clip(0.0, 1.0), options.path)


class ExportDialog(QDialog):
    """Asks for the PNG's (or SVG's) file, size (aspect kept on request) and antialiasing.

    Parameters
    ----------
    canvas : tuple of int
        The document's canvas size (the default output size).
    path : pathlib.Path
        The suggested file; its suffix, ``.png`` or ``.svg``, is the kind exported.
    parent : QWidget, optional
    """

    def __init__(self, canvas: tuple[int, int], path: Path, parent=None) -> None:
        super().__init__(parent)
        self.suffix = path.suffix.lower() if path.suffix.lower() in EXPORTS else ".png"
        self.setWindowTitle(EXPORTS[self.suffix][0])
        self.canvas = canvas
        self.path_edit = QLineEdit(str(path), self)
        browse = QPushButton("Browse\u2026", self)
        browse.clicked.connect(self._browse)
        where = QHBoxLayout()
        where.addWidget(self.path_edit, 1)
        where.addWidget(browse)
        self.width_box, self.height_box = QSpinBox(self), QSpinBox(self)
        for box, value in ((self.width_box, canvas[0]), (self.height_box, canvas[1])):
            box.setRange(1, MAX_SIDE)
            box.setValue(value)
            box.setSuffix(" px")
        self.keep_aspect = QCheckBox("Keep the canvas's aspect ratio", self)
        self.keep_aspect.setChecked(True)
        self.width_box.valueChanged.connect(lambda v: self._follow(self.height_box, v * canvas[1] / canvas[0]))
        self.height_box.valueChanged.connect(lambda v: self._follow(self.width_box, v * canvas[0] / canvas[1]))
        self.samples_box = QSpinBox(self)
        self.samples_box.setRange(1, MAX_SAMPLES)
        self.samples_box.setValue(3)
        self.samples_box.setToolTip("Antialiasing: N x N samples per pixel (1: none)")
        self.flatten = QCheckBox("Lay it on a colour where it is not opaque", self)
        self.flatten.setToolTip("Unchecked, a picture that is not opaque everywhere is written with transparency")
        self.background_button = QToolButton(self)
        self.background_button.setToolTip("The colour to lay the picture on")
        self.background_button.clicked.connect(self._choose_background)
        self.set_background((1.0, 1.0, 1.0))
        flatten_row = QHBoxLayout()
        flatten_row.addWidget(self.flatten)
        flatten_row.addWidget(self.background_button)
        flatten_row.addStretch(1)
        buttons = QDialogButtonBox(QDialogButtonBox.StandardButton.Ok | QDialogButtonBox.StandardButton.Cancel)
        buttons.button(QDialogButtonBox.StandardButton.Ok).setText("Export")
        buttons.accepted.connect(self.accept)
        buttons.rejected.connect(self.reject)
        form = QFormLayout(self)
        form.addRow("File", where)  # a layout, not a widget holding it: no margins of its own, so it lines up
        form.addRow("Width", self.width_box)
        form.addRow("Height", self.height_box)
        form.addRow("", self.keep_aspect)
        form.addRow("Antialiasing (samples per side)", self.samples_box)
        form.addRow("", flatten_row)
        form.addRow(buttons)

    def _follow(self, box: QSpinBox, value: float) -> None:
        if self.keep_aspect.isChecked():
            box.blockSignals(True)
            box.setValue(max(1, round(value)))
            box.blockSignals(False)

    def set_background(self, color: tuple[float, float, float]) -> None:
        """Lay the picture on ``color`` (when ``flatten`` is checked)."""
        self.background = tuple(float(v) for v in color)
        self.background_button.setIcon(swatch(qcolor(self.background), 20))

    def _choose_background(self) -> None:
        chosen = pick_color(self, self.background, "Background Colour")
        if chosen is not None:
            self.set_background(chosen)
            self.flatten.setChecked(True)

    def _browse(self) -> None:
        chosen = ask_export_path(self, self.path_edit.text(), self.suffix)
        if chosen is not None:
            self.path_edit.setText(str(chosen))

    def options(self) -> ExportOptions:
        """What the dialog shows now."""
        path = Path(os.path.expanduser(self.path_edit.text().strip() or f"export{self.suffix}"))
        if path.suffix.lower() != self.suffix:
            path = path.with_name(path.name + self.suffix)
        return ExportOptions(path, self.width_box.value(), self.height_box.value(), self.samples_box.value(),
                             self.background if self.flatten.isChecked() else None)

    @staticmethod
    def get_options(canvas: tuple[int, int], path: Path, parent=None) -> ExportOptions | None:
        """Show the dialog (modal); the options, or None when cancelled."""
        dialog = ExportDialog(canvas, path, parent)
        return dialog.options() if dialog.exec() == QDialog.DialogCode.Accepted else None
