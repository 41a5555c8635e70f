"""Layers and masks: a document is a stack of diffusion images composed bottom to top (docs/design.md section 5).

Each layer is a whole diffusion image (its curves and points, solved on its
own with the canvas's reflecting border).  It is drawn over what lies below
with weight ``m = opacity * clamp(M, 0, 1)``, where ``M`` is its mask's value
(1 without a mask): ``out = m S(V) + (1 - m) out_below``, ``S(V) = clamp(T(clamp(V,
0, 1)), 0, 1)`` what it shows, ``T`` its colour transform.  A mask is a diffusion image too, read through its
luminance (``MASK_LUMA``) plus a constant ``base``: white points add, points
of negative amplitude subtract, and a closed curve with white inside and
black outside is a sharp mask of its region.
"""

from __future__ import annotations

import math
import numbers
from dataclasses import dataclass, field, replace
from functools import cached_property
from itertools import repeat

import numpy as np

from .clone import Clone
from .color_transform import IDENTITY, ColorTransform
from .curve import DiffusionCurve
from .identity import checked_id, new_id
from .point import DiffusionPoint
from .refusals import EditRefused

#: Luminance weights (Rec. 709) by which a mask's colour field becomes its value.
MASK_LUMA = np.array([0.2126, 0.7152, 0.0722])
#: Most layers a document holds (files keep each layer's and mask's representation: see ``io.zip_reading``).
MAX_LAYERS = 200
#: Longest layer name, in characters.
MAX_NAME = 1000
#: Why nothing is drawn on a clone layer.
CLONE_HOLDS_NOTHING = ("a clone layer holds no curves, points or mask of its own: draw on another layer, or add a "
                       "layer above it")


def _items(owner, name: str, kind: type) -> None:
    """Check and store ``owner.name`` as a tuple of ``kind``; curves sharing an id get new ones."""
    items = tuple(getattr(owner, name))
    if not all(map(isinstance, items, repeat(kind))):  # map: 100k points in 3 ms
        raise TypeError(f"{name} must be {kind.__name__} instances")
    object.__setattr__(owner, name, _distinct_ids(items) if kind is DiffusionCurve else items)


def _number(value: object, name: str) -> float:
    if isinstance(value, bool) or not isinstance(value, numbers.Real) or not math.isfinite(value):
        raise ValueError(f"{name} must be a finite number, got {value!r}")
    return float(value) + 0.0


@dataclass(frozen=True)
class Mask:
    """A layer's mask: the luminance of a diffusion image, plus ``base``.

    Parameters
    ----------
    curves : tuple of DiffusionCurve
        Sharp edges; their colours' luminance is the mask value beside them.
    points : tuple of DiffusionPoint
        Soft dabs; white with amplitude 1 adds 1, amplitude -1 subtracts it.
    base : float
        Constant added everywhere: 1 shows the whole layer before anything
        is painted (as a new mask in Krita), 0 hides it.
    inverted : bool
        Use ``1 - value`` (before the clamp to [0, 1]).
    enabled : bool
        A disabled mask is kept but the layer is drawn as without one.
    """

    curves: tuple[DiffusionCurve, ...] = ()
    points: tuple[DiffusionPoint, ...] = ()
    base: float = 0.0
    inverted: bool = False
    enabled: bool = True

    def __post_init__(self) -> None:
        _items(self, "curves", DiffusionCurve)
        _items(self, "points", DiffusionPoint)
        object.__setattr__(self, "base", _number(self.base, "a mask's base"))
        object.__setattr__(self, "inverted", bool(self.inverted))
        object.__setattr__(self, "enabled", bool(self.enabled))

    def with_curves(self, curves) -> Mask:
        return replace(self, curves=tuple(curves))

    def with_points(self, points) -> Mask:
        return replace(self, points=tuple(points))

    @property
    def is_constant(self) -> bool:
        """True when the mask holds no curves and no points (its value is ``base`` everywhere)."""
        return not self.curves and not self.points


