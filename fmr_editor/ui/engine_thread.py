"""The engine on a worker thread: the window never waits for a solve.

The window posts each new document with ``request``; a worker thread brings
its ``LiveStack`` (the representations of every layer and mask) up to date
and hands back a ``Frame`` after every update.  While an update runs, newer requests replace older pending ones
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

from ..engine import Composite, LiveStack, Representation, Role, load_raster_kernels
from ..model import Document


@dataclass(frozen=True, eq=False)
class Frame:
    """What the view needs after an update, safe to read on the window's thread.

    Attributes
    ----------
    document : Document
        The document this frame shows.
    picture : Composite
        Its layers' representations: a snapshot (later updates replace the
        engine's arrays, never change them).
    changes : dict
        By field ``(layer id, Role)``, the ``(2^L, 2^L)`` bool
        cells that differ from the previous frame (every field, all cells, in
        the first); a field left out did not change.
    kind : str
        The update's kind (see ``engine.StackUpdate``), or ``"build"``.
    exact : bool
        False while the shading is a drag's approximate preview.
    stale : bool
        True for a preview that shows the picture before the drag (``engine.Update.stale``).
    """

    document: Document
    picture: Composite
    changes: dict[tuple[int, str], np.ndarray]
    kind: str
    exact: bool = True
    stale: bool = False

    @classmethod
    def first(cls, live: LiveStack) -> Frame:
        """The frame of ``live`` as built: every cell of every field changed."""
        picture, changes = live.composite, {}
        for layer in picture.layers:
            for kind, rep in layer.read + (((Role.BLUR, layer.blur),) if layer.blur is not None else ()):
                n = rep.lattice.cells_per_side
                changes[layer.id, kind] = np.ones((n, n), bool)
        return cls(live.document, picture, changes, "build", not live.approximate, live.stale)

    @property
    def representation(self) -> Representation:
        """The active layer's image (of a one-layer document, the picture)."""
        return self.picture.layers[self.document.active].image

    @property
    def changed(self) -> np.ndarray:
        """The cells of the active layer's image that changed (none when it did not)."""
        layer = self.document.layer
        changed = self.changes.get((layer.id, Role.IMAGE))
        if changed is None:
            n = self.representation.lattice.cells_per_side
            changed = np.zeros((n, n), bool)
        return changed


class _Worker(QObject):
    ready = Signal(object)
    failed = Signal(str)
    progress = Signal(str, float)

    def __init__(self, live: LiveStack) -> None:
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

    def drop_pending(self) -> None:
        """Forget the request waiting for the update in progress (the thread is stopping)."""
        with self._lock:
            self._pending = None

    @Slot()
    def warm_up(self) -> None:
        """The first edit's and the first CPU render's one-off costs (a save's thumbnail, a PNG export), paid
        while the user looks at the document just opened."""
        self.live.warm_up()
        load_raster_kernels()

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
                changes = {key: field.changed for key, field in update.fields.items()}
                self.ready.emit(Frame(document, self.live.composite, changes, update.kind, update.exact,
                                      update.stale))


class EngineThread(QObject):
    """A ``LiveStack`` updated on its own thread.

    Parameters
    ----------
    live : LiveStack
        Built already (opening a document builds it on a worker too, see ``ui``).
        The thread first warms it up (``LiveStack.warm_up``).

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

    def __init__(self, live: LiveStack) -> None:
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

    def set_memory(self, memory: int) -> None:
        """The bytes of recent states the representation may keep for undo (``LiveStack.memory``: the worker
        reads it at its next update, so setting it from this thread is safe)."""
        self._worker.live.memory = memory

    def set_blur(self, shown: bool, document: Document) -> None:
        """Keep the blur fields or not (``LiveStack.show_blur``: the worker reads it at its next update), and
        bring the representation to ``document`` with them."""
        self._worker.live.show_blur = shown
        self.request(document)

    def request(self, document: Document, preview: bool = False) -> None:
        """Bring the representation to ``document`` (newest request wins); ``preview``: may be approximate."""
        if self._worker.post(document, preview):
            self._wake.emit()

    def stop(self) -> None:
        """Finish the current update and end the thread (a waiting request is dropped)."""
        self._worker.drop_pending()
        self._thread.quit()
        self._thread.wait()
