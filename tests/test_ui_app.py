"""Starting the editor: ``fmr-editor [FILE]``, the display check, and the editor's run loop."""

from __future__ import annotations

from pathlib import Path

import pytest

from fmr_editor.cli import main
from fmr_editor.ui.app import display_problem

REPO = Path(__file__).resolve().parents[1]
RIBBON = REPO / "resources" / "samples" / "ribbon.xml"


def test_display_problem_says_why_no_window_can_open():
    assert "fmr-editor render" in display_problem({}, "linux")
    assert display_problem({"DISPLAY": ":1"}, "linux") is None
    assert display_problem({"WAYLAND_DISPLAY": "wayland-0"}, "linux") is None
    assert display_problem({"QT_QPA_PLATFORM": "offscreen"}, "linux") is None
    assert display_problem({}, "win32") is None


def test_without_a_display_the_editor_says_so_in_one_line(monkeypatch, capsys):
    for name in ("DISPLAY", "WAYLAND_DISPLAY", "QT_QPA_PLATFORM"):
        monkeypatch.delenv(name, raising=False)
    monkeypatch.setattr("sys.platform", "linux")
    assert main([str(RIBBON)]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("fmr-editor: no display") and "\n" not in err


def test_a_missing_file_is_reported_before_any_window(tmp_path, capsys):
    assert main([str(tmp_path / "absent.fmr")]) == 2
    assert capsys.readouterr().err.strip() == f"fmr-editor: cannot open {tmp_path / 'absent.fmr'}: no such file"


def test_help_names_the_editor_and_the_render_command(capsys):
    with pytest.raises(SystemExit) as stop:
        main(["--help"])
    assert stop.value.code == 0
    out = capsys.readouterr().out
    assert "fmr-editor [FILE ...]" in out and "fmr-editor render" in out and "fmr-editor clone" in out


@pytest.mark.gui
def test_the_editor_opens_its_files_in_tabs_and_returns_when_closed(gl_display, qapp, tmp_path, monkeypatch):
    pytest.importorskip("pytestqt", reason="pytest-qt is in the [test] extra")
    from PySide6.QtCore import QSettings, QTimer
    from shapes import scattered_document

    from fmr_editor.io import save_fmr
    from fmr_editor.ui import app
    from fmr_editor.ui.files import RecentFiles
    from fmr_editor.ui.main_window import MainWindow

    other = save_fmr(tmp_path / "other.fmr", scattered_document(64))
    seen = []

    def close_when_open() -> None:
        windows = [w for w in qapp.topLevelWidgets() if isinstance(w, MainWindow) and w.isVisible()]
        ready = [w for w in windows if len(w.workspaces) == 2 and w.job is None and w.workspace.current]
        if ready:
            tabs = ready[0].tabs
            seen.append((ready[0].windowTitle(), [tabs.tabText(i) for i in range(tabs.count())]))
            ready[0].close()
        else:
            QTimer.singleShot(50, close_when_open)

    QTimer.singleShot(50, close_when_open)
    monkeypatch.setenv("XDG_DATA_HOME", str(tmp_path / "data"))  # its own autosave folder
    settings = QSettings(str(tmp_path / "settings.ini"), QSettings.Format.IniFormat)
    assert app.main([RIBBON, other], settings=settings) == 0
    assert seen == [("other.fmr \u2014 FMR Editor", ["ribbon.xml", "other.fmr"])]
    assert RecentFiles(settings).paths() == [other, RIBBON]
