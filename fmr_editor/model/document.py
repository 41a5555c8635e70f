"""The document: a canvas and its stack of layers, with the active layer (or its mask) as the tools' target."""

from __future__ import annotations

import math
import numbers
from dataclasses import dataclass, replace
from functools import cached_property

from .curve import DiffusionCurve
from .identity import new_id
from .layer import MAX_LAYERS, Layer, Mask
from .point import DiffusionPoint
from .refusals import EditRefused


@dataclass(frozen=True, init=False)
class Document:
    """An immutable diffusion-curve document: a canvas and a stack of layers.

    Parameters
    ----------
    width, height : int
        Canvas size in pixels; document coordinates have their origin at the
        top-left corner, x to the right and y down.
    curves, points : tuple, optional
        The items of a one-layer document (``Document(w, h, curves, points)``);
        not with ``layers``.
    layers : tuple of Layer, optional
        The stack, bottom first (``layer``); one layer when omitted.
    active : int
        Index of the layer the tools act on.
    editing_mask : bool
        True when the tools act on the active layer's mask instead.

    Notes
    -----
    ``curves`` and ``points`` are those of the *target*: the active layer, or
    its mask while ``editing_mask``; ``with_curves`` and ``with_points``
    replace them there.  So every edit and tool written for one image works
    on whichever layer or mask is active.  Every change produces a new
    ``Document``.  Items are addressed by their stable ids (``curve``,
    ``curve_index``), which are unique within a layer or mask.
    """

    width: int
    height: int
    layers: tuple[Layer, ...]
    active: int
    editing_mask: bool

    def __init__(self, width: int, height: int, curves=(), points=(), *, layers=None, active: int = 0,
                 editing_mask: bool = False) -> None:
        for name, value in (("width", width), ("height", height)):
            if not (isinstance(value, numbers.Real) and math.isfinite(value) and value == int(value) and value >= 1):
                raise ValueError(f"canvas {name} must be a positive whole number of pixels, got {value!r}")
        if layers is None:
            layers = (Layer(curves, points),)
        elif curves or points:
            raise TypeError("give a document either curves and points or layers, not both")
        layers = _distinct_layer_ids(tuple(layers))
        if not layers or not all(isinstance(layer, Layer) for layer in layers):
            raise TypeError("a document's layers must be one or more Layer instances")
        if len(layers) > MAX_LAYERS:
            raise EditRefused(f"a document holds at most {MAX_LAYERS} layers, not {len(layers)}")
        if isinstance(active, bool) or not isinstance(active, numbers.Integral) or not 0 <= active < len(layers):
            raise ValueError(f"the active layer must be an index below {len(layers)}, got {active!r}")
        if editing_mask and layers[active].mask is None:
            raise ValueError("the active layer has no mask to edit")
        for name, value in (("width", int(width)), ("height", int(height)), ("layers", layers),
                            ("active", int(active)), ("editing_mask", bool(editing_mask))):
            object.__setattr__(self, name, value)

    @property
    def layer(self) -> Layer:
        """The active layer."""
        return self.layers[self.active]

    @property
    def target(self) -> Layer | Mask:
        """What the tools act on: the active layer, or its mask while ``editing_mask``."""
        return self.layer.mask if self.editing_mask else self.layer

    @property
    def curves(self) -> tuple[DiffusionCurve, ...]:
        """The target's curves."""
        return self.target.curves

    @property
    def points(self) -> tuple[DiffusionPoint, ...]:
        """The target's points."""
        return self.target.points

    def with_target(self, target: Layer | Mask) -> Document:
        """A copy with ``target`` in place of the current target."""
        layer = replace(self.layer, mask=target) if self.editing_mask else target
        return self.with_layer(self.active, layer)

    def with_layer(self, index: int, layer: Layer) -> Document:
        """A copy with ``layer`` at ``index`` of the stack."""
        layers = self.layers[:index] + (layer,) + self.layers[index + 1 :]
        return replace(self, layers=layers, editing_mask=self.editing_mask and layers[self.active].mask is not None)

    def with_curves(self, curves) -> Document:
        """A copy whose target holds ``curves`` instead."""
        return self.with_target(self.target.with_curves(curves))

    def with_points(self, points) -> Document:
        """A copy whose target holds ``points`` instead."""
        return self.with_target(self.target.with_points(points))

    @property
    def is_flat(self) -> bool:
        """True for one plain layer (what documents were before layers): its image is the picture."""
        return len(self.layers) == 1 and self.layers[0].plain

    def flat(self, target: Layer | Mask) -> Document:
        """A one-layer document of ``target``'s curves and points on this canvas (what the engine solves).

        The same target on the same canvas gives the same object: the engine
        recognises a document it has seen (undo) by identity.
        """
        memo = target.__dict__.setdefault("_flat_documents", {})  # not a field: no part of the target's value
        key = (self.width, self.height)
        if key not in memo:
            memo[key] = Document(self.width, self.height, target.curves, target.points)
        return memo[key]

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


def _distinct_layer_ids(layers: tuple[Layer, ...]) -> tuple[Layer, ...]:
    """``layers`` with a later layer sharing an earlier one's id (one layer added twice) given a new id."""
    seen: set[int] = set()
    distinct = []
    for layer in layers:
        if getattr(layer, "id", None) in seen:
            layer = replace(layer, id=new_id())
        seen.add(getattr(layer, "id", None))
        distinct.append(layer)
    return tuple(distinct)