@dataclass(frozen=True)
class Layer:
    """One diffusion image of the stack, with how it is drawn over the layers below.

    Parameters
    ----------
    curves, points : tuple
        The layer's diffusion curves and points.
    name : str
    visible : bool
    opacity : float
        In [0, 1].
    mask : Mask, optional
    transform : ColorTransform
        Applied to the layer's colours before blending.
    clone : Clone, optional
        For a clone layer, what it shows (``model.clone``); such a layer
        holds no curves, points or mask of its own (its region is its mask).
    id : int, optional
        Stable id (``identity``), not part of the value; the engine keeps a
        layer's representation under it.
    """

    curves: tuple[DiffusionCurve, ...] = ()
    points: tuple[DiffusionPoint, ...] = ()
    name: str = "Layer 1"
    visible: bool = True
    opacity: float = 1.0
    mask: Mask | None = None
    transform: ColorTransform = IDENTITY
    clone: Clone | None = None
    id: int | None = field(default=None, compare=False)

    def __post_init__(self) -> None:
        _items(self, "curves", DiffusionCurve)
        _items(self, "points", DiffusionPoint)
        if not isinstance(self.name, str):
            raise TypeError(f"a layer's name must be text, got {self.name!r}")
        if len(self.name) > MAX_NAME:
            raise EditRefused(f"a layer's name may have at most {MAX_NAME} characters, not {len(self.name)}")
        opacity = _number(self.opacity, "opacity")
        if not 0.0 <= opacity <= 1.0:
            raise ValueError(f"opacity must lie in [0, 1], got {self.opacity!r}")
        object.__setattr__(self, "opacity", opacity)
        object.__setattr__(self, "visible", bool(self.visible))
        if self.mask is not None and not isinstance(self.mask, Mask):
            raise TypeError("a layer's mask must be a Mask")
        if not isinstance(self.transform, ColorTransform):
            raise TypeError("a layer's transform must be a ColorTransform")
        if self.clone is not None:
            if not isinstance(self.clone, Clone):
                raise TypeError("a layer's clone must be a Clone")
            if self.curves or self.points or self.mask is not None:
                raise EditRefused(CLONE_HOLDS_NOTHING)
        object.__setattr__(self, "id", checked_id(self.id))

    def with_curves(self, curves) -> Layer:
        return replace(self, curves=tuple(curves))

    def with_points(self, points) -> Layer:
        return replace(self, points=tuple(points))

    @property
    def active_mask(self) -> Mask | None:
        """The mask that shapes the layer's weight: ``mask`` when it is enabled."""
        return self.mask if self.mask is not None and self.mask.enabled else None

    @property
    def covers(self) -> bool:
        """True when the layer is drawn at full weight everywhere (visible, opaque, no mask, no stop with alpha
        below 1, not a clone)."""
        return (self.visible and self.opacity == 1.0 and self.active_mask is None and self.clone is None
                and not self.translucent)

    @property
    def empty(self) -> bool:
        """True for a layer with nothing to draw (a new layer): no curves, points, mask, colour transform or clone.
        It is clear: drawn, it shows what lies below."""
        return (not self.curves and not self.points and self.mask is None and self.transform.is_identity
                and self.clone is None)

    @cached_property
    def translucent(self) -> bool:
        """True when a colour stop of one of its curves has an alpha below 1 (``model.alpha``)."""
        return any(curve.translucent for curve in self.curves)

    @property
    def plain(self) -> bool:
        """True when drawing the layer is its image as it is: ``covers`` and no colour transform."""
        return self.covers and self.transform.is_identity


def _distinct_ids(items: tuple) -> tuple:
    """``items`` with a later item sharing an earlier one's id (one item added twice) given a new id."""
    ids = {item.id for item in items}
    if len(ids) == len(items):
        return items
    seen: set[int] = set()
    distinct = []
    for item in items:
        if item.id in seen:
            item = replace(item, id=new_id())
        seen.add(item.id)
        distinct.append(item)
    return tuple(distinct)
