"""The document: a canvas and the items drawn on it."""

from __future__ import annotations

import math
import numbers
from dataclasses import dataclass, replace
from functools import cached_property
from itertools import repeat

from .curve import DiffusionCurve
from .identity import new_id
from .point import DiffusionPoint


@dataclass(frozen=True)
class Document:
    """An immutable diffusion-curve document.

    Parameters
    ----------
    width, height : int
        Canvas size in pixels; document coordinates have their origin at the
        top-left corner, x to the right and y down.
    curves : tuple of DiffusionCurve
        The diffusion curves, in drawing order.
    points : tuple of DiffusionPoint
        Gaussian colour blobs added to the curves' image.

    Notes
    -----
    Every change produces a new ``Document`` (``with_curves``, ``with_points``).
    Items are addressed by their stable ids (``curve``, ``curve_index``).
    """

    width: int
    height: int
    curves: tuple[DiffusionCurve, ...] = ()
    points: tuple[DiffusionPoint, ...] = ()

    def __post_init__(self) -> None:
        for name in ("width", "height"):
            value = getattr(self, name)
            if not (isinstance(value, numbers.Real) and math.isfinite(value) and value == int(value) and value >= 1):
                raise ValueError(f"canvas {name} must be a positive whole number of pixels, got {value!r}")
            object.__setattr__(self, name, int(value))
        object.__setattr__(self, "curves", tuple(self.curves))
        if not all(map(isinstance, self.curves, repeat(DiffusionCurve))):  # map: 100k points in 3 ms
            raise TypeError("curves must be DiffusionCurve instances")
        object.__setattr__(self, "curves", _distinct_ids(self.curves))
        object.__setattr__(self, "points", tuple(self.points))
        if not all(map(isinstance, self.points, repeat(DiffusionPoint))):
            raise TypeError("points must be DiffusionPoint instances")

    def with_curves(self, curves) -> "Document":
        """A copy of this document holding ``curves`` instead."""
        return replace(self, curves=tuple(curves))

    def with_points(self, points) -> "Document":
        """A copy of this document holding ``points`` instead."""
        return replace(self, points=tuple(points))

    @cached_property
    def _curve_positions(self) -> dict[int, int]:
        return {curve.id: index for index, curve in enumerate(self.curves)}

    def curve_index(self, curve_id: int) -> int:
        """Position in ``curves`` of the curve with id ``curve_id``.

        Raises
        ------
        KeyError
            When no curve of this document has that id.
        """
        try:
            return self._curve_positions[curve_id]
        except KeyError:
            raise KeyError(f"no curve with id {curve_id} in this document") from None

    def curve(self, curve_id: int) -> DiffusionCurve:
        """The curve with id ``curve_id`` (``KeyError`` when there is none)."""
        return self.curves[self.curve_index(curve_id)]

    def has_curve(self, curve_id: int) -> bool:
        """True when a curve of this document has id ``curve_id``."""
        return curve_id in self._curve_positions

    def point_ids(self) -> frozenset[int]:
        """The ids of the document's points."""
        return frozenset(point.id for point in self.points)


def _distinct_ids(curves: tuple[DiffusionCurve, ...]) -> tuple[DiffusionCurve, ...]:
    """``curves`` with a later curve sharing an earlier one's id (one curve added twice) given a new id."""
    ids = {curve.id for curve in curves}
    if len(ids) == len(curves):
        return curves
    seen: set[int] = set()
    distinct = []
    for curve in curves:
        if curve.id in seen:
            curve = replace(curve, id=new_id())
        seen.add(curve.id)
        distinct.append(curve)
    return tuple(distinct)
