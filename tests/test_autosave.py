"""Never lose work: autosaved copies, their discarding, and recovery after the editor is killed."""

from __future__ import annotations

import os
import select
import signal
import subprocess
import sys
import textwrap
import threading
from pathlib import Path

import pytest
from shapes import scattered_document

from fmr_editor.io import load_document
from fmr_editor.io.autosave import AutosaveFolder
from fmr_editor.model import edits

REPO = Path(__file__).resolve().parents[1]
RIBBON = REPO / "resources" / "samples" / "ribbon.xml"


def recolour(document, step: int):
    """Edit ``step`` of a session: curve 0's first left stop gets a colour of its own."""
    return edits.set_stop_color(document, document.curves[0].id, "left", 0, (step / 60, 0.5, 1 - step / 60))


# --- the folder -------------------------------------------------------------------------------------------


def test_a_copy_written_by_a_process_that_is_gone_is_an_orphan(tmp_path):
    folder = AutosaveFolder(tmp_path)
    document = scattered_document(64)
    key = folder.new_key()
    folder.write(key, document, tmp_path / "drawing.fmr")
    assert folder.orphans()[0].key == key  # this process counts as gone: it is the one starting up
    alive = subprocess.Popen([sys.executable, "-c", "import time; time.sleep(30)"])
    try:
        metadata = tmp_path / f"{key}.json"
        metadata.write_text(metadata.read_text().replace(f'"pid": {os.getpid()}', f'"pid": {alive.pid}'))
        assert folder.orphans() == []  # another editor still running owns it
    finally:
        alive.kill()
        alive.wait()
    [orphan] = folder.orphans()
    assert orphan.name == "drawing.fmr" and folder.load(orphan) == document
    folder.discard(key)
    assert folder.orphans() == [] and list(tmp_path.iterdir()) == []


def test_damaged_metadata_is_skipped(tmp_path):
    folder = AutosaveFolder(tmp_path)
    folder.write("good", scattered_document(64), None)
    (tmp_path / "bad.json").write_text("{not json")
    (tmp_path / "bad.fmr").write_bytes(b"PK")
    (tmp_path / "odd.json").write_text('{"path": 5, "written": "x", "pid": 1}')
    assert [entry.key for entry in folder.orphans()] == ["good"]


# --- the editor -------------------------------------------------------------------------------------------

gui = pytest.mark.gui


@pytest.fixture
def ribbon(editor):
    pytest.importorskip("pytestqt")
    editor.open(RIBBON)
    return editor


@gui
def test_every_50th_step_autosaves_and_saving_discards_the_copy(ribbon, tmp_path):
    window, history = ribbon.window, ribbon.history
    folder = window.autosaver.folder
    written = []
    window.autosaver.saved.connect(written.append)
    for step in range(49):
        history.apply(recolour(history.document, step), "Recolour")
    from PySide6.QtWidgets import QApplication

    window.autosaver.wait()
    QApplication.processEvents()  # a finished write's signal comes through the event loop
    assert written == []
    history.apply(recolour(history.document, 49), "Recolour")
    ribbon.qtbot.waitUntil(lambda: len(written) == 1, timeout=10_000)  # written on the autosave thread
    [key] = written
    assert AutosaveFolder(folder.folder).load(folder.orphans()[0]) == history.document
    ribbon.answers["save"] = tmp_path / "saved.fmr"
    window.save_as()
    # the first save of a fresh clone compiles the engine's kernels: an upper bound, not a pace
    ribbon.qtbot.waitUntil(lambda: window.job is None and not history.modified, timeout=180_000)
    assert not (folder.folder / f"{key}.fmr").exists()


@gui
def test_unsaved_changes_are_autosaved_after_a_while_and_closing_discards_them(ribbon):
    window, history = ribbon.window, ribbon.history
    window.autosaver.seconds = 0.2
    written, threads = [], []
    window.autosaver.saved.connect(written.append)
    folder, write = window.autosaver.folder, window.autosaver.folder.write
    folder.write = lambda *args: (threads.append(threading.current_thread()), write(*args))[1]
    history.apply(recolour(history.document, 1), "Recolour")
    ribbon.qtbot.waitUntil(lambda: len(written) == 1, timeout=10_000)
    assert threads and threading.main_thread() not in threads  # the window's thread never waits for the disk
    path = window.autosaver.folder.folder / f"{written[0]}.fmr"
    assert path.exists()
    from PySide6.QtWidgets import QMessageBox

    ribbon.answers["question"] = QMessageBox.StandardButton.Discard
    window.close_document()
    assert window.workspaces == [] and not path.exists()


DRIVER = textwrap.dedent("""
    import sys
    from PySide6.QtCore import QSettings, QTimer
    from PySide6.QtWidgets import QApplication
    from fmr_editor.model import edits
    from fmr_editor.ui import app
    from fmr_editor.ui.main_window import MainWindow

    def drive():
        windows = [w for w in QApplication.topLevelWidgets() if isinstance(w, MainWindow) and w.isVisible()]
        if not windows or windows[0].workspace is None or windows[0].job is not None:
            QTimer.singleShot(50, drive)
            return
        window = windows[0]
        window.autosaver.saved.connect(lambda key: print("autosaved", key, flush=True))
        history = window.workspace.history
        for step in range(50):
            document = history.document
            history.apply(edits.set_stop_color(document, document.curves[0].id, "left", 0,
                                               (step / 60, 0.5, 1 - step / 60)), "Recolour")

    application = QApplication(sys.argv[:1])  # the timer needs its event loop
    QTimer.singleShot(50, drive)
    app.main([sys.argv[1]], settings=QSettings(sys.argv[2], QSettings.Format.IniFormat))
""")


@gui
def test_after_a_kill_the_editor_offers_the_autosaved_document_and_restores_it_exactly(editor, tmp_path):
    environment = dict(os.environ, XDG_DATA_HOME=os.environ["XDG_DATA_HOME"], PYTHONPATH=str(REPO))
    killed = subprocess.Popen([sys.executable, "-c", DRIVER, str(RIBBON), str(tmp_path / "killed.ini")],
                              stdout=subprocess.PIPE, text=True, env=environment, cwd=tmp_path)
    try:
        ready, _, _ = select.select([killed.stdout], [], [], 300)  # the 50th step's autosave is written
        line = killed.stdout.readline() if ready else "no autosave within 300 s"
        assert line.startswith("autosaved"), line
    finally:
        killed.send_signal(signal.SIGKILL)
        killed.wait()
    expected = load_document(RIBBON)
    for step in range(50):
        expected = recolour(expected, step)

    window = editor.window
    assert window.offer_recovery()
    dialog = window.recovery
    assert dialog.list.count() == 1 and dialog.list.item(0).text().startswith("ribbon.xml")
    dialog.recover_button.click()
    editor.qtbot.waitUntil(lambda: window.job is None and window.workspace is not None, timeout=60_000)
    assert window.workspace.history.document == expected
    assert window.workspace.history.modified and window.workspace.path == RIBBON
    assert window.windowTitle().startswith("ribbon.xml*")
    assert window.history_panel.list.item(0).text() == "Recovered ribbon.xml"  # not "Open": where it came from
    # the copy stays (rewritten by later autosaves) until the recovered document is saved or closed
    assert window.autosaver.folder.orphans()[0].key == line.split()[1]
