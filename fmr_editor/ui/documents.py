"""The window's open documents: one tab each, with its own history, engine and unsaved state.

``DocumentTabs`` is mixed into ``MainWindow``.  Every open document is a
``Workspace``; the tab bar above the canvas chooses the active one, which
the canvas, the panels, the tools and the menus act on.  Each workspace
keeps its own view (pan and zoom) and its engine thread; a frame of a
document in the background only updates that document's ``frame``, shown
when its tab is chosen.  Closing a tab or the window asks about each
document with unsaved changes.
"""

from __future__ import annotations

from collections.abc import Callable

from PySide6.QtWidgets import QTabBar, QVBoxLayout, QWidget

from .files import ask_keep_changes
from .workspace import Opened, Workspace


class DocumentTabs:
    """Tabs of open documents for ``MainWindow`` (needs its canvas, panels, tool and job state)."""

    workspaces: list[Workspace]

    def _build_tabs(self) -> QWidget:
        """The tab bar over the canvas, in one widget for the window's centre."""
        self.workspaces = []
        self.tabs = QTabBar()
        self.tabs.setDocumentMode(True)
        self.tabs.setTabsClosable(True)
        self.tabs.setMovable(True)
        self.tabs.setExpanding(False)
        self.tabs.currentChanged.connect(self._tab_chosen)
        self.tabs.tabCloseRequested.connect(lambda index: self.close_document(self.workspaces[index]))
        self.tabs.tabMoved.connect(self._tab_moved)
        self.tabs.hide()
        centre = QWidget()
        layout = QVBoxLayout(centre)
        layout.setContentsMargins(0, 0, 0, 0)
        layout.setSpacing(0)
        layout.addWidget(self.tabs)
        layout.addWidget(self.canvas, 1)
        return centre

    # -- opening and choosing ---------------------------------------------------------------------
    def _install(self, opened: Opened) -> None:
        """Open ``opened`` in a new tab and make it the active document.

        A new untitled document nobody has edited is replaced instead, as
        editors do with the blank canvas they start on.
        """
        blank = self.workspace
        workspace = Workspace(opened, self.options, self._choose_stop_color, self)
        workspace.document_changed.connect(lambda w=workspace: self._if_active(w, self._document_changed))
        workspace.steps_changed.connect(lambda w=workspace: self._steps_of(w))
        workspace.frame_ready.connect(lambda frame, w=workspace: self._if_active(w, self._frame_ready, frame))
        workspace.engine_failed.connect(lambda text, w=workspace: self._if_active(w, self._engine_failed, text))
        workspace.engine_progress.connect(lambda *a, w=workspace: self._if_active(w, self._engine_progress, *a))
        workspace.message.connect(lambda text, w=workspace: self._if_active(w, self.status_label.setText, text))
        self.workspaces.append(workspace)
        self.autosaver.watch(workspace, opened.recovered)
        self.tabs.blockSignals(True)  # shown once, by _activate
        self.tabs.addTab(workspace.name)
        self.tabs.blockSignals(False)
        if workspace.path is not None:
            self.recent.add(workspace.path)
        self._activate(workspace)
        if blank is not None and blank.path is None and blank.history.index == 0 and not blank.history.modified:
            self._drop(blank)
        if opened.notes:
            self.status_label.setText(f"{workspace.name}: " + "; ".join(opened.notes))

    def _if_active(self, workspace: Workspace, slot: Callable, *args) -> None:
        if workspace is self.workspace:
            slot(*args)

    def _activate(self, workspace: Workspace) -> None:
        """Make ``workspace``'s tab current (which shows it)."""
        index = self.workspaces.index(workspace)
        if self.tabs.currentIndex() != index:
            self.tabs.setCurrentIndex(index)
        else:
            self._show(workspace)

    def _tab_chosen(self, index: int) -> None:
        if 0 <= index < len(self.workspaces) and self.workspaces[index] is not self.workspace:
            self._show(self.workspaces[index])

    def next_document(self, step: int = 1) -> None:
        """Show the next open document's tab (Ctrl+Tab), or with ``step`` -1 the previous one."""
        if len(self.workspaces) > 1 and not self._busy:
            self.tabs.setCurrentIndex((self.tabs.currentIndex() + step) % len(self.workspaces))

    def previous_document(self) -> None:
        self.next_document(-1)

    def _tab_moved(self, source: int, target: int) -> None:
        self.workspaces.insert(target, self.workspaces.pop(source))

    def _show(self, workspace: Workspace | None) -> None:
        """Point the canvas, the panels and the tools at ``workspace`` (None: nothing open)."""
        old = self.workspace
        if old is not None and old is not workspace:
            old.tools[self.tool_name].finish()
            old.view = (self.canvas.view, self.canvas.fitted)
        self.workspace = workspace
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
        self.tabs.setVisible(len(self.workspaces) > 1)
        self.status_label.setText("")  # what was said was about the document shown before
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
        if workspace is self.workspace:
            self._update_state()

    def _name_tab(self, workspace: Workspace) -> None:
        """The file name on ``workspace``'s tab, with ``*`` while it has unsaved changes."""
        index = self.workspaces.index(workspace)
        self.tabs.setTabText(index, workspace.name + ("*" if workspace.history.modified else ""))
        self.tabs.setTabToolTip(index, str(workspace.path) if workspace.path is not None else "not saved yet")

    # -- closing ------------------------------------------------------------------------------------
    def close_document(self, workspace: Workspace | None = None) -> None:
        """Close ``workspace`` (default: the active one), asking first about unsaved changes (Ctrl+W).

        A tab in the background is brought forward only for the question;
        the document worked on stays in front.
        """
        workspace, shown = workspace or self.workspace, self.workspace
        if workspace is None or self._busy:
            return

        def close() -> None:
            self._drop(workspace)
            if shown is not workspace and shown in self.workspaces:
                self._activate(shown)

        if workspace.history.modified:
            self._activate(workspace)
            self._settle_changes(close)
        else:
            close()

    def _drop(self, workspace: Workspace, show_next: bool = True) -> None:
        """Close ``workspace`` now: its tab, tools and engine thread; the next tab is shown if it was (unless
        not ``show_next``: the window is closing)."""
        index = self.workspaces.index(workspace)
        workspace.tools[self.tool_name].cancel()
        workspace.close()
        self.autosaver.forget(workspace)
        self.workspaces.pop(index)
        self.tabs.blockSignals(True)
        self.tabs.removeTab(index)
        self.tabs.blockSignals(False)
        if workspace is self.workspace:
            self.workspace = None  # nothing to keep of it: the next one is shown without finishing its tools
            following = self.workspaces[min(index, len(self.workspaces) - 1)] if self.workspaces else None
            if following is not None and show_next:
                self._activate(following)
            else:
                self._show(None)
        self.tabs.setVisible(len(self.workspaces) > 1)
        workspace.deleteLater()

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
        """Run ``proceed`` once the active document's unsaved changes are saved or may be dropped (asks)."""
        workspace = self.workspace
        if workspace is None or not workspace.history.modified:
            proceed()
            return
        answer = ask_keep_changes(self, workspace.name)
        if answer == "discard":
            proceed()
        elif answer == "save":
            self.save(then=proceed)
