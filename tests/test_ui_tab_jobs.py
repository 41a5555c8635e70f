"""A job belongs to its tab: while one document opens or saves, every other tab stays fully usable.

The slow work is held on an event the test releases, so what the window does meanwhile is checked at a
known moment, not raced against a real solve.
"""

from __future__ import annotations

import shutil
import threading
from pathlib import Path

import pytest
from canvas_oracle import mismatches

pytest.importorskip("pytestqt", reason="pytest-qt is in the [test] extra")

from PySide6.QtCore import Qt  # noqa: E402

from fmr_editor.ui import file_commands  # noqa: E402

pytestmark = pytest.mark.gui

RIBBON = Path(__file__).resolve().parents[1] / "resources" / "samples" / "ribbon.xml"
#: 8-bit levels a shown pixel may differ from the CPU's value (rounding, and the shader's float32 near field).
LEVELS = 2.0


class Held:
    """Stands in for ``real(*args)`` on a job: reports 30% when its last argument is the progress, waits for
    ``release``, then does the real work."""

    def __init__(self, real, reports: bool = True) -> None:
        self.real, self.reports = real, reports
        self.started, self.release = threading.Event(), threading.Event()

    def __call__(self, *args, **kwargs):
        if self.reports:
            args[-1]("solve", 0.3)
        self.started.set()
        assert self.release.wait(60), "the test never released the job"
        return self.real(*args, **kwargs)


def shows_the_cpu_raster(editor) -> None:
    """The canvas at 1:1 shows the CPU composite of the shown document (over the checkerboard where it is clear)."""
    editor.window.actual_size()
    editor.wait_idle()
    off = mismatches(editor.canvas.grab_image(), editor.fresh_picture(), editor.canvas.device_view(),
                     LEVELS)
    assert off["inside"] == 0 and off["outside"] == 0, off


@pytest.fixture
def opening_in_second_tab(editor, tmp_path, monkeypatch):
    """Ribbon open in the first tab; ``slow.xml`` (a copy) held while opening in the second, shown."""
    editor.open(RIBBON)
    slow = tmp_path / "slow.xml"
    shutil.copy(RIBBON, slow)
    held = Held(file_commands.open_file)
    monkeypatch.setattr(file_commands, "open_file", held)
    editor.window.open_path(slow)
    editor.qtbot.waitUntil(held.started.is_set, timeout=10_000)
    try:
        yield editor, held, slow
    finally:
        held.release.set()


def test_a_second_tab_stays_usable_while_the_first_opens_a_slow_file(opening_in_second_tab):
    editor, held, slow = opening_in_second_tab
    window, qtbot = editor.window, editor.qtbot
    first = window.workspaces[0]
    # the opening tab shows its job: progress on the tab and in the status bar, Cancel, nothing to edit
    qtbot.waitUntil(lambda: window.tabs.tabText(1) == "slow.xml (30%)", timeout=10_000)
    assert window.shown.name == "slow.xml" and window.workspace is None and window.windowTitle().startswith("slow.xml")
    assert window.status_label.text() == "Opening slow.xml" and window.cancel_button.isVisible()
    assert not window.actions["save"].isEnabled() and window.actions["open"].isEnabled()
    assert not window.zoom_button.isVisible()

    editor.key(Qt.Key.Key_PageUp, Qt.KeyboardModifier.ControlModifier)  # the first tab, while the job is held
    assert window.workspace is first and window.job is not None and window.job.isRunning()
    assert window.zoom_button.isVisible()
    assert not window.cancel_button.isVisible() and not window.progress_bar.isVisible()
    assert window.layers_panel.isEnabled() and window.history_panel.isEnabled()
    assert window.actions["save"].isEnabled() and not window.actions["undo"].isEnabled()

    # its commands act: Select All and Delete is one step, and the canvas shows the result as the CPU draws it
    steps = first.history.index
    window.actions["select_all"].trigger()
    window.actions["delete"].trigger()
    assert first.history.index == steps + 1 and editor.document.curves == ()
    shows_the_cpu_raster(editor)
    window.actions["undo"].trigger()
    assert len(editor.document.curves) > 0
    shows_the_cpu_raster(editor)
    # and its view answers
    scale = editor.canvas.view.scale
    window.actions["zoom_in"].trigger()
    assert editor.canvas.view.scale > scale

    editor.key(Qt.Key.Key_PageDown, Qt.KeyboardModifier.ControlModifier)  # back to the opening tab
    assert window.workspace is None and window.cancel_button.isVisible() and window.progress_bar.isVisible()
    held.release.set()
    qtbot.waitUntil(lambda: window.job is None, timeout=60_000)
    assert [tab.name for tab in window.open_tabs] == ["ribbon.xml", "slow.xml"]
    assert window.workspace is window.workspaces[1] and window.workspace.path == slow
    assert window.tabs.tabText(1) == "slow.xml" and not window.cancel_button.isVisible()


def test_a_file_opened_in_the_background_does_not_take_the_front(opening_in_second_tab):
    editor, held, slow = opening_in_second_tab
    window = editor.window
    first = window.workspaces[0]
    window.previous_document()
    held.release.set()
    editor.qtbot.waitUntil(lambda: window.job is None, timeout=60_000)
    assert window.workspace is first and [w.path for w in window.workspaces] == [RIBBON, slow]
    window.next_document()
    assert window.workspace.path == slow


def test_closing_a_tab_that_is_still_opening_cancels_it_and_shows_the_tab_it_came_from(opening_in_second_tab):
    editor, held, slow = opening_in_second_tab
    window = editor.window
    first = window.workspaces[0]
    window.tabs.tabCloseRequested.emit(1)  # its close button
    held.release.set()
    editor.qtbot.waitUntil(lambda: window.job is None, timeout=60_000)
    assert window.open_tabs == [first] and window.workspace is first
    assert window.status_label.text() == "Cancelled: Opening slow.xml" and editor.errors == []


def test_a_document_being_saved_waits_while_another_tab_is_edited(editor, tmp_path, monkeypatch):
    editor.open(RIBBON)
    window, qtbot = editor.window, editor.qtbot
    first = window.workspace
    held = Held(file_commands.save_fmr, reports=False)
    monkeypatch.setattr(file_commands, "save_fmr", held)
    window.new_document((96, 64))
    qtbot.waitUntil(lambda: window.job is None and len(window.workspaces) == 2, timeout=30_000)
    second = window.workspace
    window.previous_document()
    try:
        window.save_to(tmp_path / "first.fmr")
        qtbot.waitUntil(held.started.is_set, timeout=10_000)
        assert first.task is not None and window.status_label.text() == "Saving first.fmr"
        assert not window.layers_panel.isEnabled() and not window.actions["delete"].isEnabled()
        steps = first.history.index
        window.actions["select_all"].trigger()
        window.actions["delete"].trigger()
        assert first.history.index == steps  # the document being saved is not edited

        window.next_document()
        assert window.workspace is second and window.layers_panel.isEnabled()
        window.actions["select_all"].trigger()
        window.actions["delete"].trigger()
        assert second.history.document.curves == () and second.history.modified
    finally:
        held.release.set()
    qtbot.waitUntil(lambda: window.job is None, timeout=30_000)
    assert (tmp_path / "first.fmr").exists() and not first.history.modified and first.task is None
