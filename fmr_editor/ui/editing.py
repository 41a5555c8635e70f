"""What the window's command objects need of it, and nothing more: the document in front and room for an edit."""

from __future__ import annotations

from typing import Protocol

from ..tools import Tool
from .workspace import Workspace


class Editing(Protocol):
    """The window as its command objects see it (``MainWindow`` is one).

    Attributes
    ----------
    workspace : Workspace or None
        The document in front (None: none, or its tab is still opening).
    busy : bool
        True while that document waits for a job and takes no edits.
    tool : Tool or None
        The active tool of that document.
    """

    workspace: Workspace | None
    busy: bool
    tool: Tool | None

    def settle_edits(self) -> bool:
        """Make way for an edit (the active tool finishes); False when nothing can be edited now."""

    def update_state(self) -> None:
        """Show the document's state again: title, actions, overlay."""

    def set_tool(self, name: str) -> None:
        """Make tool ``name`` active."""

    def after_tool(self) -> None:
        """Show what a tool or a command did (overlay, the selection's stops, actions)."""

    def say(self, text: str) -> None:
        """A one-line message in the status bar."""
