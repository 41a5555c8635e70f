"""The engine on a worker thread: the window never waits for a solve.

The window posts each new document with ``request``; a worker thread brings
its ``LiveRepresentation`` up to date and hands back a ``Frame`` after every
update.  While an update runs, newer requests replace older pending ones
(the newest document is the next one built), so a drag gets a frame for
each update the worker manages, never a backlog.  A request marked
``preview`` (a drag in progress) may be answered approximately (a geometry
edit without its solve, see ``engine.live``); the next request that is not
a preview, even of the same document, is answered exactly.
"""

from __future__ import annotations

import threading
import traceback
from dataclasses import dataclass

import numpy as np
from PySide6.QtCore import QObject, QThread, Signal, Slot

from ..engine import LiveRepresentation, Representation
from ..model import Document


@dataclass(frozen=True, eq=False)
class Frame:
    """What the view needs after an update, safe to read on the window's thread.

    Attributes
    ----------
    document : Document
        The document this frame shows.
    representation : Representation
        Its FMR: a snapshot (later updates replace the engine's arrays, never change them).
    changed : numpy.ndarray
        ``(2^L, 2^L)`` bool: cells that differ from the previous frame (all for the first).
    kind : str
        The update's kind (see ``engine.Update``), or ``"build"``.
    exact : bool
        False while the shading is a drag's approximate preview.
    """

    document: Document
    representation: Representation
    changed: np.ndarray
    kind: str
    exact: bool = True

    @classmethod
    def first(cls, live: LiveRepresentation) -> Frame:
        """The frame of ``live`` as built: every cell changed."""
        rep = live.representation
        n = rep.lattice.cells_per_side
        return cls(live.document, rep, np.ones((n, n), bool), "build", not live.approximate)


class _Worker(QObject):
    ready = Signal(object)
    failed = Signal(str)
    progress = Signal(str, float)

    def __init__(self, live: LiveRepresentation) -> None:
        super().__init__()
        self.live = live
        self._lock = threading.Lock()
        self._pending: tuple[Document, bool] | None = None

    def post(self, document: Document, preview: bool) -> bool:
        """Make ``document`` the next to build; True if the worker was idle (it must be woken)."""
        with self._lock:
            idle = self._pending is None
            self._pending = (document, preview)
        return idle

    @Slot()
    def warm_up(self) -> None:
        self.live.warm_up()

    @Slot()
    def run(self) -> None:
        while True:
            with self._lock:
                request = self._pending
            if request is None:
                return
            document, preview = request
            try:
                update = self.live.update(document, lambda stage, fraction: self.progress.emit(stage, fraction),
                                          exact=not preview)
            except Exception as error:  # noqa: BLE001 - the window shows it; the worker must survive
                self.failed.emit(f"{error}\n{traceback.format_exc(limit=3)}")
                update = None
            with self._lock:
                if self._pending is request:
                    self._pending = None
            if update is not None:
                rep = self.live.representation
                self.ready.emit(Frame(document, rep, update.changed, update.kind, update.exact))


class EngineThread(QObject):
    """A ``LiveRepresentation`` updated on its own thread.

    Parameters
    ----------
    live : LiveRepresentation
        Built already (opening a document builds it on a worker too, see ``ui``).
        The thread first warms it up (``LiveRepresentation.warm_up``).

    Signals
    -------
    ready(Frame)
        After each finished update, on the window's thread.
    failed(str)
        An update raised; the message is for the user.
    progress(str, float)
        Stage and fraction of long work (rebuilds).
    """

    ready = Signal(object)
    failed = Signal(str)
    progress = Signal(str, float)
    _wake = Signal()
    _warm = Signal()

    def __init__(self, live: LiveRepresentation) -> None:
        super().__init__()
        self._thread = QThread()
        self._worker = _Worker(live)
        self._worker.moveToThread(self._thread)
        self._wake.connect(self._worker.run)
        self._warm.connect(self._worker.warm_up)
        self._worker.ready.connect(self.ready)
        self._worker.failed.connect(self.failed)
        self._worker.progress.connect(self.progress)
        self._thread.start()
        self._warm.emit()

    def first_frame(self) -> Frame:
        """The frame of the representation as built (call before any ``request``)."""
        return Frame.first(self._worker.live)

    def request(self, document: Document, preview: bool = False) -> None:
        """Bring the representation to ``document`` (newest request wins); ``preview``: may be approximate."""
        if self._worker.post(document, preview):
            self._wake.emit()

    def stop(self) -> None:
        """Finish the current update and end the thread."""
        self._thread.quit()
        self._thread.wait()
