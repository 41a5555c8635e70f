"""Edits of the layer stack: functions from a document to a new document, one undo step each.

Layers are addressed by their index in ``Document.layers`` (bottom first), as
a Layers panel lists them; the active layer follows its layer through moves
and deletions.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from .color_transform import IDENTITY, ColorTransform
from .curve import ColorStop
from .document import Document
from .layer import Layer, Mask
from .refusals import EditRefused


def _index(document: Document, index: int | None) -> int:
    index = document.active if index is None else index
    if not 0 <= index < len(document.layers):
        raise IndexError(f"no layer {index}; the document has {len(document.layers)}")
    return index


def _changed(document: Document, index: int | None, **fields) -> Document:
    index = _index(document, index)
    return document.with_layer(index, replace(document.layers[index], **fields))


def new_layer_name(document: Document) -> str:
    """``"Layer N"`` with the smallest ``N`` above every layer count and no name taken."""
    names = {layer.name for layer in document.layers}
    n = len(document.layers) + 1
    while f"Layer {n}" in names:
        n += 1
    return f"Layer {n}"


def add_layer(document: Document, layer: Layer | None = None) -> Document:
    """``layer`` (an empty one by default) above the active layer, made active."""
    layer = Layer(name=new_layer_name(document)) if layer is None else layer
    at = document.active + 1
    return replace(document, layers=document.layers[:at] + (layer,) + document.layers[at:], active=at,
                   editing_mask=False)


def duplicate_layer(document: Document, index: int | None = None) -> Document:
    """A copy of layer ``index`` (the active one by default) above it, named "... copy", made active."""
    index = _index(document, index)
    original = document.layers[index]
    copy = replace(original, name=f"{original.name} copy", id=None)
    moved = replace(document, active=index, editing_mask=False)
    return add_layer(moved, copy)


def remove_layer(document: Document, index: int | None = None) -> Document:
    """The document without layer ``index``; the one below (or above, for the bottom layer) becomes active."""
    index = _index(document, index)
    if len(document.layers) == 1:
        raise EditRefused("a document keeps at least one layer")
    layers = document.layers[:index] + document.layers[index + 1 :]
    active = document.active if document.active < index else max(document.active - 1, 0)
    return replace(document, layers=layers, active=active, editing_mask=False)


def move_layer(document: Document, index: int, to: int) -> Document:
    """Layer ``index`` moved to position ``to`` of the stack; the active layer stays the same layer."""
    index = _index(document, index)
    to = _index(document, to)
    order = list(range(len(document.layers)))
    order.insert(to, order.pop(index))
    return replace(document, layers=tuple(document.layers[i] for i in order), active=order.index(document.active))


def select_layer(document: Document, index: int, mask: bool = False) -> Document:
    """Layer ``index`` made the tools' target, or its mask when ``mask``."""
    return replace(document, active=_index(document, index), editing_mask=mask)


def rename_layer(document: Document, index: int | None, name: str) -> Document:
    return _changed(document, index, name=str(name))


def set_visible(document: Document, index: int | None, visible: bool) -> Document:
    return _changed(document, index, visible=bool(visible))


def set_opacity(document: Document, index: int | None, opacity: float) -> Document:
    """Opacity in [0, 1] (``ValueError`` otherwise, NaN included)."""
    return _changed(document, index, opacity=opacity)


def set_transform(document: Document, index: int | None, transform: ColorTransform) -> Document:
    return _changed(document, index, transform=transform)


def add_mask(document: Document, index: int | None = None, mask: Mask | None = None) -> Document:
    """Layer ``index`` given ``mask``: by default an empty one of base 1, which shows the whole layer."""
    return _changed(document, index, mask=Mask(base=1.0) if mask is None else mask)


def remove_mask(document: Document, index: int | None = None) -> Document:
    return _changed(document, index, mask=None)


def _mask_changed(document: Document, index: int | None, **fields) -> Document:
    mask = document.layers[_index(document, index)].mask
    if mask is None:
        raise EditRefused("the layer has no mask")
    return _changed(document, index, mask=replace(mask, **fields))


