"""Undo history: the document's one mutation path.

A ``History`` holds the sequence of documents that edits produced, with a
label per step ("Move Stop").  Undo, redo and jumps move along it; a new edit
after an undo drops the undone steps.  A drag is a *transaction*: ``begin``,
any number of ``preview`` documents (shown, not recorded), then ``commit``
(one step) or ``cancel`` (back to the state before it).  Listeners are told
of every change of the current document as ``listener(before, after)``;
step listeners (``subscribe_steps``) of every change of the recorded steps,
the current step or the saved mark, and of every transaction's end (a drag's
commit changes no document that is shown but adds a step).
"""

from __future__ import annotations

from collections.abc import Callable, Hashable

from .document import Document

Listener = Callable[[Document, Document], None]


class History:
    """The documents an editing session went through.

    Parameters
    ----------
    document : Document
        The starting state (step 0, not undoable).
    """

    def __init__(self, document: Document) -> None:
        self._documents = [document]
        self._labels = [""]
        self._merge_keys: list[Hashable | None] = [None]
        self._index = 0
        self._saved: int | None = 0
        self._preview: Document | None = None
        self._pending: str | None = None
        self._listeners: list[Listener] = []
        self._step_listeners: list[Callable[[], None]] = []

    # -- observing ---------------------------------------------------------------------------
    def subscribe(self, listener: Listener) -> None:
        """Call ``listener(before, after)`` whenever the current document changes."""
        self._listeners.append(listener)

    def subscribe_steps(self, listener: Callable[[], None]) -> None:
        """Call ``listener()`` whenever the steps, their labels, the current step or the saved mark change,
        and when a transaction ends."""
        self._step_listeners.append(listener)

    def unsubscribe(self, listener: Listener) -> None:
        """Stop calling ``listener`` (given to ``subscribe``; nothing when it was not)."""
        if listener in self._listeners:
            self._listeners.remove(listener)

    def unsubscribe_steps(self, listener: Callable[[], None]) -> None:
        """Stop calling ``listener`` (given to ``subscribe_steps``; nothing when it was not)."""
        if listener in self._step_listeners:
            self._step_listeners.remove(listener)

    def _steps_changed(self) -> None:
        for listener in list(self._step_listeners):
            listener()

    def _show(self, before: Document) -> None:
        after = self.document
        if after is not before:
            for listener in list(self._listeners):
                listener(before, after)

    @property
    def document(self) -> Document:
        """The current document (a transaction's preview while one is open)."""
        return self._preview if self._preview is not None else self._documents[self._index]

    # -- recording ---------------------------------------------------------------------------
    def apply(self, document: Document, label: str, merge_key: Hashable | None = None) -> None:
        """Make ``document`` current as a new step named ``label``.

        A step whose ``merge_key`` equals the previous step's (and is not
        None) replaces it instead, so that e.g. dragging a colour slider
        stays one step.  Applying the current document records nothing.
        """
        if self._pending is not None:
            raise RuntimeError("finish the open transaction before applying another edit")
        before = self.document
        if document != before:
            self._record(document, label, merge_key)
            self._show(before)

    def _record(self, document: Document, label: str, merge_key: Hashable | None, notify: bool = True) -> None:
        del self._documents[self._index + 1 :], self._labels[self._index + 1 :], self._merge_keys[self._index + 1 :]
        if self._saved is not None and self._saved > self._index:
            self._saved = None  # the saved state is no longer reachable
        if merge_key is not None and self._index > 0 and self._merge_keys[self._index] == merge_key:
            self._documents[self._index] = document
            if self._saved == self._index:
                self._saved = None
        else:
            self._documents.append(document)
            self._labels.append(label)
            self._merge_keys.append(merge_key)
            self._index += 1
        if notify:
            self._steps_changed()

    def retarget(self, document: Document) -> None:
        """Make ``document`` current in place of the current step's, without a step.

        For what the tools act on (the active layer, mask editing): choosing
        a layer is no edit, as in Krita.  ``document`` must hold the same
        canvas and layers as the current one.
        """
        if self._pending is not None:
            raise RuntimeError("finish the open transaction before choosing another layer")
        before = self.document
        if (document.width, document.height, document.layers) != (before.width, before.height, before.layers):
            raise ValueError("retarget changes only the active layer and mask editing")
        self._documents[self._index] = document
        self._show(before)

    def begin(self, label: str) -> None:
        """Open a transaction (a drag) that ``commit`` records as one step named ``label``."""
        if self._pending is not None:
            raise RuntimeError("a transaction is already open")
        self._pending = label

    def preview(self, document: Document) -> None:
        """Show ``document`` as the open transaction's current state, without recording it."""
        if self._pending is None:
            raise RuntimeError("preview needs an open transaction (begin)")
        before = self.document
        self._preview = document
        self._show(before)

    def commit(self) -> None:
        """Record the transaction's last preview as one step (nothing if it changed nothing)."""
        label, final = self._finish()
        if final is not None and final != self._documents[self._index]:
            self._record(final, label, None, notify=False)  # document listeners already show it
        self._steps_changed()  # a step, or at least the transaction's end

    def cancel(self) -> None:
        """Drop the open transaction and return to the document before it."""
        _, final = self._finish()
        if final is not None:
            self._show(final)
        self._steps_changed()

    def _finish(self) -> tuple[str, Document | None]:
        if self._pending is None:
            raise RuntimeError("no transaction is open")
        label, final = self._pending, self._preview
        self._pending, self._preview = None, None
        return label, final

    @property
    def in_transaction(self) -> bool:
        """True between ``begin`` and ``commit`` or ``cancel`` (a drag in progress)."""
        return self._pending is not None

    # -- moving ------------------------------------------------------------------------------
    @property
    def index(self) -> int:
        """The current step (0 is the starting state)."""
        return self._index

    @property
    def labels(self) -> tuple[str, ...]:
        """Every step's label; ``labels[0]`` is the starting state's (empty)."""
        return tuple(self._labels)

    @property
    def step_count(self) -> int:
        """``len(labels)``, without the copy."""
        return len(self._labels)

    @property
    def can_undo(self) -> bool:
        return self._pending is None and self._index > 0

    @property
    def can_redo(self) -> bool:
        return self._pending is None and self._index < len(self._documents) - 1

    @property
    def undo_label(self) -> str | None:
        """Label of the step ``undo`` reverts, or None."""
        return self._labels[self._index] if self.can_undo else None

    @property
    def redo_label(self) -> str | None:
        """Label of the step ``redo`` replays, or None."""
        return self._labels[self._index + 1] if self.can_redo else None

    def jump(self, index: int) -> None:
        """Make step ``index`` current (undoing or redoing every step in between)."""
        if self._pending is not None:
            raise RuntimeError("finish the open transaction first")
        if not 0 <= index < len(self._documents):
            raise IndexError(f"no step {index}: the history has steps 0 to {len(self._documents) - 1}")
        before = self.document
        moved, self._index = index != self._index, index
        self._show(before)
        if moved:
            self._steps_changed()

    def undo(self) -> None:
        """Revert the last step; nothing when there is none."""
        if self.can_undo:
            self.jump(self._index - 1)

    def redo(self) -> None:
        """Replay the next undone step; nothing when there is none."""
        if self.can_redo:
            self.jump(self._index + 1)

    # -- saving ------------------------------------------------------------------------------
    def mark_saved(self) -> None:
        """Remember the current step as the one on disk."""
        self._saved = self._index
        self._steps_changed()

    def mark_unsaved(self) -> None:
        """Forget the step on disk: no step is saved (a document recovered from an autosave)."""
        self._saved = None
        self._steps_changed()

    @property
    def modified(self) -> bool:
        """True when the current document differs from the last saved step."""
        return self._saved != self._index or self._preview is not None
