"""Never lose work: each open document with unsaved changes is autosaved, and offered back after a crash.

A document is autosaved ``seconds`` after its first unsaved change and after
every ``steps``-th step (edits, undos, redos) since its last autosave; its
copy is discarded when it is saved, undone back to its saved state or closed
normally.  Copies are written on a thread of their own (roses took 250 ms, a
hitch in a stroke; documents never change, so the thread reads a snapshot);
a discard waits for the writes before it.  On start the window asks
``RecoveryDialog`` about the copies a crashed editor left (``io.autosave``).
"""

from __future__ import annotations

import time
from concurrent.futures import Future, ThreadPoolExecutor
from dataclasses import dataclass
from pathlib import Path

from PySide6.QtCore import QObject, QStandardPaths, Qt, QTimer, Signal
from PySide6.QtWidgets import QDialog, QDialogButtonBox, QLabel, QListWidget, QListWidgetItem, QVBoxLayout

from ..io.autosave import Autosaved, AutosaveFolder

#: Seconds of unsaved changes before a document is autosaved.
AUTOSAVE_SECONDS = 60.0
#: Steps since the last autosave after which a document is autosaved at once.
AUTOSAVE_STEPS = 50


def default_folder() -> Path:
    """``fmr-editor/autosave`` in the platform's application-data folder (``$XDG_DATA_HOME`` on Linux)."""
    return Path(QStandardPaths.writableLocation(QStandardPaths.StandardLocation.GenericDataLocation)) / \
        "fmr-editor" / "autosave"


@dataclass
class _Watched:
    """A watched document's autosave key, steps since its last autosave and when its unsaved changes began."""

    key: str
    steps: int = 0
    since: float | None = None


class Autosaver(QObject):
    """Autosaves the workspaces it watches.

    Parameters
    ----------
    folder : AutosaveFolder
    seconds : float
    steps : int
    parent : QObject, optional

    Signals
    -------
    failed(str)
        An autosave could not be written (said once until one succeeds).
    saved(str)
        The key of an entry just written.
    """

    failed = Signal(str)
    saved = Signal(str)
    _written = Signal(object, str, object)  # (workspace, key, error or None), from the writing thread

    def __init__(self, folder: AutosaveFolder, seconds: float = AUTOSAVE_SECONDS, steps: int = AUTOSAVE_STEPS,
                 parent: QObject | None = None) -> None:
        super().__init__(parent)
        self.folder, self.seconds, self.steps = folder, seconds, steps
        self._watched: dict = {}  # workspace -> _Watched
        self._failing = False
        self._writer = ThreadPoolExecutor(1, thread_name_prefix="autosave")
        self._pending: list[Future] = []
        self._written.connect(self._finish, Qt.ConnectionType.QueuedConnection)
        self._timer = QTimer(self)
        self._timer.timeout.connect(self._tick)
        self.set_seconds(seconds)
        self._timer.start()

    def set_seconds(self, seconds: float) -> None:
        """Autosave ``seconds`` after a document's first unsaved change from now on."""
        self.seconds = seconds
        self._timer.setInterval(int(min(1000.0, self.seconds * 250)))

    def watch(self, workspace, key: str | None = None) -> None:
        """Autosave ``workspace`` from now on, under ``key`` (a recovered entry's) or a new one."""
        self._watched[workspace] = _Watched(key or self.folder.new_key())
        workspace.steps_changed.connect(lambda w=workspace: self._stepped(w))
        if workspace.history.modified:
            self._stepped(workspace)

    def forget(self, workspace) -> None:
        """Stop watching ``workspace`` (closed normally) and discard its copy."""
        state = self._watched.pop(workspace, None)
        if state is not None:
            self._discard(state.key)

    def _discard(self, key: str) -> None:
        """Discard ``key``'s copy once the writes under way are done (one of them may be of it)."""
        self.wait()
        self.folder.discard(key)

    def wait(self) -> None:
        """Return once every autosave asked for so far is written (or failed)."""
        for future in self._pending:
            future.exception()
        self._pending.clear()

    def _stepped(self, workspace) -> None:
        state = self._watched.get(workspace)
        if state is None:
            return
        if not workspace.history.modified:  # saved, or back at the saved step
            self._discard(state.key)
            state.steps, state.since = 0, None
            return
        state.steps += 1
        state.since = state.since if state.since is not None else time.monotonic()
        if state.steps >= self.steps:
            self.write(workspace)

    def _tick(self) -> None:
        now = time.monotonic()
        for workspace, state in list(self._watched.items()):
            if state.since is not None and now - state.since >= self.seconds:
                self.write(workspace)

    def write(self, workspace) -> None:
        """Autosave ``workspace`` now, on the writing thread (after its drag, if one is going on); ``saved`` or
        ``failed`` says when it is done."""
        state = self._watched.get(workspace)
        if state is None or workspace.history.in_transaction:
            return
        state.steps, state.since = 0, None
        document, path, key = workspace.history.document, workspace.path, state.key

        def work() -> None:
            try:
                self.folder.write(key, document, path)
            except (OSError, ValueError) as error:
                self._written.emit(workspace, key, error)
                return
            self._written.emit(workspace, key, None)

        self._pending = [future for future in self._pending if not future.done()]
        self._pending.append(self._writer.submit(work))

    def _finish(self, workspace, key: str, error: Exception | None) -> None:
        """A write is done (on the window's thread)."""
        if error is None:
            self._failing = False
            self.saved.emit(key)
            return
        if not self._failing:
            self.failed.emit(f"Cannot autosave {workspace.name}: {getattr(error, 'strerror', None) or error}")
        self._failing = True
        state = self._watched.get(workspace)
        if state is not None and state.since is None:
            state.since = time.monotonic()  # try again a while later


