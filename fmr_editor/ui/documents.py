"""The window's open documents: one tab each, with its own history, engine, unsaved state and job.

``DocumentTabs`` is mixed into ``MainWindow``.  Every open document is a
``Workspace``; a document still being read and built is an ``Opening`` in a
tab of its own until its job ends.  The tab bar above the canvas chooses the
one shown, which the canvas, the panels, the tools and the menus act on.
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


class DocumentTabs:
    """Tabs of open documents for ``MainWindow`` (needs its canvas, panels, tool and job runner).

    Attributes
    ----------
    open_tabs : list of Workspace or Opening
        Every tab, in order.
    shown : Workspace or Opening or None
        The tab in front; ``workspace`` is it when it is a ``Workspace``.
    """

    open_tabs: list[Workspace | Opening]
    shown: Workspace | Opening | None

    def _build_tabs(self) -> QWidget:
        """The tab bar over the canvas, in one widget for the window's centre."""
        self.open_tabs, self.shown = [], None
        self.tabs = QTabBar()
        self.tabs.setDocumentMode(True)
        self.tabs.setTabsClosable(True)
        self.tabs.setMovable(True)
        self.tabs.setExpanding(False)
        self.tabs.currentChanged.connect(self._tab_chosen)
        self.tabs.tabCloseRequested.connect(lambda index: self.close_document(self.open_tabs[index]))
        self.tabs.tabMoved.connect(self._tab_moved)
        self.tabs.hide()
        centre = QWidget()
        layout = QVBoxLayout(centre)
        layout.setContentsMargins(0, 0, 0, 0)
        layout.setSpacing(0)
        layout.addWidget(self.tabs)
        layout.addWidget(self.canvas, 1)
        return centre

    @property
    def workspaces(self) -> list[Workspace]:
        """The open documents (tabs still opening left out), in the order of their tabs."""
        return [tab for tab in self.open_tabs if isinstance(tab, Workspace)]

    # -- opening and choosing ---------------------------------------------------------------------
    def _open_tab(self, name: str, path: Path | None, title: str, work, then: Callable[[], None] | None,
                  failed: Callable[[BaseException], None]) -> None:
        """A tab for a document that ``work(progress) -> Opened`` reads and builds on a job: it shows the job's
        progress, and becomes the document (``_install``) when the job ends; a failure (``failed(error)``) or a
        cancel closes it.  ``then()`` follows either way, unless cancelled."""
        opening = Opening(name, path, Task(title), came_from=self.shown)
        self._add_tab(opening)

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
        self.open_tabs.append(tab)
        self.tabs.blockSignals(True)  # shown once, by _activate
        self.tabs.addTab(tab.name)
        self.tabs.blockSignals(False)
        self._name_tab(tab)
        self._activate(tab)

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
        self.open_tabs[self.open_tabs.index(opening)] = workspace
        self._name_tab(workspace)
        self.autosaver.watch(workspace, opened.recovered)
        if workspace.path is not None:
            self.recent.add(workspace.path)
        if self.shown is opening:
            self._show(workspace)
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
        """Make ``tab`` current (which shows it)."""
        index = self.open_tabs.index(tab)
        if self.tabs.currentIndex() != index:
            self.tabs.setCurrentIndex(index)
        else:
            self._show(tab)

    def _tab_chosen(self, index: int) -> None:
        if 0 <= index < len(self.open_tabs) and self.open_tabs[index] is not self.shown:
            self._show(self.open_tabs[index])

    def next_document(self, step: int = 1) -> None:
        """Show the next tab (Ctrl+Tab), or with ``step`` -1 the previous one."""
        if len(self.open_tabs) > 1:
            self.tabs.setCurrentIndex((self.tabs.currentIndex() + step) % len(self.open_tabs))

    def previous_document(self) -> None:
        self.next_document(-1)

    def _tab_moved(self, source: int, target: int) -> None:
        self.open_tabs.insert(target, self.open_tabs.pop(source))

    def _show(self, tab: Workspace | Opening | None) -> None:
        """Point the canvas, the panels and the tools at ``tab`` (None: nothing open; an ``Opening``: nothing to
        edit yet, its progress in the status bar)."""
        old = self.workspace
        if old is not None and old is not tab:
            old.tools[self.tool_name].finish()
            old.view = (self.canvas.view, self.canvas.fitted)
        self.shown = tab
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
            first = f"Open {workspace.name}" if workspace.path is not None else "New Document"
            self.history_panel.bind(workspace.history, first)
            self.layers_panel.bind(workspace.history)
            self.stops_panel.bind(workspace.context)
            self._document_changed()
            self._frame_ready(workspace.frame)
        self.tabs.setVisible(len(self.open_tabs) > 1)
        self.zoom_button.setVisible(workspace is not None)  # nothing to zoom while a tab is still opening
        self.status_label.setText("")  # what was said was about the document shown before
        self._show_task()
        if workspace is not None and workspace.failure is not None:
            self._engine_failed(workspace.failure)
        self.set_tool(self.tool_name)
        self._update_state()
        self.canvas.setFocus()
        if workspace is not None and self.canvas.error:  # no suitable OpenGL: editing works, nothing is shown
            self.status_label.setText(f"The canvas cannot draw the image: {self.canvas.error}")

    # -- names --------------------------------------------------------------------------------------
    def _steps_of(self, workspace: Workspace) -> None:
        """A workspace's steps or saved mark changed: its tab's name, and the window if it is shown."""
        self._name_tab(workspace)
        if workspace is self.shown:
            self._update_state()

    def _name_tab(self, tab: Workspace | Opening) -> None:
        """The file name on ``tab``, with ``*`` while it has unsaved changes, or how far its opening got."""
        index = self.open_tabs.index(tab)
        if isinstance(tab, Opening):
            self.tabs.setTabText(index, f"{tab.name} ({tab.task.fraction:.0%})")
            self.tabs.setTabToolTip(index, tab.task.title)
            return
        self.tabs.setTabText(index, tab.name + ("*" if tab.history.modified else ""))
        self.tabs.setTabToolTip(index, str(tab.path) if tab.path is not None else "not saved yet")

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
        index = self.open_tabs.index(tab)
        if isinstance(tab, Workspace):
            tab.tools[self.tool_name].cancel()
            tab.close()
            self.autosaver.forget(tab)
        self.open_tabs.pop(index)
        self.tabs.blockSignals(True)
        self.tabs.removeTab(index)
        self.tabs.blockSignals(False)
        if tab is self.shown:
            self.shown = self.workspace = None  # nothing to keep of it: the next one is shown without finishing
            following = self.open_tabs[min(index, len(self.open_tabs) - 1)] if self.open_tabs else None
            if isinstance(tab, Opening) and tab.came_from in self.open_tabs:
                following = tab.came_from
            if following is not None and show_next:
                self._activate(following)
            else:
                self._show(None)
        self.tabs.setVisible(len(self.open_tabs) > 1)
        if isinstance(tab, Workspace):
            tab.deleteLater()

    def _settle_all(self, proceed: Callable[[], None], asked: tuple = ()) -> None:
        """Run ``proceed`` once every document's unsaved changes are saved or may be dropped (asks per
        document; Cancel stops there)."""
        waiting = [w for w in self.workspaces if w.history.modified and w not in asked]
        if not waiting:
            proceed()
            return
        self._activate(waiting[0])
        self._settle_changes(lambda: self._settle_all(proceed, asked + (waiting[0],)))

    def _settle_changes(self, proceed: Callable[[], None]) -> None:
        """Run ``proceed`` once the shown document's unsaved changes are saved or may be dropped (asks)."""
        workspace = self.workspace
        if workspace is None or not workspace.history.modified:
            proceed()
            return
        answer = ask_keep_changes(self, workspace.name)
        if answer == "discard":
            proceed()
        elif answer == "save":
            self.save(then=proceed)
