"""The Help menu: the shortcuts listed from the actions themselves, the user guide, About with the version."""

from __future__ import annotations

import pytest

pytest.importorskip("pytestqt", reason="pytest-qt is in the [test] extra")

from PySide6.QtGui import QDesktopServices, QKeySequence  # noqa: E402
from PySide6.QtWidgets import QMessageBox  # noqa: E402

import fmr_editor  # noqa: E402
from fmr_editor.tools import TOOLS  # noqa: E402
from fmr_editor.ui.menus import ACTIONS  # noqa: E402

pytestmark = pytest.mark.gui


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


def test_help_opens_the_user_guide_and_about_names_the_version(editor, monkeypatch):
    opened, about = [], []
    monkeypatch.setattr(QDesktopServices, "openUrl", staticmethod(lambda url: opened.append(url) or True))
    monkeypatch.setattr(QMessageBox, "about", staticmethod(lambda parent, title, text: about.append(text)))
    editor.window.actions["user_guide"].trigger()
    assert len(opened) == 1 and opened[0].toLocalFile().endswith("docs/user-guide.md")
    with open(opened[0].toLocalFile()) as guide:
        assert guide.readline().startswith("# User guide")
    editor.window.actions["about"].trigger()
    assert len(about) == 1 and fmr_editor.__version__ in about[0]
