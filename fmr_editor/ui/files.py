"""File dialogs, the recent-files list and the new-canvas dialog.

The dialogs go through ``QFileDialog``'s and ``QMessageBox``'s static
methods (tests replace them); the recent files live in a ``QSettings`` that
the window is given (no global settings object).
"""

from __future__ import annotations

import os
from pathlib import Path

from PySide6.QtCore import QSettings
from PySide6.QtWidgets import QDialog, QDialogButtonBox, QFileDialog, QFormLayout, QMessageBox, QSpinBox

from ..model.limits import MAX_CANVAS_SIDE

#: Suffixes the editor opens.
OPENABLE = (".fmr", ".xml", ".svg")
OPEN_FILTER = ("Documents (*.fmr *.xml *.svg);;FMR documents (*.fmr);;Orzan curve sets (*.xml);;SVG images (*.svg);;"
               "All files (*)")
IMPORT_SVG_FILTER = "SVG images (*.svg)"
SAVE_FILTER = "FMR documents (*.fmr)"
#: What each export writes: its dialog's title and file filter, by suffix.
EXPORTS = {".png": ("Export PNG", "PNG images (*.png)"), ".svg": ("Export SVG", "SVG images (*.svg)")}
#: Largest canvas side the new-canvas dialog offers, pixels.
MAX_CANVAS = MAX_CANVAS_SIDE


def openable(path: str | os.PathLike) -> bool:
    """True for a file name the editor can open (by its suffix)."""
    return Path(path).suffix.lower() in OPENABLE


def ask_open_path(parent, folder: str = "", title: str = "Open Document", filters: str = OPEN_FILTER) -> Path | None:
    """Ask for a document to open; None when cancelled."""
    path, _ = QFileDialog.getOpenFileName(parent, title, folder, filters)
    return Path(path) if path else None


def ask_save_path(parent, suggested: str | os.PathLike) -> Path | None:
    """Ask where to save as ``.fmr`` (the suffix is added when missing); None when cancelled."""
    return _ask_target(parent, "Save Document As", suggested, SAVE_FILTER, ".fmr")


def ask_export_path(parent, suggested: str | os.PathLike, suffix: str = ".png") -> Path | None:
    """Ask where to export a PNG or an SVG (``suffix``, added when missing); None when cancelled."""
    title, filters = EXPORTS[suffix]
    return _ask_target(parent, title, suggested, filters, suffix)


def _ask_target(parent, title: str, suggested: str | os.PathLike, filters: str, suffix: str) -> Path | None:
    path, _ = QFileDialog.getSaveFileName(parent, title, str(suggested), filters)
    if not path:
        return None
    path = Path(path)
    return path if path.suffix.lower() == suffix else path.with_name(path.name + suffix)


def ask_keep_changes(parent, name: str, others: int = 0) -> str:
    """Ask what to do with unsaved changes of ``name``: ``"save"``, ``"discard"`` or ``"cancel"``; with ``others``
    documents of unsaved changes waiting after it, ``"discard all"`` too (No to All: none of them saved)."""
    buttons = QMessageBox.StandardButton
    question = f"Save the changes to {name} before closing it?"
    choices = buttons.Save | buttons.Discard | buttons.Cancel
    if others:
        question += f" ({others} more {'document has' if others == 1 else 'documents have'} unsaved changes.)"
        choices |= buttons.NoToAll
    answer = QMessageBox.question(parent, "Unsaved Changes", question, choices, buttons.Save)
    return {buttons.Save: "save", buttons.Discard: "discard", buttons.NoToAll: "discard all"}.get(answer, "cancel")


def show_error(parent, title: str, message: str) -> None:
    """A critical message box."""
    QMessageBox.critical(parent, title, message)


class RecentFiles:
    """The most recently opened or saved files, newest first, kept in ``settings``.

    Parameters
    ----------
    settings : QSettings
    limit : int
        How many to keep.
    """

    KEY = "recentFiles"

    def __init__(self, settings: QSettings, limit: int = 10) -> None:
        self.settings = settings
        self.limit = limit

    def paths(self) -> list[Path]:
        """The files, newest first (those that no longer exist included)."""
        value = self.settings.value(self.KEY, [])
        if isinstance(value, str):  # QSettings gives a lone string for a list of one
            value = [value]
        # resolved: a file listed before under two spellings of its path (``..``, a link) is listed once
        return list(dict.fromkeys(Path(text).resolve() for text in value or [] if text))

    def add(self, path: str | os.PathLike) -> None:
        """Put ``path`` first."""
        path = Path(path).resolve()
        paths = [path] + [p for p in self.paths() if p != path]
        self._store(paths[: self.limit])

    def remove(self, path: str | os.PathLike) -> None:
        path = Path(path).resolve()
        self._store([p for p in self.paths() if p != path])

    def clear(self) -> None:
        self._store([])

    def _store(self, paths: list[Path]) -> None:
        self.settings.setValue(self.KEY, [str(p) for p in paths])
        self.settings.sync()


class NewDocumentDialog(QDialog):
    """Asks for the canvas size of a new document."""

    def __init__(self, parent=None, width: int = 512, height: int = 512) -> None:
        super().__init__(parent)
        self.setWindowTitle("New Document")
        self.width_box, self.height_box = QSpinBox(self), QSpinBox(self)
        for box, value in ((self.width_box, width), (self.height_box, height)):
            box.setRange(1, MAX_CANVAS)
            box.setValue(value)
            box.setSuffix(" px")
        buttons = QDialogButtonBox(QDialogButtonBox.StandardButton.Ok | QDialogButtonBox.StandardButton.Cancel)
        buttons.accepted.connect(self.accept)
        buttons.rejected.connect(self.reject)
        form = QFormLayout(self)
        form.addRow("Width", self.width_box)
        form.addRow("Height", self.height_box)
        form.addRow(buttons)

    def size_chosen(self) -> tuple[int, int]:
        return self.width_box.value(), self.height_box.value()

    @staticmethod
    def get_size(parent=None, width: int = 512, height: int = 512) -> tuple[int, int] | None:
        """Ask for a canvas size (modal); None when cancelled."""
        dialog = NewDocumentDialog(parent, width, height)
        return dialog.size_chosen() if dialog.exec() == QDialog.DialogCode.Accepted else None
