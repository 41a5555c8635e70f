"""The Help menu: the shortcuts listed from the actions themselves, the user guide, About with the version."""

from __future__ import annotations

import pytest

pytest.importorskip("pytestqt", reason="pytest-qt is in the [test] extra")

from PySide6.QtCore import QUrl  # noqa: E402
from PySide6.QtGui import QDesktopServices, QKeySequence, QTextDocument  # noqa: E402
from PySide6.QtWidgets import QMessageBox  # noqa: E402

import fmr_editor  # noqa: E402
from fmr_editor.tools import TOOLS  # noqa: E402
from fmr_editor.ui.help import GUIDE_PICTURE_WIDTH, USER_GUIDE, picture_fragments  # noqa: E402
from fmr_editor.ui.menus import ACTIONS  # noqa: E402

pytestmark = pytest.mark.gui
REPO = USER_GUIDE.parents[1]


def native(key: str) -> str:
    return QKeySequence(key).toString(QKeySequence.SequenceFormat.NativeText)


def test_the_shortcuts_dialog_lists_every_command_s_keys(editor):
    editor.window.actions["shortcuts"].trigger()
    table = editor.window.shortcuts_dialog.table
    listed = {table.item(row, 0).text(): table.item(row, 1).text() for row in range(table.rowCount())}
    expected = {text.replace("&", "").rstrip("\u2026"): ", ".join(map(native, keys))
                for text, keys, _, _ in ACTIONS.values() if keys}
    expected.update({tool.title: native(tool.shortcut) for tool in TOOLS})
    assert listed == expected
    assert listed["Actual Size"] == "1" and listed["Fit Canvas"] == "Ctrl+0, 5"
    dialog = editor.window.shortcuts_dialog
    editor.qtbot.waitExposed(dialog)
    header, metrics = table.horizontalHeader(), table.fontMetrics()
    assert header.length() == table.viewport().width()  # the columns fill the table
    widest = max(metrics.horizontalAdvance(keys) for keys in listed.values())
    assert header.sectionSize(1) > widest + 8  # the longest keys clear the column's edge
    dialog.close()


def test_help_shows_the_user_guide_in_the_editor_and_about_names_the_version(editor, monkeypatch):
    about = []
    monkeypatch.setattr(QMessageBox, "about", staticmethod(lambda parent, title, text: about.append(text)))
    editor.window.actions["user_guide"].trigger()  # F1: no viewer of the desktop needed
    dialog = editor.window.guide_dialog
    document = dialog.text.document()
    assert dialog.isVisible() and document.toPlainText().startswith("User guide")  # the heading, rendered
    pictures = [fragment.charFormat().toImageFormat() for fragment in picture_fragments(document)]
    assert [picture.name() for picture in pictures] == ["screenshot.png", "layers.png", "clone.png"]  # each once
    assert all(0 < picture.width() <= GUIDE_PICTURE_WIDTH for picture in pictures)  # and no wider than the viewer
    pictures = {picture.name() for picture in pictures}
    for name in pictures:  # each found beside the guide
        assert not document.resource(QTextDocument.ResourceType.ImageResource, QUrl(name)).isNull(), name
    opened = []
    monkeypatch.setattr(QDesktopServices, "openUrl", staticmethod(lambda url: opened.append(url) or True))
    assert not dialog.back_button.isEnabled()
    dialog.follow(QUrl("#command-line"))  # a heading of the page shown: it stays as it is
    assert dialog.shown == USER_GUIDE and not opened
    dialog.follow(QUrl("../README.md"))  # the guide's link to the README: shown here
    assert dialog.shown.name == "README.md" and document.toPlainText().startswith("fmr-editor")
    dialog.follow(QUrl("docs/examples/layers.py"))  # the README's link to an example: outside
    dialog.follow(QUrl("https://example.org/"))  # the web: in the browser
    assert [url.toString() for url in opened] == [QUrl.fromLocalFile(str(REPO / "docs/examples/layers.py")).toString(),
                                                  "https://example.org/"]
    dialog.back_button.click()
    assert dialog.shown == USER_GUIDE and document.toPlainText().startswith("User guide")
    assert not dialog.back_button.isEnabled()
    dialog.close()
    editor.window.actions["user_guide"].trigger()  # F1 again: the same window
    assert editor.window.guide_dialog is dialog and dialog.isVisible()
    dialog.close()
    editor.window.actions["about"].trigger()
    assert len(about) == 1 and fmr_editor.__version__ in about[0]
