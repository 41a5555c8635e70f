"""The status bar's message: what was done, or why not, said of the document at one step of its history."""

from __future__ import annotations

from collections.abc import Callable, Hashable

from PySide6.QtWidgets import QLabel


class StatusMessage(QLabel):
    """A label whose text lasts until the document shown moves to another step (``expire``).

    Parameters
    ----------
    step : callable
        The step the document shown is at, as a value equal for equal steps (None with no document).
    """

    def __init__(self, step: Callable[[], Hashable]) -> None:
        super().__init__()
        self._step = step
        self._said_at: Hashable = None

    def setText(self, text: str) -> None:  # noqa: N802 - Qt's name
        super().setText(text)
        self._said_at = self._step()

    def expire(self, standing: str = "") -> None:
        """The document moved on (an edit, an undo, a drag's end): what was said of an earlier step gives way to
        ``standing``, what the state of the window says (the mask being edited, say)."""
        if self._step() != self._said_at:
            self.setText(standing)
