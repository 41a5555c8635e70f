"""What the window's command objects need of it, and nothing more: the document in front and room for an edit."""

from __future__ import annotations

from typing import Protocol

from .workspace import Workspace


class Editing(Protocol):
    """The window as its command objects see it (``MainWindow`` is one).

    Attributes
    ----------
    workspace : Workspace or None
        The document in front (None: none, or its tab is still opening).
    busy : bool
        True while that document waits for a job and takes no edits.
    """

    workspace: Workspace | None
    busy: bool

    def settle_edits(self) -> bool:
        """Make way for an edit (the active tool finishes); False when nothing can be edited now."""

    def update_state(self) -> None:
        """Show the document's state again: title, actions, overlay."""
