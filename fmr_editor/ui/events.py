"""Qt's buttons, modifiers and keys in the tools' terms (``tools.PointerEvent``, key names)."""

from __future__ import annotations

from PySide6.QtCore import Qt

from ..tools import PointerEvent

_BUTTONS = (
    (Qt.MouseButton.LeftButton, "left"),
    (Qt.MouseButton.RightButton, "right"),
    (Qt.MouseButton.MiddleButton, "middle"),
)
_MODIFIERS = (
    (Qt.KeyboardModifier.ShiftModifier, "shift"),
    (Qt.KeyboardModifier.ControlModifier, "ctrl"),
    (Qt.KeyboardModifier.AltModifier, "alt"),
)

#: Keys the active tool sees before any menu shortcut, by their tool names.
TOOL_KEYS = {
    Qt.Key.Key_Escape: "Escape",
    Qt.Key.Key_Return: "Return",
    Qt.Key.Key_Enter: "Enter",
    Qt.Key.Key_Delete: "Delete",
    Qt.Key.Key_Backspace: "BackSpace",
    Qt.Key.Key_Left: "Left",
    Qt.Key.Key_Right: "Right",
    Qt.Key.Key_Up: "Up",
    Qt.Key.Key_Down: "Down",
}


def button_name(buttons) -> str:
    """``"left"``, ``"right"``, ``"middle"`` or ``"none"`` for ``Qt.MouseButton`` flags (left first)."""
    for flag, name in _BUTTONS:
        if buttons & flag:
            return name
    return "none"


def modifier_names(modifiers) -> frozenset[str]:
    """``Qt.KeyboardModifier`` flags as the tools' modifier names."""
    return frozenset(name for flag, name in _MODIFIERS if modifiers & flag)


def pointer_event(x: float, y: float, buttons, modifiers, clicks: int = 1) -> PointerEvent:
    """A ``tools.PointerEvent`` from the canvas's signal arguments."""
    return PointerEvent((x, y), button_name(buttons), modifier_names(modifiers), clicks)


def tool_key(key) -> str | None:
    """The tool name of ``Qt.Key`` ``key``, or None for keys the tools do not take."""
    try:
        return TOOL_KEYS.get(Qt.Key(key))
    except ValueError:
        return None