def invert_mask(document: Document, index: int | None = None) -> Document:
    mask = document.layers[_index(document, index)].mask
    return _mask_changed(document, index, inverted=not (mask is not None and mask.inverted))


def set_mask_enabled(document: Document, index: int | None, enabled: bool) -> Document:
    return _mask_changed(document, index, enabled=enabled)


def baked(layer: Layer) -> Layer:
    """``layer`` with its colour transform applied to its items' colours (the same image) and none left.

    Exact: the image is linear in the colours and a constant diffuses to
    itself, so ``T`` of every curve's stops (a side without stops is black)
    gives ``T(V)`` of the curves, and ``A`` of every point's colour adds ``A``
    of its blob.
    """
    transform = layer.transform
    if transform.is_identity:
        return layer

    def stops(side: tuple[ColorStop, ...]) -> tuple[ColorStop, ...]:
        side = side or (ColorStop(0.0, (0.0, 0.0, 0.0)),)
        return tuple(replace(stop, color=tuple(transform.apply(stop.color))) for stop in side)

    curves = tuple(replace(curve, left=stops(curve.left), right=stops(curve.right)) for curve in layer.curves)
    points = tuple(replace(point, color=tuple(transform.matrix @ point.color)) for point in layer.points)
    if not layer.curves and transform.offset.any():  # no curve to carry the offset: the layer stays as it is
        return layer
    return replace(layer, curves=curves, points=points, transform=IDENTITY)


def merge_down(document: Document, index: int | None = None) -> Document:
    """Layer ``index`` (the active one) and the one below it made one layer, named as the lower one.

    The items of both are kept, colour transforms applied to them
    (``baked``).  The curves of both then diffuse together, so the picture
    changes where the two layers' images met: merging is a change of the
    drawing, not of pixels.

    Raises
    ------
    EditRefused
        For the bottom layer (nothing below), a clone layer, a hidden layer, either layer with a mask, an
        opacity below 1 or stops with alpha below 1 (the upper one's merged items cannot keep them; the lower
        one's would then weigh the upper one's items too), or a layer whose transform cannot be applied to its
        items (a colour offset with no curve to carry it, as a Paint layer's): every one of these last that
        holds, at once.
    """
    index = _index(document, index)
    if index == 0:
        raise EditRefused("the bottom layer has no layer below to merge into")
    for layer in document.layers[index - 1 : index + 1]:
        if layer.clone is not None:
            raise EditRefused(f"{layer.name} is a clone layer, made anew from the layers below it: it cannot be merged")
    upper, lower = baked(document.layers[index]), baked(document.layers[index - 1])
    if not (upper.visible and lower.visible):
        raise EditRefused("show both layers to merge them (a hidden layer's items would appear or vanish)")
    reasons = []
    if upper.active_mask is not None or upper.opacity < 1.0:
        reasons.append(f"{upper.name}'s mask and opacity cannot be kept by merging its items: "
                       "delete or disable the mask and set the opacity to 100% first")
    if upper.translucent:
        reasons.append(f"{upper.name}'s curves have colour stops with alpha below 1, which merged items "
                       "cannot keep: make them opaque first")
    weighing = [kind for kind, holds in (("mask", lower.active_mask is not None),
                                         ("opacity below 100%", lower.opacity < 1.0),
                                         ("colour stops with alpha below 1", lower.translucent)) if holds]
    if weighing:
        reasons.append(f"{lower.name}'s {' and '.join(weighing)} would weigh {upper.name}'s items too once "
                       "merged")
    reasons += [f"{layer.name}'s colour transform shifts colours but it has no curve to carry the shift "
                "(a Paint layer, say): it cannot be merged" for layer in (upper, lower)
                if not layer.transform.is_identity]
    if reasons:
        raise EditRefused("; ".join(reasons))
    merged = replace(lower, curves=lower.curves + upper.curves, points=lower.points + upper.points)
    layers = document.layers[: index - 1] + (merged,) + document.layers[index + 1 :]
    active = document.active - (document.active >= index)
    return replace(document, layers=layers, active=active, editing_mask=False)


