"""Long jobs can be cancelled with the status bar's button and with Esc; the document stays as it was."""

from __future__ import annotations

import threading
import time
from pathlib import Path

import pytest

pytest.importorskip("pytestqt", reason="pytest-qt is in the [test] extra")

from PySide6.QtCore import Qt  # noqa: E402

from fmr_editor.ui import file_commands  # noqa: E402

pytestmark = pytest.mark.gui

RIBBON = Path(__file__).resolve().parents[1] / "resources" / "samples" / "ribbon.xml"


def endless(started: threading.Event):
    """Work that reports progress until it is cancelled (as a build does between its stages)."""
    def work(path, progress):
        started.set()
        while True:
            progress("solve", 0.5)
            time.sleep(0.005)
    return work


@pytest.mark.parametrize("how", ["button", "escape"])
def test_opening_a_file_can_be_cancelled_and_leaves_the_open_document_as_it_was(editor, monkeypatch, how):
    editor.open(RIBBON)
    window = editor.window
    before, tabs = window.workspace.history.document, len(window.workspaces)
    started = threading.Event()
    monkeypatch.setattr(file_commands, "open_file", endless(started))
    window.open_path(Path("/nowhere/slow.xml"))
    editor.qtbot.waitUntil(started.is_set, timeout=10_000)
    assert window.cancel_button.isVisible()
    if how == "button":
        window.cancel_button.click()
    else:
        editor.key(Qt.Key.Key_Escape)
    editor.qtbot.waitUntil(lambda: window.job is None, timeout=10_000)
    assert window.status_label.text() == "Cancelled: Opening slow.xml"
    assert not window.cancel_button.isVisible() and editor.errors == []
    assert len(window.workspaces) == tabs and window.workspace.history.document is before
    assert window.canvas.isEnabled()  # editing resumes


def test_escape_still_reaches_the_tools_when_no_job_runs(editor):
    editor.open(RIBBON)
    assert not editor.window.cancel_shortcut.isEnabled()
