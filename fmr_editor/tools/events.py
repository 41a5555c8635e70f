"""Pointer events and key names, as the view hands them to a tool (no Qt).

Positions are in document pixels (x to the right, y down); the view converts
from screen coordinates and tells the tools its zoom (``ToolContext.zoom``) so
that hit tolerances stay a fixed number of screen pixels.
"""

from __future__ import annotations

from dataclasses import dataclass, field

BUTTONS = ("left", "middle", "right", "none")
MODIFIERS = frozenset({"shift", "ctrl", "alt"})

# Key names (X11 keysym spelling, as Qt's key names read without the "Key_").
ESCAPE = "Escape"
RETURN = "Return"
ENTER = "Enter"
DELETE = "Delete"
BACKSPACE = "BackSpace"
ARROWS = {"Left": (-1.0, 0.0), "Right": (1.0, 0.0), "Up": (0.0, -1.0), "Down": (0.0, 1.0)}


@dataclass(frozen=True)
class PointerEvent:
    """One press, move or release of the pointer.

    Parameters
    ----------
    position : tuple of float
        ``(x, y)`` in document pixels.
    button : str
        ``"left"``, ``"middle"`` or ``"right"``: the button pressed or
        released, or held during a move; ``"none"`` for a move with no button
        held (hovering).
    modifiers : frozenset of str
        Any of ``"shift"``, ``"ctrl"``, ``"alt"`` held at the time.
    clicks : int
        1 for a single press, 2 for the second press of a double click
        (Qt: ``mouseDoubleClickEvent``, which replaces the second press).
    """

    position: tuple[float, float]
    button: str = "left"
    modifiers: frozenset[str] = field(default_factory=frozenset)
    clicks: int = 1

    def __post_init__(self) -> None:
        x, y = (float(v) for v in self.position)
        object.__setattr__(self, "position", (x, y))
        if self.button not in BUTTONS:
            raise ValueError(f"button must be one of {BUTTONS}, got {self.button!r}")
        modifiers = frozenset(self.modifiers)
        if not modifiers <= MODIFIERS:
            raise ValueError(f"modifiers must be among {sorted(MODIFIERS)}, got {sorted(modifiers)}")
        object.__setattr__(self, "modifiers", modifiers)

    @property
    def shift(self) -> bool:
        return "shift" in self.modifiers

    @property
    def alt(self) -> bool:
        return "alt" in self.modifiers

    @property
    def ctrl(self) -> bool:
        return "ctrl" in self.modifiers
