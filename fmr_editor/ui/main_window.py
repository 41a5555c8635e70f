"""The editor's main window: canvas, panels, menus, and the jobs that open, save and export.

Each open document is a ``Workspace`` in a tab of its own (``documents``, ``tabs``);
the one shown is ``workspace``.  Pointer events from the canvas go to its
active tool; every change of the document goes to the
engine thread, whose frames update the canvas cell by cell.  Opening,
building, saving and exporting run on ``jobs.Job`` threads, each for one tab
with its progress in the status bar while that tab is shown; the document a
job works on cannot be edited until it ends (so that it reads a
representation nothing changes), every other tab can.
"""

from __future__ import annotations

from collections.abc import Callable

from PySide6.QtCore import QEvent, QSettings, Qt
from PySide6.QtGui import QCursor, QKeySequence, QShortcut
from PySide6.QtWidgets import (
    QAbstractSpinBox,
    QDockWidget,
    QFrame,
    QLabel,
    QMainWindow,
    QMenu,
    QMessageBox,
    QProgressBar,
    QScrollArea,
    QToolButton,
)

from .. import __version__
from ..io.autosave import AutosaveFolder
from ..model.clone_edits import canvas_region
from ..tools import TOOLS, Selection, ToolOptions, delete_selection
from ..tools.overlay import region_marks
from .autosave import Autosaver, RecoveryDialog, default_folder
from .canvas import Canvas
from .clip_commands import ClipCommands
from .documents import DocumentCommands, Opening
from .elided_label import ElidedLabel
from .events import modifier_names, pointer_event, tool_key
from .file_commands import FileCommands
from .files import RecentFiles
from .help import USER_GUIDE, GuideDialog, ShortcutsDialog
from .history_panel import HistoryPanel
from .jobs import Job, Task
from .layer_commands import LayerCommands
from .layers_panel import LayersPanel
from .menus import build_actions, build_menus
from .options_panel import OptionsPanel
from .overlay import Overlay
from .panel_focus import ReturnToCanvas
from .preferences import Preferences, PreferencesDialog
from .progress import STAGE_WORDS, progress_text
from .refusals import reporting
from .status_message import StatusMessage
from .stops_panel import StopsPanel
from .toolbox import build_toolbox
from .workspace import Workspace
from .zoom import ZoomButton

APP_NAME = "FMR Editor"
#: Room in the progress bar beside its words: its frame and the chunk's margins, pixels.
PROGRESS_MARGIN = 40
CURSORS = {
    "arrow": Qt.CursorShape.ArrowCursor,
    "crosshair": Qt.CursorShape.CrossCursor,
    "pen": Qt.CursorShape.CrossCursor,
    "picker": Qt.CursorShape.PointingHandCursor,
}


