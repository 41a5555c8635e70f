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


def test_the_command_line_leaves_missing_files_to_the_window(tmp_path, monkeypatch):
    """``fmr-editor A missing B`` starts the editor on all three (it names the missing one and opens the others)."""
    started = []
    monkeypatch.setattr("fmr_editor.ui.app.main", lambda paths: started.append(paths) or 0)
    files = [str(RIBBON), str(tmp_path / "missing.fmr"), str(RIBBON)]
    assert main(files) == 0 and started == [files]


def test_help_names_the_editor_and_the_render_command(capsys):
    with pytest.raises(SystemExit) as stop:
        main(["--help"])
    assert stop.value.code == 0
    out = capsys.readouterr().out
    assert "fmr-editor [FILE ...]" in out and "fmr-editor render" in out and "fmr-editor clone" in out


@pytest.mark.gui
def test_the_editor_opens_its_files_in_tabs_names_a_missing_one_and_returns_when_closed(gl_display, qapp, tmp_path,
                                                                                      monkeypatch):
    pytest.importorskip("pytestqt", reason="pytest-qt is in the [test] extra")
    from PySide6.QtCore import QSettings, QTimer
    from PySide6.QtWidgets import QMessageBox
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
    errors = []
    monkeypatch.setattr(QMessageBox, "critical", staticmethod(lambda parent, title, text, *args: errors.append(text)))
    settings = QSettings(str(tmp_path / "settings.ini"), QSettings.Format.IniFormat)
    missing = tmp_path / "missing.fmr"
    assert app.main([RIBBON, missing, other], settings=settings) == 0  # as a file manager opens several
    assert seen == [("other.fmr \u2014 FMR Editor", ["ribbon.xml", "other.fmr"])]
    assert len(errors) == 1 and "missing.fmr" in errors[0]  # said in the window, the others opened
    assert RecentFiles(settings).paths() == [other, RIBBON]
