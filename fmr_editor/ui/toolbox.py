"""The tool bar: a button per tool with its icon, and a tooltip saying what the tool is for and its key.

The icons are SVG files in ``resources/icons`` named after each tool (drawn for
this project; see the README there); a tool whose icon is missing shows its
name instead.
"""

from __future__ import annotations

from pathlib import Path

from PySide6.QtCore import QSize, Qt
from PySide6.QtGui import QAction, QIcon
from PySide6.QtWidgets import QMainWindow, QToolBar

from ..tools import TOOLS

ICONS = Path(__file__).resolve().parents[2] / "resources" / "icons"
ICON_SIZE = 24


def tool_icon(name: str) -> QIcon:
    """The icon of tool ``name`` (a null icon when its file is missing)."""
    path = ICONS / f"{name}.svg"
    return QIcon(str(path)) if path.is_file() else QIcon()


def build_toolbox(window: QMainWindow, actions: dict[str, QAction]) -> QToolBar:
    """A tool bar of the tools' actions (``"tool:NAME"``) on the left of ``window``; the actions get their icons."""
    bar = QToolBar("Tools", window)
    bar.setObjectName("tools")  # its place is kept with the window's layout
    bar.setIconSize(QSize(ICON_SIZE, ICON_SIZE))
    for cls in TOOLS:
        action = actions[f"tool:{cls.name}"]
        action.setIcon(tool_icon(cls.name))
        bar.addAction(action)
    window.addToolBar(Qt.ToolBarArea.LeftToolBarArea, bar)
    return bar
