"""One open document: its history, tools and engine thread, and how it is opened.

``open_file`` and ``new_document`` do the slow part (reading, solving) and
run on a ``jobs.Job``; the window then makes a ``Workspace`` of the result on
its own thread.  The workspace sends every change of the current document
(edits, drags, undo) to its ``EngineThread`` and keeps the newest ``Frame``.
"""

from __future__ import annotations

import os
from collections.abc import Callable
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np
from PySide6.QtCore import QObject, Signal

from ..engine import LiveStack, Progress, Settings, evaluate_points
from ..io import open_live
from ..io.autosave import Autosaved, AutosaveFolder
from ..model import ColorStop, DiffusionCurve, Document
from ..model.history import History
from ..tools import ToolContext, ToolOptions, create_tools
from .engine_thread import EngineThread, Frame
from .jobs import Task

#: Canvas size of a new document, pixels.
DEFAULT_SIZE = (512, 512)
#: A new document's background: a closed curve this far inside the canvas edge, white on both sides.
BACKGROUND_INSET = 2.0
BACKGROUND = (1.0, 1.0, 1.0)


@dataclass(frozen=True, eq=False)
class Opened:
    """A document read (or made) and built, ready for a ``Workspace``.

    Attributes
    ----------
    live : LiveStack
        Built for ``live.document``.
    frame : Frame
        The first frame (every cell changed).
    path : pathlib.Path or None
        The file it came from; None for a new document.
    notes : tuple of str
        What was not taken from the file and why (a saved representation rebuilt).
    recovered : str or None
        The key of the autosaved copy it was recovered from (its changes are not saved).
    """

    live: LiveStack
    frame: Frame
    path: Path | None
    notes: tuple[str, ...] = ()
    recovered: str | None = None

    def blurred(self, progress: Progress | None = None) -> Opened:
        """This document with its blur fields solved (``LiveStack.set_blur``), so that its first frame shows the
        blur."""
        self.live.set_blur(True, progress)
        return replace(self, frame=Frame.first(self.live))

    @property
    def document(self) -> Document:
        return self.live.document


def _opened(live: LiveStack, path: Path | None, notes: list[str] = ()) -> Opened:
    return Opened(live, Frame.first(live), path, tuple(notes))


def open_file(path: str | os.PathLike, progress: Progress | None = None) -> Opened:
    """Read and build the document in ``path`` (``.fmr`` or Orzan ``.xml``).

    A ``.fmr`` file's saved representation is taken as it is (no solve).

    Raises
    ------
    DocumentLoadError
        When the file cannot be read.
    """
    path = Path(path).resolve()
    notes: list[str] = []
    return _opened(open_live(path, progress=progress, notes=notes), path, notes)


def recover(folder: AutosaveFolder, entry: Autosaved, progress: Progress | None = None) -> Opened:
    """Read and build the document autosaved in ``entry``; it keeps the path of the file it came from.

    Raises
    ------
    DocumentLoadError
        When the copy cannot be read.
    """
    live = LiveStack(folder.load(entry), Settings(), progress)
    return Opened(live, Frame.first(live), entry.path, recovered=entry.key)


def background_curve(width: float, height: float, color=BACKGROUND) -> DiffusionCurve:
    """A closed rectangle just inside the canvas with ``color`` on both sides: the canvas shows ``color``.

    With no curve at all a diffusion image is black; this gives a new
    document a background the user can select and recolour like any curve.
    """
    a, w, h = BACKGROUND_INSET, width - BACKGROUND_INSET, height - BACKGROUND_INSET
    corners = np.array([(a, a), (w, a), (w, h), (a, h), (a, a)])
    points = [corners[0]]
    for start, end in zip(corners[:-1], corners[1:]):  # straight pieces: handles a third of the way along
        points += [start + (end - start) / 3, start + 2 * (end - start) / 3, end]
    stop = (ColorStop(0.0, tuple(color)),)
    return DiffusionCurve(np.array(points), left=stop, right=stop)


def new_document(width: int = DEFAULT_SIZE[0], height: int = DEFAULT_SIZE[1],
                 progress: Progress | None = None) -> Opened:
    """A canvas of ``width x height`` pixels with a white background curve (``background_curve``), built."""
    document = Document(int(width), int(height), (background_curve(width, height),))
    return _opened(LiveStack(document, Settings(), progress), None)