class RecoveryDialog(QDialog):
    """Lists the documents a crash left autosaved, each checked; Recover opens the checked ones, Discard
    deletes them, Later keeps every copy for the next start.

    Parameters
    ----------
    entries : list of Autosaved
    parent : QWidget, optional

    Attributes
    ----------
    choice : str
        ``"recover"``, ``"discard"`` or ``"later"`` once the dialog is closed.
    """

    def __init__(self, entries: list[Autosaved], parent=None) -> None:
        super().__init__(parent)
        self.setWindowTitle("Recover Documents")
        self.entries, self.choice = entries, "later"
        layout = QVBoxLayout(self)
        layout.addWidget(QLabel("The editor did not close normally last time. These documents were autosaved:"))
        self.list = QListWidget()
        for entry in entries:
            written = time.strftime("%Y-%m-%d %H:%M:%S", time.localtime(entry.written))
            item = QListWidgetItem(f"{entry.name}  (autosaved {written})")
            item.setToolTip(str(entry.path) if entry.path is not None else "never saved")
            item.setFlags(item.flags() | Qt.ItemFlag.ItemIsUserCheckable)
            item.setCheckState(Qt.CheckState.Checked)
            self.list.addItem(item)
        layout.addWidget(self.list)
        buttons = QDialogButtonBox()
        self.recover_button = buttons.addButton("&Recover", QDialogButtonBox.ButtonRole.AcceptRole)
        self.discard_button = buttons.addButton("&Discard", QDialogButtonBox.ButtonRole.DestructiveRole)
        self.later_button = buttons.addButton("&Later", QDialogButtonBox.ButtonRole.RejectRole)
        self.recover_button.clicked.connect(lambda: self._close_with("recover"))
        self.discard_button.clicked.connect(lambda: self._close_with("discard"))
        self.later_button.clicked.connect(lambda: self._close_with("later"))
        layout.addWidget(buttons)

    def checked(self) -> list[Autosaved]:
        """The entries left checked."""
        return [entry for row, entry in enumerate(self.entries)
                if self.list.item(row).checkState() == Qt.CheckState.Checked]

    def _close_with(self, choice: str) -> None:
        self.choice = choice
        self.accept() if choice != "later" else self.reject()
