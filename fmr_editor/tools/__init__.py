"""Tools: pointer events turned into document edits, without Qt.

Each tool takes a ``ToolContext`` (history, selection, zoom, options, colour
sampler) and gets ``press``, ``move``, ``release`` (``PointerEvent``), ``key``
(a key name; returns whether it was used), ``cancel`` (Esc, focus lost),
``finish`` (switching tools) and ``overlay()`` (primitives from
``tools.overlay`` to draw).  A drag is one undo step; cancelling it restores
the document from before it.

>>> from fmr_editor.model import Document
>>> from fmr_editor.model.history import History
>>> context = ToolContext(History(Document(64, 64)))
>>> tools = create_tools(context)
>>> sorted(tools)
['brush', 'clone', 'eyedropper', 'lasso', 'pen', 'select', 'stops']
"""

from __future__ import annotations

from .actions import delete_selection, nudge, recolor_stops, set_blur_stops
from .base import Drag, EditDrag, Tool
from .brush import BrushTool
from .context import Selection, ToolContext, ToolOptions
from .events import PointerEvent
from .eyedropper import EyedropperTool
from .lasso import LassoTool
from .pen import PenTool
from .select import SelectTool
from .stops import StopsTool
from .transform import CloneTool

TOOLS: tuple[type[Tool], ...] = (SelectTool, PenTool, StopsTool, BrushTool, EyedropperTool, LassoTool, CloneTool)
"""The tool classes in toolbar order."""


def create_tools(context: ToolContext) -> dict[str, Tool]:
    """One instance of every tool, by ``name``, sharing ``context``."""
    return {cls.name: cls(context) for cls in TOOLS}


__all__ = [
    "TOOLS", "BrushTool", "CloneTool", "Drag", "EditDrag", "EyedropperTool", "LassoTool", "PenTool", "PointerEvent",
    "SelectTool", "Selection", "StopsTool", "Tool", "ToolContext", "ToolOptions", "create_tools", "delete_selection",
    "nudge", "recolor_stops", "set_blur_stops",
]
