"""Copy and paste between documents: a clipboard of one layer's items in a region, pasted seamlessly or plainly.

``copy_region`` takes the active layer's items and the selection;
``paste_seamless`` adds a clone layer (``model.clone``) above the active
layer, ``paste_curves`` adds the copied curves and points as they are to
the active layer.
Each is one undo step, as are ``place_clone`` (a clone moved, turned or
scaled) and the commit of the on-canvas handles.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
import shapely

from .clone import Clone, Similarity, region_on_canvas
from .document import Document
from .layer import Layer
from .layer_edits import baked
from .refusals import EditRefused

#: Samples per curve piece by which ``copied_items`` tells which curves the region holds.
SAMPLES_PER_PIECE = 8


@dataclass(frozen=True, eq=False)
class Copied:
    """What Edit > Copy put on the clipboard.

    Attributes
    ----------
    source : Document
        The copied layer's items on its document's canvas (one plain layer).
    region : numpy.ndarray
        ``(k, 2)`` the selection, a simple polygon in the source's pixels.
    name : str
        The copied layer's name.
    """

    source: Document
    region: np.ndarray
    name: str


def copy_region(document: Document, region) -> Copied:
    """What the tools act on (the active layer, or its mask while it is edited) with ``region`` (cut to the
    canvas), for ``paste_seamless`` and ``paste_curves``.

    The layer's colour adjustment is applied to the copied items' colours
    (``layer_edits.baked``), so that the copy shows what the layer shows;
    its mask and opacity stay behind.

    Raises
    ------
    EditRefused
        For a bad region (``clone.region_on_canvas``), a clone layer active
        (copy from its source instead), or a colour adjustment no item can
        carry (a Paint layer's colour).
    """
    layer = document.layer
    if layer.clone is not None:
        raise EditRefused("a clone layer has no curves to copy; copy from the layer it was cloned from")
    target = document.target if document.editing_mask else baked(layer)
    if not document.editing_mask and not target.transform.is_identity:
        raise EditRefused(f"{layer.name}'s colour is a transform that no curve of it carries (a Paint layer): "
                         "copy the layers it covers instead")
    source = Document(document.width, document.height, target.curves, target.points)
    return Copied(source, region_on_canvas(region, document.width, document.height), layer.name)


def canvas_region(document: Document) -> np.ndarray:
    """The whole canvas of ``document`` as a region, ``(4, 2)`` (Select All)."""
    w, h = float(document.width), float(document.height)
    return np.array([[0.0, 0.0], [w, 0.0], [w, h], [0.0, h]])


def paste_position(copied: Copied, document: Document) -> Similarity:
    """Where a paste of ``copied`` goes in ``document``: where it was copied from when that lies on the canvas,
    else its centroid at the canvas's centre."""
    low, high = copied.region.min(axis=0), copied.region.max(axis=0)
    if (low >= 0).all() and high[0] <= document.width and high[1] <= document.height:
        return Similarity()
    centroid = shapely.Polygon(copied.region).centroid
    return Similarity(offset=(document.width / 2 - centroid.x, document.height / 2 - centroid.y))


def _add_above(document: Document, layer: Layer) -> Document:
    at = document.active + 1
    return replace(document, layers=document.layers[:at] + (layer,) + document.layers[at:], active=at,
                   editing_mask=False)


def paste_seamless(document: Document, copied: Copied, similarity: Similarity = Similarity()) -> Document:
    """A clone layer of ``copied`` above the active layer, placed by ``similarity``, made active.

    Raises
    ------
    EditRefused
        When the placed region misses the canvas or its edge splits the region.
    """
    clone = _landing(document, Clone(copied.source, tuple(map(tuple, copied.region)), similarity))
    return _add_above(document, Layer(name=f"{copied.name} clone", clone=clone))


def place_clone(document: Document, index: int, similarity: Similarity) -> Document:
    """Layer ``index``'s clone placed by ``similarity`` instead."""
    layer = document.layers[index]
    if layer.clone is None:
        raise ValueError(f"{layer.name} is not a clone layer")
    clone = _landing(document, replace(layer.clone, similarity=similarity))
    return document.with_layer(index, replace(layer, clone=clone))


def _landing(document: Document, clone: Clone) -> Clone:
    """``clone``, checked to land on ``document``'s canvas in one piece (``EditRefused`` if not)."""
    try:
        region_on_canvas(clone.placed_region, document.width, document.height)
    except EditRefused as error:
        raise EditRefused(f"where the clone goes, {error}") from None
    return clone


def copied_items(copied: Copied) -> tuple[tuple, tuple]:
    """The copied curves that meet the region and the points inside it: ``(curves, points)``."""
    polygon = shapely.Polygon(copied.region)
    curves = []
    for curve in copied.source.curves:
        s = np.linspace(0.0, curve.piece_count, SAMPLES_PER_PIECE * curve.piece_count + 1)
        xy = curve.point_at(s)
        if shapely.contains_xy(polygon, xy[:, 0], xy[:, 1]).any():
            curves.append(curve)
    points = [point for point in copied.source.points if shapely.contains_xy(polygon, *point.position)]
    return tuple(curves), tuple(points)


def paste_curves(document: Document, copied: Copied, offset: tuple[float, float] = (0.0, 0.0)) -> Document:
    """The copied curves that meet the region and the points inside it added to the active layer (or the mask
    edited), moved by ``offset``, as they are: they then diffuse with the items there, as drawn curves do.

    Raises
    ------
    EditRefused
        When nothing was copied (no curve meets the region, no point lies in it) or the active layer is a
        clone layer (which holds no curves).
    """
    curves, points = copied_items(copied)
    if not (curves or points):
        raise EditRefused(f"no curve of {copied.name} meets the selection, and no point lies in it: nothing to paste")
    if document.layer.clone is not None and not document.editing_mask:
        raise EditRefused(f"{document.layer.name} is a clone layer, which holds no curves: choose a layer to paste "
                         "into")
    shift = np.asarray(offset, dtype=np.float64)
    moved_curves = tuple(replace(curve, control_points=curve.control_points + shift, id=None) for curve in curves)
    moved_points = tuple(replace(point, position=tuple(np.asarray(point.position) + shift), id=None)
                         for point in points)
    return document.with_curves(document.curves + moved_curves).with_points(document.points + moved_points)