class Workspace(QObject):
    """An open document: history, tool context, tools and the engine on its thread.

    Parameters
    ----------
    opened : Opened
    options : ToolOptions
        Shared by every workspace of the window (tool settings outlive documents).
    choose_color : callable, optional
        ``ToolContext.choose_color``.
    parent : QObject, optional

    Attributes
    ----------
    history : History
    context : ToolContext
    tools : dict of str to Tool
    frame : Frame
        The newest frame the engine produced.
    path : pathlib.Path or None
        Where the document was read from or last saved to (resolved).
    recovered : bool
        Whether it was recovered from an autosaved copy (``Opened.recovered``, that copy's key).
    view : tuple
        ``(render.view.View or None, fitted)``: the canvas's view while the
        document was last shown (fitted: it fitted the canvas in the window).
    failure : str or None
        The engine's last failure, until a frame arrives (shown when the
        document's tab comes to the front).
    task : jobs.Task or None
        The job the document waits for (saving, exporting): nothing edits it
        until it is done.

    Signals
    -------
    frame_ready(Frame)
    document_changed()
        After every change of the current document (edits, previews, undo, jumps).
    steps_changed()
        After every change of the history's steps, current step or saved mark
        (a drag's commit adds a step without changing the document shown).
    engine_failed(str)
    engine_progress(str, float)
    message(str)
        A tool's one-line message for the status bar (``ToolContext.say``).
    """

    frame_ready = Signal(object)
    document_changed = Signal()
    steps_changed = Signal()
    engine_failed = Signal(str)
    engine_progress = Signal(str, float)
    message = Signal(str)

    def __init__(self, opened: Opened, options: ToolOptions, choose_color=None, parent=None) -> None:
        super().__init__(parent)
        self.path = opened.path
        self.settings = opened.live.settings
        self.history = History(opened.document)
        self.recovered = opened.recovered is not None  # from an autosaved copy: its changes are not saved
        if self.recovered:
            self.history.mark_unsaved()
        self.context = ToolContext(self.history, sample=self.sample, choose_color=choose_color, options=options,
                                   say=self.message.emit)
        self.view = (None, True)
        self.failure: str | None = None  # why the engine could not bring the image up to date, until it can
        self.task: Task | None = None
        self.tools = create_tools(self.context)
        self.frame = opened.frame
        self._waiting: list[Callable[[Frame | None], None]] = []
        self._previewing = False  # the last request was a drag's preview
        self.engine = EngineThread(opened.live)
        self.engine.ready.connect(self._ready)
        self.engine.failed.connect(self._failed)
        self.engine.progress.connect(self.engine_progress)
        self.history.subscribe(self._changed)
        self.history.subscribe_steps(self._steps_changed)

    # -- naming ------------------------------------------------------------------------------
    @property
    def name(self) -> str:
        """The file name shown in the title ("Untitled" for a new document)."""
        return self.path.name if self.path is not None else "Untitled"

    @property
    def native(self) -> bool:
        """True when ``path`` is a ``.fmr`` file, which Save writes back to."""
        return self.path is not None and self.path.suffix.lower() == ".fmr"

    # -- the engine --------------------------------------------------------------------------
    def _changed(self, before: Document, after: Document) -> None:
        self._previewing = self.history.in_transaction
        self.engine.request(after, preview=self._previewing)
        self.document_changed.emit()

    def _steps_changed(self) -> None:
        if self._previewing and not self.history.in_transaction:  # a drag ended: its last preview, exactly
            self._previewing = False
            self.engine.request(self.history.document)
        self.steps_changed.emit()

    def _ready(self, frame: Frame) -> None:
        self.frame, self.failure = frame, None
        self.frame_ready.emit(frame)
        if self.current and self._waiting:
            waiting, self._waiting = self._waiting, []
            for callback in waiting:
                callback(frame)

    def _failed(self, message: str) -> None:
        self.failure = message
        self.engine_failed.emit(message)
        waiting, self._waiting = self._waiting, []
        for callback in waiting:
            callback(None)

    @property
    def current(self) -> bool:
        """True when the newest frame shows the current document exactly (the engine is idle)."""
        return self.frame.document is self.history.document and self.frame.exact

    def when_current(self, callback: Callable[[Frame | None], None]) -> None:
        """Call ``callback(frame)`` once the engine has caught up with the current document.

        At once if it has; ``callback(None)`` if the engine fails first.  The
        frame's representation stays unchanged until the next edit, so a job
        may read it on another thread while the window lets nothing edit.
        """
        if self.current:
            callback(self.frame)
        else:
            self._waiting.append(callback)

    def set_blur(self, shown: bool) -> None:
        """Show the blur of the document's curves, or not (the engine solves or drops the blur fields)."""
        self.engine.set_blur(shown, self.history.document)

    def set_undo_memory(self, memory: int) -> None:
        """Let the document keep ``memory`` bytes of recent states for fast undo (from its next change on)."""
        self.engine.set_memory(memory)

    def sample(self, x: float, y: float) -> tuple[float, float, float]:
        """The rendered colour at document point ``(x, y)`` (the eyedropper's sampler)."""
        value = evaluate_points(self.frame.picture, np.array([[x, y]], dtype=np.float64))[0]
        return tuple(float(v) for v in np.clip(value, 0.0, 1.0))

    def close(self) -> None:
        """End the engine thread (after its current update)."""
        self._waiting = []
        self.engine.stop()
