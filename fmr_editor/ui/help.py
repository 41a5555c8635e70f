"""The Help menu's windows: the keyboard shortcuts, made from the actions themselves, and the user guide, shown in
the editor."""

from __future__ import annotations

import re
from collections.abc import Iterator
from pathlib import Path

from PySide6.QtCore import QUrl
from PySide6.QtGui import QAction, QDesktopServices, QKeySequence, QTextCursor, QTextDocument, QTextFragment
from PySide6.QtWidgets import (
    QDialog,
    QDialogButtonBox,
    QHeaderView,
    QTableWidget,
    QTableWidgetItem,
    QTextBrowser,
    QVBoxLayout,
    QWidget,
)

#: The user guide in a checkout of the repository (``docs/user-guide.md``).
USER_GUIDE = Path(__file__).resolve().parents[2] / "docs" / "user-guide.md"
#: The widest a picture of the guide is shown, pixels (its viewer opens 760 wide).
GUIDE_PICTURE_WIDTH = 680


def _lay_out(dialog: QDialog, content: QWidget, width: int, height: int) -> QDialogButtonBox:
    """``content`` above a Close button in ``dialog``, which opens ``width x height``; the buttons."""
    buttons = QDialogButtonBox(QDialogButtonBox.StandardButton.Close, dialog)
    buttons.rejected.connect(dialog.reject)
    layout = QVBoxLayout(dialog)
    layout.addWidget(content)
    layout.addWidget(buttons)
    dialog.resize(width, height)
    return buttons


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
        _lay_out(self, self.table, 460, 560)


def one_line_alt_texts(markdown: str) -> str:
    """``markdown`` with each picture's description on one line: Qt's reader shows a picture once for every line
    of it (three lines, three pictures)."""
    return re.sub(r"!\[([^\]]*)\]", lambda match: "![" + " ".join(match.group(1).split()) + "]", markdown)


class GuideDialog(QDialog):
    """Help > User Guide: ``USER_GUIDE`` shown in the editor itself (no viewer of the desktop needed), its
    pictures beside it; its links to the other documents open them here, links to the web in the browser."""

    def __init__(self, parent=None) -> None:
        super().__init__(parent)
        self.setWindowTitle("User Guide")
        self.text = QTextBrowser(self)
        self.text.setOpenLinks(False)
        self.text.anchorClicked.connect(self.follow)
        self.back_button = _lay_out(self, self.text, 760, 680).addButton("Back", QDialogButtonBox.ButtonRole.ActionRole)
        self.back_button.clicked.connect(self.back)
        self._before: list[Path] = []  # the files shown before the one shown, which Back returns to
        self.show_file(USER_GUIDE)

    def show_file(self, path: Path) -> None:
        """Show the markdown file ``path``, its pictures from its folder (``shown``: what links are relative to)."""
        self.shown = path
        self.text.setSearchPaths([str(path.parent)])
        self.text.setMarkdown(one_line_alt_texts(path.read_text(encoding="utf-8")))
        self._fit_pictures(GUIDE_PICTURE_WIDTH)
        self.back_button.setEnabled(bool(self._before))

    def follow(self, url: QUrl) -> None:
        """A link: a markdown file beside the one shown (``../README.md``) is shown here (at its top: Qt gives its
        headings no anchors), another file of the repository (an example, the licence) and the web outside."""
        if url.scheme() not in ("", "file"):
            QDesktopServices.openUrl(url)
            return
        if not url.path():  # a heading of the page shown
            return
        target = (self.shown.parent / url.path()).resolve()
        if target.suffix.lower() == ".md" and target.is_file():
            self._before.append(self.shown)
            self.show_file(target)
        elif target.exists():
            QDesktopServices.openUrl(QUrl.fromLocalFile(str(target)))

    def back(self) -> None:
        """Show the file shown before the last link followed."""
        if self._before:
            self.show_file(self._before.pop())

    def _fit_pictures(self, width: int) -> None:
        """Show each picture wider than ``width`` pixels at that width (the screenshots are the window's size)."""
        document = self.text.document()
        for fragment in list(picture_fragments(document)):
            picture = fragment.charFormat().toImageFormat()
            image = document.resource(QTextDocument.ResourceType.ImageResource, QUrl(picture.name()))
            if not image.isNull() and image.width() > width:
                picture.setWidth(width)
                picture.setHeight(image.height() * width / image.width())
                cursor = QTextCursor(document)
                cursor.setPosition(fragment.position())
                cursor.setPosition(fragment.position() + fragment.length(), QTextCursor.MoveMode.KeepAnchor)
                cursor.setCharFormat(picture)


def picture_fragments(document: QTextDocument) -> Iterator[QTextFragment]:
    """The fragments of ``document`` that are pictures, in order."""
    block = document.begin()
    while block.isValid():
        fragments = block.begin()
        while not fragments.atEnd():
            fragment = fragments.fragment()
            if fragment.charFormat().isImageFormat():
                yield fragment
            fragments += 1
        block = block.next()
