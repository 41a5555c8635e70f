"""Copy and paste between documents: a clipboard of one layer's items in a region, pasted seamlessly or plainly.

``copy_region`` takes the active layer's items and the selection;
``paste_seamless`` adds a clone layer (``model.clone``) above the active
layer, ``paste_plain`` a layer of the copied curves and points as they are.
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

#: Samples per curve piece by which ``paste_plain`` tells which curves the region holds.
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
    """The active layer's items with ``region`` (cut to the canvas), for ``paste_seamless`` and ``paste_plain``.

    Raises
    ------
    ValueError
        For a bad region (``clone.region_on_canvas``), or a clone layer active (copy from its source instead).
    """
    layer = document.layer
    if layer.clone is not None:
        raise ValueError("a clone layer has no curves to copy; copy from the layer it was cloned from")
    source = Document(document.width, document.height, layer.curves, layer.points)
    return Copied(source, region_on_canvas(region, document.width, document.height), layer.name)


def _add_above(document: Document, layer: Layer) -> Document:
    at = document.active + 1
    return replace(document, layers=document.layers[:at] + (layer,) + document.layers[at:], active=at,
                   editing_mask=False)


def paste_seamless(document: Document, copied: Copied, similarity: Similarity = Similarity()) -> Document:
    """A clone layer of ``copied`` above the active layer, placed by ``similarity``, made active.

    Raises
    ------
    ValueError
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
    """``clone``, checked to land on ``document``'s canvas in one piece (``ValueError`` if not)."""
    try:
        region_on_canvas(clone.placed_region, document.width, document.height)
    except ValueError as error:
        raise ValueError(f"where the clone goes, {error}") from None
    return clone


def paste_plain(document: Document, copied: Copied, offset: tuple[float, float] = (0.0, 0.0)) -> Document:
    """A layer above the active one of the copied curves that meet the region and the points inside it,
    moved by ``offset``, as they are (no blending: they diffuse on their own in their new layer)."""
    polygon = shapely.Polygon(copied.region)
    shift = np.asarray(offset, dtype=np.float64)
    curves = []
    for curve in copied.source.curves:
        s = np.linspace(0.0, curve.piece_count, SAMPLES_PER_PIECE * curve.piece_count + 1)
        xy = curve.point_at(s)
        if shapely.contains_xy(polygon, xy[:, 0], xy[:, 1]).any():
            curves.append(replace(curve, control_points=curve.control_points + shift, id=None))
    points = [replace(point, position=tuple(np.asarray(point.position) + shift), id=None)
              for point in copied.source.points if shapely.contains_xy(polygon, *point.position)]
    return _add_above(document, Layer(curves, points, name=f"{copied.name} pasted"))
