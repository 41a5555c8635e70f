"""Edit > Preferences: brush settings to start with, the autosave delay and the undo memory, kept across starts."""

from __future__ import annotations

from pathlib import Path

import pytest

pytest.importorskip("pytestqt", reason="pytest-qt is in the [test] extra")

from PySide6.QtCore import QSettings  # noqa: E402

from fmr_editor.engine import DEFAULT_MEMORY  # noqa: E402
from fmr_editor.tools import ToolOptions  # noqa: E402
from fmr_editor.ui.preferences import MIB, Preferences  # noqa: E402

RIBBON = Path(__file__).resolve().parents[1] / "resources" / "samples" / "ribbon.xml"


def test_missing_unreadable_or_out_of_range_values_take_their_defaults(tmp_path):
    settings = QSettings(str(tmp_path / "settings.ini"), QSettings.Format.IniFormat)
    assert Preferences.load(settings) == Preferences()
    defaults = ToolOptions()
    assert (Preferences().brush_radius, Preferences().brush_mode) == (defaults.brush_radius, defaults.brush_mode)
    assert Preferences().undo_memory == DEFAULT_MEMORY
    for name, value in (("brush_radius", "wide"), ("brush_spacing", -3.0), ("brush_mode", "smudge"),
                        ("autosave_seconds", 10**9), ("undo_memory_mib", "")):
        settings.setValue(f"preferences/{name}", value)
    settings.setValue("preferences/brush_amplitude", "0.75")  # as an ini file gives it back: text
    assert Preferences.load(settings) == Preferences(brush_amplitude=0.75)


@pytest.mark.gui
def test_preferences_apply_at_once_and_hold_after_a_restart(editor, tmp_path, qtbot):
    from fmr_editor.ui.main_window import MainWindow

    editor.open(RIBBON)
    window = editor.window
    window.actions["preferences"].trigger()
    dialog = window.preferences_dialog
    assert dialog.isVisible() and dialog.chosen == Preferences()
    dialog.spins["brush_radius"].setValue(7.5)
    dialog.spins["autosave_seconds"].setValue(30)
    dialog.spins["undo_memory_mib"].setValue(64)
    dialog.mode.setCurrentIndex(dialog.mode.findData("glow"))
    dialog.accept()
    chosen = Preferences(brush_radius=7.5, brush_mode="glow", autosave_seconds=30, undo_memory_mib=64)
    assert window.preferences == chosen
    # at once: the brush, the options panel, the autosave delay, the open document's undo memory
    assert (window.options.brush_radius, window.options.brush_mode) == (7.5, "glow")
    assert window.options_panel.spins["brush_radius"].value() == 7.5
    assert window.autosaver.seconds == 30
    assert window.workspace.engine._worker.live.memory == 64 * MIB  # noqa: SLF001 - what the engine will keep

    window.settings.sync()  # what quitting does
    restarted = MainWindow(QSettings(str(tmp_path / "settings.ini"), QSettings.Format.IniFormat))
    try:
        assert restarted.preferences == chosen
        assert (restarted.options.brush_radius, restarted.options.brush_mode) == (7.5, "glow")
        assert restarted.options_panel.brush_mode.currentData() == "glow"
        assert restarted.autosaver.seconds == 30
    finally:
        restarted._close_now = True  # noqa: SLF001 - nothing to ask
        restarted.close()
        restarted.deleteLater()


@pytest.mark.gui
def test_restore_defaults_and_cancel(editor):
    window = editor.window
    window.set_preferences(Preferences(brush_spacing=3.0))
    window.edit_preferences()
    dialog = window.preferences_dialog
    assert dialog.chosen == Preferences(brush_spacing=3.0)
    from PySide6.QtWidgets import QDialogButtonBox

    dialog.findChild(QDialogButtonBox).button(QDialogButtonBox.StandardButton.RestoreDefaults).click()
    assert dialog.chosen == Preferences()
    dialog.reject()
    assert window.preferences == Preferences(brush_spacing=3.0) and window.options.brush_spacing == 3.0


@pytest.mark.gui
def test_the_dialog_sets_its_settings_under_headings(editor):
    from PySide6.QtWidgets import QGroupBox

    window = editor.window
    window.edit_preferences()
    dialog = window.preferences_dialog
    groups = {group.title(): group for group in dialog.findChildren(QGroupBox)}
    assert set(groups) == {"Point Brush", "Every document"}
    brush, documents = groups["Point Brush"], groups["Every document"]
    assert all(brush.isAncestorOf(dialog.spins[name]) for name in ("brush_radius", "brush_amplitude", "brush_spacing"))
    assert brush.isAncestorOf(dialog.mode)
    assert all(documents.isAncestorOf(dialog.spins[name]) for name in ("autosave_seconds", "undo_memory_mib"))
    dialog.reject()


@pytest.mark.gui
def test_new_preferences_redraw_the_brush_circle_before_the_pointer_moves(editor):
    from PySide6.QtCore import QEvent, QObject
    from PySide6.QtWidgets import QApplication

    class Paints(QObject):
        count = 0

        def eventFilter(self, watched, event):  # noqa: N802 - Qt's name
            self.count += event.type() == QEvent.Type.Paint
            return False

    editor.open(RIBBON)
    window = editor.window
    paints = Paints()
    window.overlay.installEventFilter(paints)
    QApplication.processEvents()
    before = paints.count
    window.set_preferences(Preferences(brush_radius=42.0))
    editor.qtbot.waitUntil(lambda: paints.count > before)
    assert window.options.brush_radius == 42.0
    window.overlay.removeEventFilter(paints)
    editor.wait_idle()
