"""Edits of the layer stack: functions from a document to a new document, one undo step each.

Layers are addressed by their index in ``Document.layers`` (bottom first), as
a Layers panel lists them; the active layer follows its layer through moves
and deletions.
"""

from __future__ import annotations

from dataclasses import replace

from .color_transform import ColorTransform
from .document import Document
from .layer import Layer, Mask


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
        raise ValueError("a document keeps at least one layer")
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
        raise ValueError("the layer has no mask")
    return _changed(document, index, mask=replace(mask, **fields))


def invert_mask(document: Document, index: int | None = None) -> Document:
    mask = document.layers[_index(document, index)].mask
    return _mask_changed(document, index, inverted=not (mask is not None and mask.inverted))


def set_mask_enabled(document: Document, index: int | None, enabled: bool) -> Document:
    return _mask_changed(document, index, enabled=enabled)
