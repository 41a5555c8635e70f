"""Scripted editing: a document, its undo history and its live FMR, without Qt.

>>> from fmr_editor.session import Session
>>> from fmr_editor.model import edits
>>> session = Session.open("lady_bug.xml")                       # doctest: +SKIP
>>> session.apply(lambda d: edits.set_stop_color(d, d.curves[3].id, "left", 0, (1, 0, 0)),
...               "Change Stop Colour")                           # doctest: +SKIP
>>> session.undo(); session.redo()                                # doctest: +SKIP
>>> session.save_png("red.png", width=512)                        # doctest: +SKIP

The editor drives the same object: tools apply edits (a drag through the
history's ``begin``/``preview``/``commit``), and every change of the current
document, undo and redo included, updates the representations of the layers
it touches incrementally; ``last_update`` says which.  Layer edits are in
``model.layer_edits``; ``image`` renders the composite of all layers.
"""

from __future__ import annotations

import os
from collections.abc import Callable, Hashable
from pathlib import Path

import numpy as np

from .engine import LiveStack, Progress, Representation, Settings, StackUpdate, rasterise
from .io import open_live, save_fmr
from .io.png import save_png
from .model import Document
from .model.history import History

Edit = Callable[[Document], Document]


class Session:
    """An editing session on one document.

    Parameters
    ----------
    document : Document
    settings : Settings
    progress : callable, optional
        ``progress(stage, fraction)`` during the first build and rebuilds.
    saved : sequence, optional
        Per layer, ``(image, mask)`` representations as saved, taken instead of builds.

    Attributes
    ----------
    history : History
        The undo history; changing its current document updates the FMR.
    live : LiveStack
        The representations of the document's layers and masks, kept up to date.
    last_update : StackUpdate or None
        What the most recent change did (None before any).
    """

    def __init__(self, document: Document, settings: Settings = Settings(), progress: Progress | None = None,
                 saved: tuple[tuple[Representation | None, Representation | None], ...] | None = None) -> None:
        self._adopt(LiveStack(document, settings, progress, saved), progress)

    def _adopt(self, live: LiveStack, progress: Progress | None) -> None:
        self.history = History(live.document)
        self._progress = progress
        self.live = live
        self.last_update: StackUpdate | None = None
        self.history.subscribe(self._follow)

    @classmethod
    def open(cls, path: str | os.PathLike, settings: Settings = Settings()) -> Session:
        """A session on the document in ``path`` (raises ``io.DocumentLoadError``).

        A ``.fmr`` file's saved representation is taken as it is (no solve).
        """
        return cls.resume(open_live(path, settings))

    @classmethod
    def resume(cls, live: LiveStack) -> Session:
        """A session on ``live``'s document, taking ``live`` as it is."""
        session = cls.__new__(cls)
        session._adopt(live, None)
        return session

    def _follow(self, before: Document, after: Document) -> None:
        self.last_update = self.live.update(after, self._progress)

    @property
    def document(self) -> Document:
        return self.history.document

    @property
    def representation(self) -> Representation:
        """The active layer's image (of a one-layer document, the picture)."""
        return self.live.representation

    def apply(self, edit: Edit | Document, label: str, merge_key: Hashable | None = None) -> StackUpdate | None:
        """Apply ``edit`` (a function of the document, or the new document) as one undo step.

        Returns
        -------
        StackUpdate or None
            What the engine did; None when the edit changed nothing.
        """
        document = edit(self.document) if callable(edit) else edit
        self.last_update = None
        self.history.apply(document, label, merge_key)
        return self.last_update

    def undo(self) -> StackUpdate | None:
        """Undo the last step (nothing when there is none)."""
        self.last_update = None
        self.history.undo()
        return self.last_update

    def redo(self) -> StackUpdate | None:
        """Redo the next undone step (nothing when there is none)."""
        self.last_update = None
        self.history.redo()
        return self.last_update

    def image(self, width: int | None = None, height: int | None = None, samples: int = 3,
              blur: bool = True) -> np.ndarray:
        """The picture (all layers composed, each clamped to [0, 1]) ``(height, width, 3)``, as ``engine.rasterise``:
        each layer softened by its curves' blur stops (the first time solves the blur fields, which then follow
        the edits), or with ``blur=False`` every edge sharp."""
        if blur and not self.live.show_blur:
            self.live.set_blur(True, self._progress)
        picture = self.live.composite
        return rasterise(picture if blur else picture.sharp, width, height, samples=samples)

    def cells(self, order: int | None = None) -> np.ndarray:
        """The active layer's cell polynomials ``c[row, column, channel, i, j]`` (``Representation.polynomials``)."""
        return self.representation.polynomials(order)

    def save(self, path: str | os.PathLike) -> Path:
        """Save the document with its representation as ``.fmr`` (atomically) and mark it saved."""
        written = save_fmr(path, self.document, self.live.composite, settings=self.live.settings)
        self.history.mark_saved()
        return written

    def save_png(self, path: str | os.PathLike, width: int | None = None, height: int | None = None,
                 samples: int = 3, blur: bool = True) -> Path:
        """Render the current image (``image``) and write it to ``path`` as a PNG."""
        return save_png(self.image(width, height, samples, blur), path)
