"""The Help menu's windows: the keyboard shortcuts, made from the actions themselves, and the user guide."""

from __future__ import annotations

from pathlib import Path

from PySide6.QtCore import QUrl
from PySide6.QtGui import QAction, QDesktopServices, QKeySequence
from PySide6.QtWidgets import QDialog, QDialogButtonBox, QHeaderView, QTableWidget, QTableWidgetItem, QVBoxLayout

#: The user guide in a checkout of the repository (``docs/user-guide.md``).
USER_GUIDE = Path(__file__).resolve().parents[2] / "docs" / "user-guide.md"


def shortcut_rows(actions: dict[str, QAction]) -> list[tuple[str, str]]:
    """``(command, keys)`` of every action with a shortcut, in the actions' order, as the menus spell them."""
    rows = []
    for action in actions.values():
        keys = [key.toString(QKeySequence.SequenceFormat.NativeText) for key in action.shortcuts()]
        if keys:
            rows.append((action.text().replace("&", "").rstrip("\u2026"), ", ".join(keys)))
    return rows


class ShortcutsDialog(QDialog):
    """Help > Keyboard Shortcuts: every action's keys (so the list cannot drift from what the keys do)."""

    def __init__(self, actions: dict[str, QAction], parent=None) -> None:
        super().__init__(parent)
        self.setWindowTitle("Keyboard Shortcuts")
        rows = shortcut_rows(actions)
        self.table = QTableWidget(len(rows), 2, self)
        self.table.setHorizontalHeaderLabels(["Command", "Keys"])
        self.table.verticalHeader().hide()
        self.table.setEditTriggers(QTableWidget.EditTrigger.NoEditTriggers)
        for row, (command, keys) in enumerate(rows):
            self.table.setItem(row, 0, QTableWidgetItem(command))
            self.table.setItem(row, 1, QTableWidgetItem(keys))
        header = self.table.horizontalHeader()
        header.setSectionResizeMode(0, QHeaderView.ResizeMode.ResizeToContents)
        header.setSectionResizeMode(1, QHeaderView.ResizeMode.Stretch)  # the keys take the rest of the width
        buttons = QDialogButtonBox(QDialogButtonBox.StandardButton.Close, self)
        buttons.rejected.connect(self.reject)
        layout = QVBoxLayout(self)
        layout.addWidget(self.table)
        layout.addWidget(buttons)
        self.resize(460, 560)


def open_user_guide() -> bool:
    """Open ``USER_GUIDE`` with the desktop's viewer; False when nothing opened it."""
    return QDesktopServices.openUrl(QUrl.fromLocalFile(str(USER_GUIDE)))