def flatten(document: Document) -> Document:
    """The visible layers merged into one (``merge_down`` from the top down, refusing as it does); hidden
    layers are dropped.

    Raises
    ------
    EditRefused
        When no layer is visible, or as ``merge_down``.
    """
    visible = tuple(layer for layer in document.layers if layer.visible)
    if not visible:
        raise EditRefused("no layer is visible: there is nothing to flatten")
    flat = replace(document, layers=visible, active=len(visible) - 1, editing_mask=False)
    while len(flat.layers) > 1:
        flat = merge_down(flat, len(flat.layers) - 1)
    return flat


def fill_color(layer: Layer) -> tuple[float, float, float] | None:
    """The colour of a fill layer (no items, a transform to one constant colour, a mask); None for others."""
    if layer.curves or layer.points or layer.mask is None or np.any(layer.transform.matrix):
        return None
    return tuple(float(v) for v in layer.transform.offset)


def with_fill_layer(document: Document, color: tuple[float, float, float]) -> tuple[Document, int]:
    """``document`` with a fill layer of ``color`` just above the active layer, and its index.

    A fill layer shows one colour through its mask (``T(v) = color``, mask
    base 0): paint dabs go into the mask, so colour covers what lies below
    rather than adding up.  Strokes of one colour after another stack up
    as paint does: the topmost of the fill layers just above the active
    layer is taken when it has this colour, else a new one goes above them
    all.  The active layer stays active.
    """
    color = tuple(float(v) for v in color)
    above = document.active + 1
    while above < len(document.layers) and fill_color(document.layers[above]) is not None:
        above += 1  # past the run of fill layers painted from the active layer
    if above > document.active + 1 and fill_color(document.layers[above - 1]) == color:
        return document, above - 1
    fill = Layer(name=f"Paint #{''.join(f'{round(min(max(v, 0.0), 1.0) * 255):02x}' for v in color)}",
                 mask=Mask(base=0.0), transform=ColorTransform(np.zeros((3, 3)), color))
    layers = document.layers[:above] + (fill,) + document.layers[above:]
    return replace(document, layers=layers), above


def add_mask_points(document: Document, index: int, points) -> Document:
    """``points`` added to the mask of layer ``index`` (which must have one)."""
    mask = document.layers[_index(document, index)].mask
    if mask is None:
        raise EditRefused("the layer has no mask")
    return _changed(document, index, mask=mask.with_points(mask.points + tuple(points)))


def _items_only(document: Document) -> bool:
    """True for one layer that is its items alone: shown, no mask, opacity 1, no transform, no clone (its stops
    may carry alpha, which its items keep)."""
    layer = document.layers[0]
    return (len(document.layers) == 1 and layer.visible and layer.opacity == 1.0 and layer.active_mask is None
            and layer.clone is None and layer.transform.is_identity)


def stacked(bottom: Document, top: Document, mask: Document | None = None, opacity: float = 1.0,
            transform: ColorTransform | None = None) -> Document:
    """A two-layer document: ``top`` over ``bottom``, masked by the luminance of ``mask``'s picture.

    Each of the three is a one-layer document on the same canvas; the top
    layer takes ``opacity`` and ``transform``, and ``mask``'s curves and
    points as its mask (base 0: black hides the top layer).

    Raises
    ------
    EditRefused
        When the canvases differ or a document has layers of its own.
    ValueError
        When the opacity lies outside [0, 1].
    """
    sources = {"bottom": bottom, "top": top} | ({"mask": mask} if mask is not None else {})
    for role, document in sources.items():
        if (document.width, document.height) != (bottom.width, bottom.height):
            raise EditRefused(f"the {role} canvas is {document.width}x{document.height}, the bottom's "
                             f"{bottom.width}x{bottom.height}; compose documents of one canvas size")
        if not _items_only(document):
            raise EditRefused(f"the {role} document has layers of its own; compose takes one-layer documents")
    layer_mask = Mask(mask.curves, mask.points, base=0.0) if mask is not None else None
    layers = (replace(bottom.layer, name="Bottom"),
              Layer(top.curves, top.points, "Top", opacity=opacity, mask=layer_mask,
                    transform=transform if transform is not None else IDENTITY))
    return Document(bottom.width, bottom.height, layers=layers, active=1)
