"""Diffusion points: Gaussian colour blobs added to the image.

A point at ``x_i`` adds ``amplitude * colour * exp(-|x - x_i|^2 / radius^2)``
to each channel, in document pixels (x to the right, y down).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from .identity import checked_id
from .limits import MAX_COLOR

Color = tuple[float, float, float]


@dataclass(frozen=True)
class DiffusionPoint:
    """An immutable diffusion point.

    Parameters
    ----------
    position : tuple of float
        Centre ``(x, y)`` in document pixels (may lie outside the canvas).
    radius : float
        Gaussian radius ``r > 0`` in pixels: the blob is ``exp(-d^2 / r^2)``.
    color : tuple of float
        sRGB red, green, blue, normally in ``[0, 1]``.
    amplitude : float
        Multiplies the colour; negative values subtract.
    id : int, optional
        The point's stable id (``identity``); a new one when omitted.  Not
        part of the point's value (equality and hash).
    """

    position: tuple[float, float]
    radius: float
    color: Color
    amplitude: float = 1.0
    id: int | None = field(default=None, compare=False)

    def __post_init__(self) -> None:
        position = _floats(self.position, 2, "position")
        color = _floats(self.color, 3, "color")
        radius = _finite(self.radius, "radius")
        if not radius > 0.0:
            raise ValueError(f"radius must be positive, got {radius!r}")
        # + 0.0 turns -0.0 into 0.0, so equal points hash equally
        object.__setattr__(self, "position", tuple(v + 0.0 for v in position))
        object.__setattr__(self, "color", tuple(v + 0.0 for v in color))
        object.__setattr__(self, "radius", radius)
        amplitude = _finite(self.amplitude, "amplitude")
        if max(abs(amplitude), *map(abs, color)) > MAX_COLOR:
            raise ValueError(f"a point's colour and amplitude must be at most {MAX_COLOR:g} in size")
        object.__setattr__(self, "amplitude", amplitude + 0.0)
        object.__setattr__(self, "id", checked_id(self.id))


def _finite(value, name: str) -> float:
    try:
        number = float(value)
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be a number, got {value!r}") from None
    if not math.isfinite(number):
        raise ValueError(f"{name} must be finite, got {value!r}")
    return number


def _floats(values, count: int, name: str) -> tuple[float, ...]:
    try:
        items = tuple(values)
    except TypeError:
        raise ValueError(f"{name} must be {count} numbers, got {values!r}") from None
    if len(items) != count:
        raise ValueError(f"{name} must be {count} numbers, got {len(items)}")
    return tuple(_finite(v, name) for v in items)
