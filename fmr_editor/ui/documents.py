"""The window's open documents: one tab each, with its own history, engine, unsaved state and job.

``DocumentCommands`` is mixed into ``MainWindow``.  Every open document is a
``Workspace``; a document still being read and built is an ``Opening`` in a
tab of its own until its job ends.  The window's ``tabs.Tabs`` keeps their
order and the one in front; its ``shown_changed`` points the canvas, the
panels, the tools and the menus at that one (``_show``).
Each workspace keeps its own view (pan and zoom) and its engine thread; a
frame of a document in the background only updates that document's
``frame``, shown when its tab is chosen.  A job (opening, saving, exporting)
belongs to one tab: only that document waits for it.  Closing a tab or the
window asks about each document with unsaved changes.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from PySide6.QtWidgets import QTabBar, QVBoxLayout, QWidget

from .files import ask_keep_changes
from .jobs import Task
from .tabs import Tabs
from .workspace import Opened, Workspace


@dataclass(eq=False)
class Opening:
    """A tab whose document is still being read and built.

    Attributes
    ----------
    name : str
        The tab's name (the file's, or "Untitled").
    path : pathlib.Path or None
        The file being opened.
    task : Task
        The job opening it.
    came_from : Workspace or Opening or None
        The tab shown when it was asked for (shown again if it fails or is cancelled).
    """

    name: str
    path: Path | None
    task: Task
    came_from: object = None


class DocumentCommands:
    """Opening, showing and closing documents for ``MainWindow``, over its ``Tabs`` (``documents``).

    Needs the window's canvas, panels, tools, job runner (``_start``) and status bar.
    """

    documents: Tabs

    def _build_tabs(self) -> QWidget:
        """The tabs (``documents``) and the bar over the canvas, in one widget for the window's centre."""
        self.documents = Tabs(self)
        self.documents.shown_changed.connect(self._show)
        self.documents.close_requested.connect(self.close_document)
        centre = QWidget()
        layout = QVBoxLayout(centre)
        layout.setContentsMargins(0, 0, 0, 0)
        layout.setSpacing(0)
        layout.addWidget(self.documents.bar)
        layout.addWidget(self.canvas, 1)
        return centre

    @property
    def tabs(self) -> QTabBar:
        return self.documents.bar

    @property
    def open_tabs(self) -> list[Workspace | Opening]:
        """Every tab, documents still opening included, in order."""
        return self.documents.open_tabs

    @property
    def shown(self) -> Workspace | Opening | None:
        """The tab in front."""
        return self.documents.shown

    @property
    def workspaces(self) -> list[Workspace]:
        """The open documents (tabs still opening left out), in the order of their tabs."""
        return self.documents.workspaces

    # -- opening and choosing ---------------------------------------------------------------------
    def _open_tab(self, name: str, path: Path | None, title: str, work, then: Callable[[], None] | None,
                  failed: Callable[[BaseException], None]) -> None:
        """A tab for a document that ``work(progress) -> Opened`` reads and builds on a job: it shows the job's
        progress, and becomes the document (``_install``) when the job ends; a failure (``failed(error)``) or a
        cancel closes it.  ``then()`` follows either way, unless cancelled."""
        opening = Opening(name, path, Task(title), came_from=self.shown)
        self._add_tab(opening)
        if self.show_blur:
            work = (lambda progress, read=work: read(progress).blurred(progress))

        def succeeded(opened: Opened) -> None:
            self._install(opened, opening)
            if then is not None:
                then()

        def refused(error: BaseException) -> None:
            self._drop(opening)
            failed(error)
            if then is not None:
                then()

        def cancelled() -> None:
            self._drop(opening)
            self.status_label.setText(f"Cancelled: {title}")

        self._start(opening, title, work, succeeded, refused, cancelled)

    def _add_tab(self, tab: Workspace | Opening) -> None:
        self.documents.add(tab, tab.name)
        self._name_tab(tab)
        self.documents.show(tab)

    def _install(self, opened: Opened, opening: Opening) -> None:
        """Make ``opening``'s tab the document ``opened``, shown if its tab is.

        A new untitled document nobody has edited, shown when the file was
        asked for, is closed, as editors do with the blank canvas they start on.
        """
        workspace = Workspace(opened, self.options, self._choose_stop_color, self)
        workspace.set_undo_memory(self.preferences.undo_memory)
        workspace.document_changed.connect(lambda w=workspace: self._if_shown(w, self._document_changed))
        workspace.steps_changed.connect(lambda w=workspace: self._steps_of(w))
        workspace.frame_ready.connect(lambda frame, w=workspace: self._if_shown(w, self._frame_ready, frame))
        workspace.engine_failed.connect(lambda text, w=workspace: self._if_shown(w, self._engine_failed, text))
        workspace.engine_progress.connect(lambda *a, w=workspace: self._if_shown(w, self._engine_progress, *a))
        workspace.message.connect(lambda text, w=workspace: self._if_shown(w, self.status_label.setText, text))
        self.documents.replace(opening, workspace)  # shown at once if its tab is in front
        self._name_tab(workspace)
        self.autosaver.watch(workspace, opened.recovered)
        if workspace.path is not None:
            self.recent.add(workspace.path)
        blank = opening.came_from
        if (isinstance(blank, Workspace) and blank in self.open_tabs and blank.path is None and blank.task is None
                and blank.history.index == 0 and not blank.history.modified):
            self._drop(blank)
        if opened.notes and self.shown is workspace:
            self.status_label.setText(f"{workspace.name}: " + "; ".join(opened.notes))

    def _if_shown(self, tab: Workspace, slot: Callable, *args) -> None:
        if tab is self.shown:
            slot(*args)

    def _activate(self, tab: Workspace | Opening) -> None:
        """Bring ``tab`` to the front (which shows it)."""
        self.documents.show(tab)

    def next_document(self, step: int = 1) -> None:
        """Show the next tab (Ctrl+Tab), or with ``step`` -1 the previous one."""
        self.documents.step(step)

    def previous_document(self) -> None:
        self.next_document(-1)

    def _show(self, tab: Workspace | Opening | None) -> None:
        """Point the canvas, the panels and the tools at ``tab``, now in front (``Tabs.shown_changed``; None:
        nothing open; an ``Opening``: nothing to edit yet, its progress in the status bar)."""
        old = self.workspace
        if old is not None and old is not tab:
            old.tools[self.tool_name].finish()
            old.view = (self.canvas.view, self.canvas.fitted)
        self.workspace = workspace = tab if isinstance(tab, Workspace) else None
        if workspace is None:
            self.canvas.set_representation(None)
            self.history_panel.bind(None, "")
            self.layers_panel.bind(None)
            self.stops_panel.bind(None)
        else:
            view, fitted = workspace.view
            self.canvas.set_representation(workspace.frame.picture, fit=fitted)
            if not fitted:
                self.canvas.set_view(view)
            workspace.context.zoom = self.canvas.view.scale
            first = (f"Recovered {workspace.name}" if workspace.recovered else f"Open {workspace.name}"
                     if workspace.path is not None else "New Document")
            self.history_panel.bind(workspace.history, first)
            self.layers_panel.bind(workspace.history)
            self.stops_panel.bind(workspace.context)
            self._document_changed()
            self._frame_ready(workspace.frame)
        self.zoom_button.setVisible(workspace is not None)  # nothing to zoom while a tab is still opening
        self.status_label.setText(self._standing_status())  # what was said was about the document shown before
        self.position_label.setText("")  # and the pointer's position was over it
        self._show_task()
        if workspace is not None and workspace.failure is not None:
            self._engine_failed(workspace.failure)
        self.set_tool(self.tool_name)
        self.update_state()
        self.canvas.setFocus()

    # -- names --------------------------------------------------------------------------------------
    def _steps_of(self, workspace: Workspace) -> None:
        """A workspace's steps or saved mark changed: its tab's name, and the window if it is shown."""
        self._name_tab(workspace)
        if workspace is self.shown:
            self.status_label.expire(self._standing_status())
            self.update_state()

    def _name_tab(self, tab: Workspace | Opening) -> None:
        """The file name on ``tab``, with ``*`` while it has unsaved changes, or how far its opening got."""
        if isinstance(tab, Opening):
            self.documents.name(tab, f"{tab.name} ({tab.task.fraction:.0%})", tab.task.title)
        else:
            self.documents.name(tab, tab.name + ("*" if tab.history.modified else ""),
                                str(tab.path) if tab.path is not None else "not saved yet")

    # -- closing ------------------------------------------------------------------------------------
    def close_document(self, tab: Workspace | Opening | None = None) -> None:
        """Close ``tab`` (default: the one shown), asking first about unsaved changes (Ctrl+W); a tab still
        opening is cancelled, a document being saved or exported closes once that is done.

        A tab in the background is brought forward only for the question;
        the document worked on stays in front.
        """
        tab, shown = tab or self.shown, self.shown
        if tab is None:
            return
        if tab.task is not None:
            if isinstance(tab, Opening):
                self._cancel(tab)
            else:
                self.status_label.setText(f"{tab.name} closes once it is done: {tab.task.title}")
            return

        def close() -> None:
            self._drop(tab)
            if shown is not tab and shown in self.open_tabs:
                self._activate(shown)

        if tab.history.modified:
            self._activate(tab)
            self._settle_changes(close)
        else:
            close()

    def _drop(self, tab: Workspace | Opening, show_next: bool = True) -> None:
        """Close ``tab`` now: its tools and engine thread; if it was shown, the one it was opened from is shown
        (an ``Opening``'s), else the next (unless not ``show_next``: the window is closing)."""
        if isinstance(tab, Workspace):
            tab.tools[self.tool_name].cancel()
            tab.close()
            self.autosaver.forget(tab)
        if tab is self.workspace:
            self.workspace = None  # nothing to keep of it: the next one is shown without finishing its tools
        back = tab.came_from if isinstance(tab, Opening) and tab.came_from in self.open_tabs else None
        self.documents.remove(tab, back, show_next)
        if isinstance(tab, Workspace):
            tab.deleteLater()

    def _settle_all(self, proceed: Callable[[], None], asked: tuple = ()) -> None:
        """Run ``proceed`` once every document's unsaved changes are saved or may be dropped (asks per
        document; Cancel stops there, No to All drops the changes of every one left)."""
        waiting = [w for w in self.workspaces if w.history.modified and w not in asked]
        if not waiting:
            proceed()
            return
        self._activate(waiting[0])
        others = (len(waiting) - 1, proceed) if len(waiting) > 1 else None
        self._settle_changes(lambda: self._settle_all(proceed, asked + (waiting[0],)), others)

    def _settle_changes(self, proceed: Callable[[], None],
                        others: tuple[int, Callable[[], None]] | None = None) -> None:
        """Run ``proceed`` once the shown document's unsaved changes are saved or may be dropped (asks); with
        ``others``, ``(count, proceed_all)`` of the documents waiting after it, No to All runs ``proceed_all``."""
        workspace = self.workspace
        if workspace is None or not workspace.history.modified:
            proceed()
            return
        answer = ask_keep_changes(self, workspace.name, others[0] if others else 0)
        if answer == "discard all":
            others[1]()
        elif answer == "discard":
            proceed()
        elif answer == "save":
            self.save(then=proceed)
