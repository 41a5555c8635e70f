"""The engine on a worker thread: the window never waits for a solve.

The window posts each new document with ``request``; a worker thread brings
its ``LiveRepresentation`` up to date and hands back a ``Frame``.  While an
update runs, newer requests replace older pending ones: the newest document
wins and intermediate ones are skipped (their changes are folded into the
next update, which diffs against the last document it built).
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
        Its FMR (segment arrays are replaced, never changed, by later updates).
    polynomials : numpy.ndarray
        ``representation.polynomials()``, computed on the worker: a private copy.
    changed : numpy.ndarray
        ``(2^L, 2^L)`` bool: cells that differ from the previous frame (all for the first).
    kind : str
        The update's kind (see ``engine.Update``), or ``"build"``.
    """

    document: Document
    representation: Representation
    polynomials: np.ndarray
    changed: np.ndarray
    kind: str


class _Worker(QObject):
    ready = Signal(object)
    failed = Signal(str)
    progress = Signal(str, float)

    def __init__(self, live: LiveRepresentation) -> None:
        super().__init__()
        self.live = live
        self._lock = threading.Lock()
        self._pending: Document | None = None

    def post(self, document: Document) -> bool:
        """Make ``document`` the next to build; True if the worker was idle (it must be woken)."""
        with self._lock:
            idle = self._pending is None
            self._pending = document
        return idle

    @Slot()
    def run(self) -> None:
        changed = None
        while True:
            with self._lock:
                document = self._pending
            if document is None:
                return
            try:
                update = self.live.update(document, lambda stage, fraction: self.progress.emit(stage, fraction))
            except Exception as error:  # noqa: BLE001 - the window shows it; the worker must survive
                self.failed.emit(f"{error}\n{traceback.format_exc(limit=3)}")
                with self._lock:
                    if self._pending is document:
                        self._pending = None
                continue
            changed = update.changed if changed is None or changed.shape != update.changed.shape else changed | update.changed
            with self._lock:
                if self._pending is not document:
                    continue  # a newer document came: fold this update into the next frame
                self._pending = None
            rep = self.live.representation
            self.ready.emit(Frame(document, rep, rep.polynomials(), changed, update.kind))
            changed = None


class EngineThread(QObject):
    """A ``LiveRepresentation`` updated on its own thread.

    Parameters
    ----------
    live : LiveRepresentation
        Built already (opening a document builds it on a worker too, see ``ui``).

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

    def __init__(self, live: LiveRepresentation) -> None:
        super().__init__()
        self._thread = QThread()
        self._worker = _Worker(live)
        self._worker.moveToThread(self._thread)
        self._wake.connect(self._worker.run)
        self._worker.ready.connect(self.ready)
        self._worker.failed.connect(self.failed)
        self._worker.progress.connect(self.progress)
        self._thread.start()

    def first_frame(self) -> Frame:
        """The frame of the representation as built (call before any ``request``)."""
        live = self._worker.live
        rep = live.representation
        n = rep.lattice.cells_per_side
        return Frame(live.document, rep, rep.polynomials(), np.ones((n, n), bool), "build")

    def request(self, document: Document) -> None:
        """Bring the representation to ``document`` (newest request wins)."""
        if self._worker.post(document):
            self._wake.emit()

    def stop(self) -> None:
        """Finish the current update and end the thread."""
        self._thread.quit()
        self._thread.wait()