class MainWindow(FileCommands, DocumentCommands, QMainWindow):
    """The editor window: file and tab commands mixed in (``file_commands``, ``documents``); the Layer and the
    clipboard commands are parts that see it through ``editing.Editing`` (``layer_commands``, ``clip_commands``).

    Parameters
    ----------
    settings : QSettings
        Where the recent files and the window layout are kept.
    parent : QWidget, optional

    Attributes
    ----------
    workspace : Workspace or None
        The document shown (None while none is, or its tab is still opening).
    workspaces : list of Workspace
        Every open document, in the order of their tabs.
    open_tabs : list of Workspace or documents.Opening
        Every tab, documents still opening included.
    canvas : ui.canvas.Canvas
    actions : dict of str to QAction
    layer_commands : layer_commands.LayerCommands
    clip_commands : clip_commands.ClipCommands
    """

    def __init__(self, settings: QSettings, parent=None, autosave: Autosaver | None = None) -> None:
        super().__init__(parent)
        self.settings = settings
        self.preferences = Preferences.load(settings)
        self.show_blur = settings.value("view/show_blur", True, type=bool)
        self.autosaver = autosave or Autosaver(AutosaveFolder(default_folder()), self.preferences.autosave_seconds)
        self.autosaver.setParent(self)
        self.recovery: RecoveryDialog | None = None  # the recovery dialog while it is open
        self.guide_dialog: GuideDialog | None = None  # the user guide, once shown
        self.recent = RecentFiles(settings)
        self.options = ToolOptions()
        self.preferences.apply_brush(self.options)
        self.workspace: Workspace | None = None
        self.tool_name = "select"
        self._close_now = False
        self._swallow: int | None = None  # a key press the tool took at its shortcut override
        self._declined: int | None = None  # a key press the tool declined at its shortcut override

        self.canvas = Canvas(self)
        self.setCentralWidget(self._build_tabs())
        self.overlay = Overlay(self.canvas, self._overlay)
        self.canvas.pressed.connect(lambda *a: self._pointer("press", pointer_event(*a)))
        self.canvas.double_clicked.connect(lambda *a: self._pointer("press", pointer_event(*a, clicks=2)))
        self.canvas.moved.connect(lambda *a: self._pointer("move", pointer_event(*a)))
        self.canvas.released.connect(lambda *a: self._pointer("release", pointer_event(*a)))
        self.canvas.view_changed.connect(self._view_changed)
        self.canvas.installEventFilter(self)

        self.actions = build_actions(self)
        self.actions["show_blur"].setChecked(self.show_blur)
        self.recent_menu = QMenu("Open &Recent", self)
        self.recent_menu.aboutToShow.connect(self._fill_recent_menu)
        self.toolbox = build_toolbox(self, self.actions)
        self.options_panel = OptionsPanel(self.options)
        self.options_panel.changed.connect(self.overlay.update)
        self.stops_panel = StopsPanel()
        self.stops_panel.changed.connect(self.after_tool)
        self.history_panel = HistoryPanel()
        self.layers_panel = LayersPanel(self.actions, self.settle_edits)
        self.layer_commands = LayerCommands(self, self.layers_panel, self.actions, self)
        self.clip_commands = ClipCommands(self, self.actions, self.canvas)
        self.layers_panel.failed.connect(lambda message: self.status_label.setText(message))
        docks = [
            self._dock("Tool Options", "options", self.options_panel, Qt.DockWidgetArea.LeftDockWidgetArea,
                       scrolled=True),
            self._dock("Layers", "layers", self.layers_panel, Qt.DockWidgetArea.RightDockWidgetArea),
            self._dock("Colour Stops", "stops", self.stops_panel, Qt.DockWidgetArea.RightDockWidgetArea,
                       scrolled=True),
            self._dock("History", "history", self.history_panel, Qt.DockWidgetArea.RightDockWidgetArea),
        ]
        build_menus(self, self.actions, self.recent_menu,
                    [self.toolbox.toggleViewAction()] + [d.toggleViewAction() for d in docks])
        self.return_to_canvas = ReturnToCanvas(self.canvas, self)
        self.return_to_canvas.watch(box for panel in (self.options_panel, self.stops_panel)
                                    for box in panel.findChildren(QAbstractSpinBox))

        self._build_status_bar()
        self.autosaver.failed.connect(lambda message: self.status_label.setText(message))

        self.setAcceptDrops(True)
        self.resize(1200, 800)
        geometry = settings.value("window/geometry")
        if geometry is not None:
            self.restoreGeometry(geometry)
            self.restoreState(settings.value("window/state", b""))
        self.set_tool(self.tool_name)
        self.update_state()

    def _build_status_bar(self) -> None:
        """Messages and the active tool's hint on the left; preview notice, progress and pointer on the right."""
        self.status_label = StatusMessage(self._history_step)
        self.hint_label = ElidedLabel()  # what the active tool does
        self.shading_label = QLabel()  # shown while a frame is a drag's preview
        self.shading_label.hide()
        self.position_label = QLabel()
        self.progress_bar = QProgressBar()
        self.progress_bar.setRange(0, 1000)
        # as wide as its widest words at 100%, and no narrower when the window is (the tool's hint gives way)
        words = max(self.progress_bar.fontMetrics().horizontalAdvance(progress_text(stage).replace("%p", "100"))
                    for stage in STAGE_WORDS)
        self.progress_bar.setFixedWidth(words + PROGRESS_MARGIN)
        self.progress_bar.hide()
        self.cancel_button = QToolButton()
        self.cancel_button.setText("Cancel")
        self.cancel_button.setToolTip("Stop the current job (Esc); the document stays as it was")
        self.cancel_button.clicked.connect(self.cancel_job)
        self.cancel_button.hide()
        self.cancel_shortcut = QShortcut(QKeySequence(Qt.Key.Key_Escape), self, self.cancel_job)
        self.cancel_shortcut.setEnabled(False)  # Esc belongs to the tools unless a job runs
        status = self.statusBar()
        status.addWidget(self.status_label)
        status.addWidget(self.hint_label, 1)
        status.addPermanentWidget(self.shading_label)
        status.addPermanentWidget(self.progress_bar)
        status.addPermanentWidget(self.cancel_button)
        status.addPermanentWidget(self.position_label)
        self.zoom_button = ZoomButton(self.canvas, self)
        status.addPermanentWidget(self.zoom_button)

    def _dock(self, title: str, name: str, widget, area, scrolled: bool = False) -> QDockWidget:
        """``widget`` in a dock; ``scrolled``: in a scroll area, for a panel of fixed rows that a small window
        would otherwise squeeze past their minimum (its last rows drawn over the dock below)."""
        dock = QDockWidget(title, self)
        dock.setObjectName(name)
        if scrolled:
            scroll = QScrollArea(dock)
            scroll.setWidgetResizable(True)
            scroll.setFrameShape(QFrame.Shape.NoFrame)
            scroll.setWidget(widget)
            widget = scroll
        dock.setWidget(widget)
        self.addDockWidget(area, dock)
        return dock

    # -- the active tool ------------------------------------------------------------------------------
    @property
    def tool(self):
        """The active tool of the open document (None without one)."""
        return self.workspace.tools[self.tool_name] if self.workspace is not None else None

    def set_tool(self, name: str) -> None:
        """Make tool ``name`` active; the previous one finishes what it was doing."""
        if self.tool is not None and name != self.tool_name:
            self.tool.finish()
        self.tool_name = name
        self.actions[f"tool:{name}"].setChecked(True)
        cursor = self.workspace.tools[name].cursor if self.workspace is not None else "arrow"
        self.canvas.setCursor(QCursor(CURSORS.get(cursor, Qt.CursorShape.ArrowCursor)))
        self.hint_label.setText((self.tool or next(cls for cls in TOOLS if cls.name == name)).hint)
        self.after_tool()

    def _pointer(self, kind: str, event) -> None:
        tool = self.tool
        if tool is None or self.busy:
            return
        self._refusing(getattr(tool, kind), event)
        x, y = event.position
        self.position_label.setText(f"{x:.1f}, {y:.1f}")
        self.after_tool()

    def settle_edits(self) -> bool:
        """Make way for an edit from a menu or a panel: the active tool finishes what it was doing (a clone's
        placement is kept); False when nothing can be edited (no document, a job, a panel's drag open)."""
        if self.workspace is None or self.busy:
            return False
        self.tool.finish()
        return not self.workspace.history.in_transaction

    def _refusing(self, action: Callable, *args):
        """``action(*args)`` of the tool; an edit the document refuses (drawing on a clone layer, say), or a bug,
        cancels what the tool was doing and the status bar says why (``refusals.reporting``)."""
        said: list[str] = []
        with reporting(said.append):
            return action(*args)
        self.tool.cancel()  # first: ending the tool's gesture would take back what is said of it (``StatusMessage``)
        self.status_label.setText(said[-1])
        return True

    def say(self, text: str) -> None:
        """``text`` in the status bar (what was done, or why not)."""
        self.status_label.setText(text)

    def after_tool(self) -> None:
        """Show what a tool or panel did that no panel follows by itself: the overlay, the selection's stops, the
        colours (the eyedropper's), the actions."""
        self.overlay.update()
        self.stops_panel.refresh()
        self.options_panel.refresh()
        self._update_actions()

    def _overlay(self) -> list:
        tool = self.tool
        return region_marks(self.workspace.context) + tool.overlay() if tool is not None else []

    def _view_changed(self) -> None:
        if self.workspace is not None:
            self.workspace.context.zoom = self.canvas.view.scale

    def eventFilter(self, watched, event) -> bool:
        """Delete, BackSpace, Return, Escape and the arrows go to the tool first, then to the menus."""
        kind = event.type()
        if watched is not self.canvas or kind not in (QEvent.Type.ShortcutOverride, QEvent.Type.KeyPress):
            return super().eventFilter(watched, event)
        name, tool = tool_key(event.key()), self.tool
        if name is None or tool is None or self.busy:
            return False
        key = event.key()
        if kind == QEvent.Type.KeyPress:
            if self._swallow == key:
                self._swallow = None
                return True
            if self._declined == key:
                self._declined = None
                return False
        used = self._refusing(tool.key, name, modifier_names(event.modifiers()))
        if used:
            self.after_tool()
            if kind == QEvent.Type.ShortcutOverride:
                self._swallow = key
                event.accept()
            return True
        if kind == QEvent.Type.ShortcutOverride:
            self._declined = key
        return False

    # -- edit commands --------------------------------------------------------------------------------
    def undo(self) -> None:
        """Undo the last step (a gesture in progress is cancelled instead)."""
        if self.workspace is None or self.busy:
            return
        if self.tool.busy:
            self.tool.cancel()
            self.after_tool()
            return
        self.workspace.history.undo()

    def redo(self) -> None:
        if self.workspace is not None and not self.busy and not self.tool.busy:
            self.workspace.history.redo()

    def delete_selection(self) -> None:
        if self.workspace is None or self.busy:
            return
        if not self.tool.key("Delete"):
            delete_selection(self.workspace.context)
        self.after_tool()

    def select_all(self) -> None:
        if self.workspace is None:
            return
        context = self.workspace.context
        document = context.document
        context.selection = Selection.of(curves=[c.id for c in document.curves], points=document.point_ids())
        context.region = canvas_region(document)
        self.after_tool()

    def deselect(self) -> None:
        if self.workspace is not None:
            self.workspace.context.selection = Selection()
            self.workspace.context.region = None
            self.after_tool()

    def zoom_in(self) -> None:
        self.canvas.zoom_in()

    def zoom_out(self) -> None:
        self.canvas.zoom_out()

    def fit(self) -> None:
        self.canvas.fit()

    def actual_size(self) -> None:
        self.canvas.zoom_to(1.0)

    def toggle_blur(self) -> None:
        """View > Show Blur: soften each layer by its curves' blur stops, or show it sharp (every open
        document; the choice holds from one start to the next)."""
        self.show_blur = self.actions["show_blur"].isChecked()
        self.settings.setValue("view/show_blur", self.show_blur)
        for workspace in self.workspaces:
            workspace.set_blur(self.show_blur)

    def swap_colors(self) -> None:
        self.options_panel.swap_colors()

    def default_colors(self) -> None:
        self.options_panel.default_colors()

    def edit_preferences(self) -> None:
        """Edit > Preferences: a dialog; its choices hold at once and from one start to the next."""
        self.preferences_dialog = dialog = PreferencesDialog(self.preferences, self)
        dialog.accepted.connect(lambda: self.set_preferences(dialog.chosen))
        dialog.open()

    def set_preferences(self, preferences: Preferences) -> None:
        """Keep ``preferences`` in the settings and apply them: the brush now, the autosave delay, and the undo
        memory of every open document."""
        self.preferences = preferences
        preferences.save(self.settings)
        preferences.apply_brush(self.options)
        self.options_panel.refresh()
        self.overlay.update()  # the brush's circle at its new radius, before the pointer moves
        self.autosaver.set_seconds(preferences.autosave_seconds)
        for workspace in self.workspaces:
            workspace.set_undo_memory(preferences.undo_memory)

    def about(self) -> None:
        QMessageBox.about(self, f"About {APP_NAME}",
                          f"<b>{APP_NAME}</b> {__version__}<p>Diffusion curves and points, rendered through the fast "
                          "multipole representation.</p>")

    def show_shortcuts(self) -> None:
        self.shortcuts_dialog = ShortcutsDialog(self.actions, self)
        self.shortcuts_dialog.open()

    def user_guide(self) -> None:
        if not USER_GUIDE.is_file():
            self.status_label.setText("The user guide is docs/user-guide.md in the editor's source repository")
            return
        if self.guide_dialog is None:  # one guide window, brought to the front again
            self.guide_dialog = GuideDialog(self)
        self.guide_dialog.show()
        self.guide_dialog.raise_()
        self.guide_dialog.activateWindow()

    # -- the document ---------------------------------------------------------------------------------
    def _choose_stop_color(self, current) -> None:
        """The stops tool's double click: the selected stop's live colour dialog (``StopsPanel.edit_color``)."""
        stops = self.workspace.context.selection.stops if self.workspace is not None else ()
        if stops:
            self.stops_panel.refresh()
            self.stops_panel.edit_color(next(iter(stops))[1])
        return None

    def _document_changed(self) -> None:
        document = self.workspace.history.document
        overlay = document.layer.id if document.editing_mask else None
        if overlay != self.canvas.mask_overlay:
            self.canvas.set_mask_overlay(overlay)
            self.status_label.setText(self._standing_status())
        self.after_tool()
        self._update_title()

    def _history_step(self) -> tuple[int, int, int, bool] | None:
        """The shown document's step (``StatusMessage``): its history, current step, count of steps and whether a
        gesture is open on it (a drag, a clone's placement), whose end, kept or dropped, moves it on too.  An
        edit merged into the step before it (a slider's drag) stays at that step."""
        if self.workspace is None:
            return None
        history = self.workspace.history
        return id(history), history.index, history.step_count, history.in_transaction

    def _standing_status(self) -> str:
        """What the status bar says while nothing else is said: that the canvas cannot draw, or the mask being
        edited and how to leave it."""
        document = self.workspace.history.document if self.workspace is not None else None
        if document is not None and self.canvas.error:  # no suitable OpenGL: editing works, nothing is shown
            return f"The canvas cannot draw the image: {self.canvas.error}"
        if document is None or not document.editing_mask:
            return ""
        return f"Editing the mask of {document.layer.name} (red: hidden); Ctrl+Shift+M goes back to the layer"

    def _frame_ready(self, frame) -> None:
        self._show_shading(frame)
        self.canvas.update_representation(frame.picture, frame.changes)
        if not self.busy:
            self.progress_bar.hide()

    def _show_shading(self, frame) -> None:
        """Say in the status bar when the picture is a drag's preview, and which kind."""
        self.shading_label.setVisible(not frame.exact)
        if frame.stale:
            self.shading_label.setText("Preview: shading when the drag ends")
            self.shading_label.setToolTip("The picture before the drag, with the moved curve's outline: a preview "
                                          "of this move would be off by more than 1/255")
        else:
            self.shading_label.setText("Preview")
            self.shading_label.setToolTip("While dragging, the moved curve is solved again with the curves near it "
                                          "(within 1/255 of the exact image); the exact image follows when the drag "
                                          "ends")

    def _engine_failed(self, message: str) -> None:
        self.status_label.setText(f"The image could not be updated: {message.splitlines()[0]}")

    def _engine_progress(self, stage: str, fraction: float) -> None:
        if not self.busy:
            self._show_progress(stage, fraction)

    def _show_progress(self, stage: str, fraction: float) -> None:
        self.progress_bar.show()
        self.progress_bar.setFormat(progress_text(stage))
        self.progress_bar.setValue(int(round(min(max(fraction, 0.0), 1.0) * 1000)))

    # -- state shown --------------------------------------------------------------------------------------
    def _update_title(self) -> None:
        workspace = self.workspace
        if workspace is None:  # nothing open, or a tab still opening
            self.setWindowTitle(f"{self.shown.name} \u2014 {APP_NAME}" if self.shown is not None else APP_NAME)
            return
        mark = "*" if workspace.history.modified else ""
        self.setWindowTitle(f"{workspace.name}{mark} \u2014 {APP_NAME}")
        self._name_tab(workspace)

    def _update_actions(self) -> None:
        workspace, actions, free = self.workspace, self.actions, not self.busy
        history = workspace.history if workspace is not None else None
        undo = history.undo_label if history is not None else None
        redo = history.redo_label if history is not None else None
        actions["undo"].setText(f"Undo {undo}" if undo else "Undo")
        actions["redo"].setText(f"Redo {redo}" if redo else "Redo")
        gesture = self.tool is not None and self.tool.busy  # Undo drops it
        actions["undo"].setEnabled(free and (undo is not None or gesture))
        actions["redo"].setEnabled(free and redo is not None)
        for name in ("save", "save_as", "export", "export_svg", "delete", "select_all", "deselect"):
            actions[name].setEnabled(free and workspace is not None)
        actions["close"].setEnabled(self.shown is not None)
        for name in ("next_document", "previous_document"):
            actions[name].setEnabled(len(self.open_tabs) > 1)
        self.clip_commands.update_actions()
        self.layer_commands.update_actions()

    def update_state(self) -> None:
        """Show the document's state again: title, actions, overlay."""
        self._update_title()
        self._update_actions()
        self.overlay.update()

    # -- jobs -------------------------------------------------------------------------------------------
    @property
    def busy(self) -> bool:
        """True while the tab shown waits for a job (opening, saving, exporting): nothing edits it."""
        return self.shown is not None and self.shown.task is not None

    @property
    def job(self) -> Job | None:
        """A job still running for any tab (None when none is)."""
        return next((tab.task.job for tab in self.open_tabs if tab.task is not None and tab.task.job is not None),
                    None)

    def _show_task(self) -> None:
        """The shown tab's job in the status bar (title, progress, Cancel) and its document paused, or neither."""
        task = self.shown.task if self.shown is not None else None
        for widget in (self.stops_panel, self.history_panel, self.layers_panel):
            widget.setEnabled(task is None)
        running = task is not None and task.job is not None
        if task is not None:
            self.status_label.setText(task.title)
            self._show_progress(task.stage, task.fraction)
        else:
            self.progress_bar.hide()
        self.cancel_button.setVisible(running)
        self.cancel_shortcut.setEnabled(running)
        self._update_actions()

    def _begin(self, tab, title: str) -> Task:
        """Mark ``tab`` busy with ``title`` (before its job starts: a save waits for the engine first)."""
        if tab is self.shown and self.tool is not None:
            self.tool.finish()
        tab.task = Task(title)
        if tab is self.shown:
            self._show_task()
        return tab.task

    def _start(self, tab, title: str, work, succeeded: Callable, failed: Callable,
               cancelled: Callable[[], None] | None = None) -> None:
        """Run ``work(progress)`` on a job thread for ``tab``, which waits for it; then ``succeeded(result)``,
        ``failed(error)`` or ``cancelled()`` (default: the status bar says so)."""
        task = tab.task or self._begin(tab, title)  # a save's began while it waited for the engine
        job = task.job = Job(work, title, self)
        cancelled = cancelled or (lambda: self.status_label.setText(f"Cancelled: {title}"))
        job.progress.connect(lambda stage, fraction: self._job_progress(tab, stage, fraction))
        job.succeeded.connect(lambda result: self._finish_job(tab, job, succeeded, result))
        job.failed.connect(lambda error: self._finish_job(tab, job, failed, error))
        job.cancelled.connect(lambda: self._finish_job(tab, job, lambda _: cancelled(), None))
        if tab is self.shown:
            self._show_task()
        job.start()

    def _job_progress(self, tab, stage: str, fraction: float) -> None:
        task = tab.task
        if task is None:
            return
        shown_percent = round(task.fraction * 100)
        task.stage, task.fraction = stage, fraction
        if tab is self.shown:
            self._show_progress(stage, fraction)
        if isinstance(tab, Opening) and round(fraction * 100) != shown_percent:
            self._name_tab(tab)

    def cancel_job(self) -> None:
        """Stop the shown tab's job at its next progress report (the Cancel button, Esc)."""
        if self.shown is not None:
            self._cancel(self.shown)

    def _cancel(self, tab) -> None:
        if tab.task is not None and tab.task.job is not None:
            tab.task.job.cancel()
            if tab is self.shown:
                self.status_label.setText(f"Cancelling: {tab.task.title}")

    def _finish_job(self, tab, job: Job, then: Callable, value) -> None:
        job.wait()
        job.deleteLater()
        tab.task = None
        if tab is self.shown:
            self._show_task()
            self.status_label.setText("")
        then(value)
        if tab is self.shown:
            self.update_state()
