"""The window's file commands: new, open, save, save as, export, recent files, drops and closing.

``FileCommands`` is mixed into ``MainWindow``; it uses the window's tabs
(``_open_tab``), its job runner (``_start``) and the ``workspace`` shown.
Each document opens in a tab of its own on a job; saving and exporting wait
until the engine has caught up with the document
(``Workspace.when_current``) and then read that frame's representation on
a job thread while that document is paused.
"""

from __future__ import annotations

import os
from collections.abc import Callable
from pathlib import Path

from PySide6.QtCore import QTimer

from ..io import DocumentLoadError, save_fmr
from .autosave import RecoveryDialog
from .export import ExportDialog, ExportOptions, export_picture
from .files import IMPORT_SVG_FILTER, NewDocumentDialog, ask_open_path, ask_save_path, openable, show_error
from .workspace import DEFAULT_SIZE, new_document, open_file, recover


def _reason(error: BaseException):
    """What to tell the user about ``error`` (an OSError's own words when it has them)."""
    return error.strerror if isinstance(error, OSError) and error.strerror else error


class FileCommands:
    """File menu commands, drag and drop, and the question before unsaved changes are lost."""

    def _folder(self) -> str:
        workspace = self.workspace
        if workspace is not None and workspace.path is not None:
            return str(workspace.path.parent)
        recent = self.recent.paths()
        return str(recent[0].parent) if recent else os.getcwd()

    # -- file commands ------------------------------------------------------------------------------------
    def new_document(self, size: tuple[int, int] | None = None) -> None:
        """A new, empty document in a tab of its own; asks for the canvas size unless ``size`` is given."""
        chosen = size or NewDocumentDialog.get_size(self, *DEFAULT_SIZE)
        if chosen is None:
            return
        width, height = chosen
        self._open_tab("Untitled", None, "New document", lambda progress: new_document(width, height, progress),
                       None, lambda error: show_error(self, "Cannot Create the Document", str(error)))

    def open_document(self) -> None:
        """Ask for a document and open it."""
        path = ask_open_path(self, self._folder())
        if path is not None:
            self.open_path(path)

    def import_svg(self) -> None:
        """Ask for an SVG file and open its paths and shapes as a new document's curves (``io.load_svg``)."""
        path = ask_open_path(self, self._folder(), "Import SVG", IMPORT_SVG_FILTER)
        if path is not None:
            self.open_path(path)

    def open_path(self, path: str | os.PathLike, then: Callable[[], None] | None = None) -> None:
        """Open ``path`` in a tab of its own (its tab, if it is open or opening already), then ``then()``; a
        failure changes nothing (with nothing open and nothing to follow, a new canvas opens instead)."""
        path = Path(path)
        tab = self.documents.find(path.resolve())
        if tab is not None:
            self._activate(tab)
            if then is not None:
                then()
            return

        def failed(error: BaseException) -> None:
            message = str(error) if isinstance(error, DocumentLoadError) else f"{path.name}: {error}"
            if not path.exists():
                self.recent.remove(path)
            show_error(self, "Cannot Open the Document", message)
            if then is None and not self.open_tabs:  # nothing open (started on this file): a blank canvas instead
                self.new_document(DEFAULT_SIZE)

        self._open_tab(path.name, path.resolve(), f"Opening {path.name}", lambda progress: open_file(path, progress),
                       then, failed)

    def offer_recovery(self) -> bool:
        """Offer the documents a crash left autosaved (``RecoveryDialog``, not blocking); False when there are none."""
        entries = self.autosaver.folder.orphans()
        if not entries:
            return False
        self.recovery = RecoveryDialog(entries, self)
        self.recovery.finished.connect(lambda _, dialog=self.recovery: self._recovery_chosen(dialog))
        self.recovery.open()
        return True

    def _recovery_chosen(self, dialog: RecoveryDialog) -> None:
        self.recovery = None
        if dialog.choice == "discard":
            for entry in dialog.checked():
                self.autosaver.folder.discard(entry.key)
        elif dialog.choice == "recover":
            self._recover(dialog.checked())

    def _recover(self, entries: list) -> None:
        """Open each autosaved entry in a tab of its own, one after the other, with its changes unsaved."""
        if not entries:
            return
        entry, rest = entries[0], entries[1:]
        folder = self.autosaver.folder
        self._open_tab(entry.name, entry.path, f"Recovering {entry.name}",
                       lambda progress: recover(folder, entry, progress), lambda: self._recover(rest),
                       lambda error: show_error(self, "Cannot Recover the Document", f"{entry.name}: {error}"))

    def open_paths(self, paths: list) -> None:
        """Open each of ``paths`` in a tab, one after the other (a new canvas when none opens)."""
        if paths:
            rest = list(paths[1:])
            self.open_path(paths[0], (lambda: self.open_paths(rest)) if rest else None)

    def save(self, then: Callable[[], None] | None = None) -> None:
        """Save to the document's ``.fmr`` file (Save As for a new or imported one)."""
        workspace = self.workspace
        if workspace is None or self.busy:
            return
        if workspace.native:
            self.save_to(workspace.path, then)
        else:
            self.save_as(then)

    def save_as(self, then: Callable[[], None] | None = None) -> None:
        """Ask for a ``.fmr`` file and save there."""
        workspace = self.workspace
        if workspace is None or self.busy:
            return
        if workspace.path is not None:
            suggested = workspace.path.with_suffix(".fmr")
        else:
            suggested = Path(self._folder()) / "Untitled.fmr"
        path = ask_save_path(self, suggested)
        if path is not None:
            self.save_to(path, then)

    def save_to(self, path: str | os.PathLike, then: Callable[[], None] | None = None) -> None:
        """Save the document with its representation to ``path`` (atomically), then ``then()``."""
        workspace = self.workspace
        if workspace is None or self.busy:
            return
        path = Path(path).resolve()
        if self.tool is not None:
            self.tool.finish()
        document, step = workspace.history.document, workspace.history.index
        self._begin(workspace, f"Saving {path.name}")  # nothing edits it until the job is done

        def saved(written: Path) -> None:
            history = workspace.history
            workspace.path = Path(written)
            if history.index == step and history.document is document:
                history.mark_saved()
            self._steps_of(workspace)
            self.recent.add(written)
            self.status_label.setText(f"Saved {Path(written).name}")
            if then is not None:
                then()

        def failed(error: BaseException) -> None:
            show_error(self, "Cannot Save the Document", f"{path.name}: {_reason(error)}")

        def start(frame) -> None:
            picture = frame.picture if frame is not None and frame.document is document else None
            settings = workspace.settings if picture is not None else None
            self._start(workspace, f"Saving {path.name}",
                        lambda progress: save_fmr(path, document, picture, settings=settings), saved, failed)

        workspace.when_current(start)

    def export_png(self, options: ExportOptions | None = None) -> None:
        """Export the image to PNG (asks for file, size and antialiasing unless ``options`` are given)."""
        self._export(".png", options)

    def export_svg(self, options: ExportOptions | None = None) -> None:
        """Export the image to SVG, the picture embedded and every curve kept as a hidden path (asks as
        ``export_png`` does)."""
        self._export(".svg", options)

    def _export(self, suffix: str, options: ExportOptions | None) -> None:
        workspace = self.workspace
        if workspace is None or self.busy:
            return
        document = workspace.history.document
        if options is None:
            stem = workspace.path.stem if workspace.path is not None else "Untitled"
            options = ExportDialog.get_options((document.width, document.height),
                                               Path(self._folder()) / f"{stem}{suffix}", self)
            if options is None:
                return
        if self.tool is not None:
            self.tool.finish()
            document = workspace.history.document
        self._begin(workspace, f"Exporting {options.path.name}")

        def done(written: Path) -> None:
            self.status_label.setText(f"Exported {Path(written).name} ({options.width}x{options.height})")

        def failed(error: BaseException) -> None:
            show_error(self, "Cannot Export", f"{options.path.name}: {_reason(error)}")

        def start(frame) -> None:
            picture = frame.picture if frame is not None and frame.document is document else None
            self._start(workspace, f"Exporting {options.path.name}",
                        lambda progress: export_picture(options, document, picture, workspace.settings, progress),
                        done, failed)

        workspace.when_current(start)

    def _fill_recent_menu(self) -> None:
        menu = self.recent_menu
        menu.clear()
        paths = self.recent.paths()
        for k, path in enumerate(paths, 1):
            action = menu.addAction(f"&{k % 10} {path.name}  \u2014  {path.parent}")
            action.triggered.connect(lambda _=False, path=path: self.open_path(path))
        if paths:
            menu.addSeparator()
        clear = menu.addAction("Clear Recent Files")
        clear.setEnabled(bool(paths))
        clear.triggered.connect(self.recent.clear)

    # -- drag and drop, closing ---------------------------------------------------------------------------
    @staticmethod
    def _dropped(event) -> list[Path]:
        mime = event.mimeData()
        if not mime.hasUrls():
            return []
        return [Path(url.toLocalFile()) for url in mime.urls() if url.isLocalFile() and openable(url.toLocalFile())]

    def dragEnterEvent(self, event) -> None:
        if self._dropped(event):
            event.acceptProposedAction()
        else:
            event.ignore()

    def dragMoveEvent(self, event) -> None:
        self.dragEnterEvent(event)

    def dropEvent(self, event) -> None:
        paths = self._dropped(event)
        if not paths:
            event.ignore()
            return
        event.acceptProposedAction()
        QTimer.singleShot(0, lambda: self.open_paths(paths))  # not inside the drop: opening may show a message

    def closeEvent(self, event) -> None:
        busy = [tab.task.title for tab in self.open_tabs if tab.task is not None]
        if not self._close_now and busy:
            event.ignore()  # a job is writing or reading: close when asked again after it
            self.status_label.setText(f"Wait for {busy[0]} to finish, or cancel it, before closing.")
            return
        if not self._close_now and any(workspace.history.modified for workspace in self.workspaces):
            event.ignore()  # asks about each document; closes when none is left unsettled
            self._settle_all(self._close_after_save)
            return
        self.settings.setValue("window/geometry", self.saveGeometry())
        self.settings.setValue("window/state", self.saveState())
        for workspace in list(self.workspaces):
            self._drop(workspace, show_next=False)
        event.accept()

    def _close_after_save(self) -> None:
        self._close_now = True
        QTimer.singleShot(0, self.close)
