"""The document as JSON: the ``document.json`` entry of an ``.fmr`` file.

Kept apart from the container so that other features (history snapshots,
the clipboard) can reuse it.  The schema, with an example, is in
``docs/fmr-format.md``; in short::

    {"format": "fmr-editor document", "version": 2,
     "canvas": {"width": 512, "height": 512}, "active": 0,
     "layers": [{"name": "Layer 1", "visible": true, "opacity": 1.0,
                 "transform": {"matrix": [[1, 0, 0], [0, 1, 0], [0, 0, 1]], "offset": [0, 0, 0]},
                 "mask": null or {"base": 1.0, "inverted": false, "enabled": true, "curves": [...], "points": [...]},
                 "curves": [{"control_points": [[x, y], ...],
                             "left": [{"position": s, "color": [r, g, b], "alpha": a (optional)}, ...],
                             "right": [...], "blur": [{"position": s, "blur": b}, ...]}],
                 "points": [{"position": [x, y], "radius": r, "color": [r, g, b], "amplitude": a}]}]}

Version 1 (before layers) had ``curves`` and ``points`` at the top level and
no ``layers``; it reads as one layer.

Positions along curves are in piece units (the model's convention).  Floats
are written with Python's shortest round-trip ``repr``, so a document comes
back exactly equal.  Reading is strict about what it uses (types,
finiteness, counts, duplicate keys; NaN and Infinity are refused) and names
the place of any problem; keys it does not know are ignored, so a later
version may add optional ones without a version change.
"""

from __future__ import annotations

import json

from ..model import BlurStop, ColorStop, DiffusionCurve, DiffusionPoint, Document, Layer, Mask, limits
from ..model.clone import MAX_REGION, Clone, Similarity, region_on_canvas
from ..model.color_transform import ColorTransform
from ..model.layer import MAX_LAYERS, MAX_NAME
from ..model.limits import shortened
from .json_checks import (
    SchemaError,
    as_list,
    as_object,
    check_version,
    finite,
    finite_rows,
    finite_tuple,
    parse_json,
    required,
    whole,
)

FORMAT_NAME = "fmr-editor document"
"""Value of the ``format`` key."""

SCHEMA_VERSION = 4
"""The newest version read (1: one image, 2: layers, 3: clone layers, 4: alpha on colour stops); a document is
written in the oldest version that holds it, so that a file without clone layers or alpha still opens in an
editor of version 2, and one with alpha is refused by older editors (which would drop its alpha) with a clear
message."""


MAX_CANVAS_SIZE = limits.MAX_CANVAS_SIDE
"""Largest canvas width or height accepted (as the Orzan reader)."""


# --- writing -------------------------------------------------------------------------------------


def document_to_data(document: Document) -> dict:
    """The JSON-ready form of ``document`` (dicts, lists, floats and ints).

    Raises
    ------
    ValueError
        If a colour is not three numbers (the model does not check it).
    """
    return {
        "format": FORMAT_NAME,
        "version": _version(document),
        "canvas": {"width": document.width, "height": document.height},
        "active": document.active,
        "layers": [_layer_to_data(layer) for layer in document.layers],
    }


def _version(document: Document) -> int:
    """The oldest version that holds ``document``: 4 for stops with alpha, 3 for clone layers, else 2."""
    def translucent(target: Layer | Mask | None) -> bool:
        return target is not None and any(curve.translucent for curve in target.curves)

    if any(translucent(layer) or translucent(layer.mask) or (layer.clone is not None and
                                                             translucent(layer.clone.source.layer))
           for layer in document.layers):
        return 4
    return 3 if any(layer.clone is not None for layer in document.layers) else 2


def _items_to_data(target: Layer | Mask) -> dict:
    return {
        "curves": [_curve_to_data(curve) for curve in target.curves],
        "points": [_point_to_data(point) for point in target.points],
    }


def _layer_to_data(layer: Layer) -> dict:
    mask = layer.mask
    return {
        "name": layer.name,
        "visible": layer.visible,
        "opacity": layer.opacity,
        "transform": {"matrix": layer.transform.matrix.tolist(), "offset": layer.transform.offset.tolist()},
        "mask": None if mask is None else {
            "base": mask.base, "inverted": mask.inverted, "enabled": mask.enabled, **_items_to_data(mask)
        },
        **_items_to_data(layer),
        **({"clone": _clone_to_data(layer.clone)} if layer.clone is not None else {}),
    }


def _clone_to_data(clone: Clone) -> dict:
    source, similarity = clone.source, clone.similarity
    return {
        "source": {"canvas": {"width": source.width, "height": source.height}, **_items_to_data(source.layer)},
        "region": [list(vertex) for vertex in clone.region],
        "similarity": {"scale": similarity.scale, "degrees": similarity.degrees, "offset": list(similarity.offset),
                       "mirror": similarity.mirror},
    }


def _curve_to_data(curve: DiffusionCurve) -> dict:
    return {
        "control_points": curve.control_points.tolist(),
        "left": [_color_stop_to_data(stop) for stop in curve.left],
        "right": [_color_stop_to_data(stop) for stop in curve.right],
        "blur": [{"position": float(stop.position), "blur": float(stop.blur)} for stop in curve.blur],
    }


def _color_stop_to_data(stop: ColorStop) -> dict:
    alpha = {"alpha": float(stop.alpha)} if stop.alpha != 1.0 else {}
    return {"position": float(stop.position), "color": _color(stop.color), **alpha}


def _point_to_data(point: DiffusionPoint) -> dict:
    return {
        "position": [float(v) for v in point.position],
        "radius": float(point.radius),
        "color": _color(point.color),
        "amplitude": float(point.amplitude),
    }


def _color(color) -> list[float]:
    values = [float(v) for v in color]
    if len(values) != 3:
        raise ValueError(f"a colour must be 3 numbers, got {len(values)}")
    return values


def dumps_document(document: Document) -> bytes:
    """``document`` as compact UTF-8 JSON.

    Raises
    ------
    ValueError
        If the document holds a non-finite number or a malformed colour.
    """
    return json.dumps(document_to_data(document), allow_nan=False, separators=(",", ":")).encode("utf-8")


# --- reading -------------------------------------------------------------------------------------


def loads_document(data: bytes) -> Document:
    """Parse ``document.json`` bytes.

    Raises
    ------
    SchemaError
        If the bytes are not strict JSON or do not describe a document
        (``NewerVersionError`` for a version above ``SCHEMA_VERSION``).
    """
    return document_from_data(parse_json(data))


def document_from_data(data: object) -> Document:
    """The document described by parsed JSON ``data``, within ``model.limits``.

    Raises
    ------
    SchemaError
        If ``data`` does not follow the schema or exceeds a limit; the message names the place.
    """
    document = _document(data)
    try:
        limits.check_document(document)
    except limits.LimitError as error:
        raise SchemaError(str(error)) from None
    return document


def _document(data: object) -> Document:
    root = as_object(data, "the top level")
    if root.get("format") != FORMAT_NAME:
        raise SchemaError(f"format is {root.get('format')!r:.60}, expected {FORMAT_NAME!r}")
    version = check_version(root, "version", SCHEMA_VERSION, "document format")
    canvas = as_object(required(root, "canvas", ""), "canvas")
    width = whole(required(canvas, "width", "canvas"), "canvas.width", 1, MAX_CANVAS_SIZE)
    height = whole(required(canvas, "height", "canvas"), "canvas.height", 1, MAX_CANVAS_SIZE)
    if version == 1:
        curves, points = _items(root, "")
        return Document(width, height, curves, points)
    values = as_list(required(root, "layers", ""), "layers")
    if not 1 <= len(values) <= MAX_LAYERS:
        raise SchemaError(f"layers must hold 1 to {MAX_LAYERS} layers, got {len(values)}")
    layers = tuple(_layer(value, f"layers[{i}]", (width, height)) for i, value in enumerate(values))
    active = whole(root.get("active", 0), "active", 0, len(layers) - 1)
    return Document(width, height, layers=layers, active=active)


def _items(item: dict, where: str) -> tuple[tuple[DiffusionCurve, ...], tuple[DiffusionPoint, ...]]:
    """The curves and points of a layer, a mask or a version-1 document."""
    prefix = f"{where}." if where else ""
    curves = as_list(item.get("curves", []), f"{prefix}curves")
    points = as_list(item.get("points", []), f"{prefix}points")
    for values, most, what in ((curves, limits.MAX_CURVES, "curves"), (points, limits.MAX_POINTS, "points")):
        if len(values) > most:
            raise SchemaError(f"{prefix}{what} holds {len(values):,}; at most {most:,} are read")
    return (tuple(_curve(value, f"{prefix}curves[{i}]") for i, value in enumerate(curves)),
            tuple(_point(value, f"{prefix}points[{i}]") for i, value in enumerate(points)))


def _flag(item: dict, key: str, default: bool, where: str) -> bool:
    value = item.get(key, default)
    if not isinstance(value, bool):
        raise SchemaError(f"{where}.{key} must be true or false, got {value!r:.40}")
    return value


def _layer(value: object, where: str, canvas: tuple[int, int]) -> Layer:
    item = as_object(value, where)
    name = item.get("name", "Layer")
    if not isinstance(name, str) or len(name) > MAX_NAME:
        raise SchemaError(f"{where}.name must be text of at most {MAX_NAME} characters")
    opacity = finite(item.get("opacity", 1.0), f"{where}.opacity")
    if not 0.0 <= opacity <= 1.0:
        raise SchemaError(f"{where}.opacity must lie in [0, 1], got {shortened(opacity)}")
    transform = as_object(item.get("transform", {}), f"{where}.transform")
    matrix = finite_rows(transform.get("matrix", [[1, 0, 0], [0, 1, 0], [0, 0, 1]]), 3, f"{where}.transform.matrix")
    if len(matrix) != 3:
        raise SchemaError(f"{where}.transform.matrix must have 3 rows, got {len(matrix)}")
    offset = finite_tuple(transform.get("offset", [0, 0, 0]), 3, f"{where}.transform.offset")
    mask = None
    if item.get("mask") is not None:
        mask_item = as_object(item["mask"], f"{where}.mask")
        curves, points = _items(mask_item, f"{where}.mask")
        mask = Mask(curves, points, finite(mask_item.get("base", 0.0), f"{where}.mask.base"),
                    _flag(mask_item, "inverted", False, f"{where}.mask"),
                    _flag(mask_item, "enabled", True, f"{where}.mask"))
    curves, points = _items(item, where)
    clone = _clone(item["clone"], f"{where}.clone", canvas) if item.get("clone") is not None else None
    try:
        return Layer(curves, points, name, _flag(item, "visible", True, where), opacity, mask,
                     ColorTransform(matrix, offset), clone)
    except ValueError as error:
        raise SchemaError(f"{where}: {error}") from None


def _clone(value: object, where: str, canvas: tuple[int, int]) -> Clone:
    item = as_object(value, where)
    source = as_object(required(item, "source", where), f"{where}.source")
    size = as_object(required(source, "canvas", f"{where}.source"), f"{where}.source.canvas")
    width = whole(required(size, "width", f"{where}.source.canvas"), f"{where}.source.canvas.width", 1, MAX_CANVAS_SIZE)
    height = whole(required(size, "height", f"{where}.source.canvas"), f"{where}.source.canvas.height", 1,
                   MAX_CANVAS_SIZE)
    region = finite_rows(required(item, "region", where), 2, f"{where}.region")
    if not 3 <= len(region) <= MAX_REGION:
        raise SchemaError(f"{where}.region must have 3 to {MAX_REGION} corners, got {len(region)}")
    placing = as_object(required(item, "similarity", where), f"{where}.similarity")
    try:
        similarity = Similarity(finite(placing.get("scale", 1.0), f"{where}.similarity.scale"),
                                finite(placing.get("degrees", 0.0), f"{where}.similarity.degrees"),
                                finite_tuple(placing.get("offset", [0, 0]), 2, f"{where}.similarity.offset"),
                                _flag(placing, "mirror", False, f"{where}.similarity"))
        clone = Clone(Document(width, height, *_items(source, f"{where}.source")), tuple(region), similarity)
        region_on_canvas(region, width, height)
        region_on_canvas(clone.placed_region, *canvas)
    except ValueError as error:
        raise SchemaError(f"{where}: {error}") from None
    return clone


def _curve(value: object, where: str) -> DiffusionCurve:
    item = as_object(value, where)
    listed = as_list(required(item, "control_points", where), f"{where}.control_points")
    if len(listed) > limits.MAX_CURVE_CONTROL_POINTS:
        raise SchemaError(f"{where}.control_points holds {len(listed):,}; at most "
                          f"{limits.MAX_CURVE_CONTROL_POINTS:,} are read")
    points = finite_rows(listed, 2, f"{where}.control_points")
    if len(points) < 4 or (len(points) - 1) % 3:
        raise SchemaError(
            f"{where}.control_points has {len(points)} points; a chain of cubic Beziers needs 3k+1 (4, 7, 10, ...)"
        )
    left = [_color_stop(stop, w) for w, stop in _stops(item, "left", where)]
    right = [_color_stop(stop, w) for w, stop in _stops(item, "right", where)]
    blur = [BlurStop(_position(stop, w), finite(required(stop, "blur", w), f"{w}.blur"))
            for w, stop in _stops(item, "blur", where)]
    try:
        return DiffusionCurve(points, left, right, blur)
    except ValueError as error:  # a safety net: the checks above leave nothing for the model
        raise SchemaError(f"{where}: {error}") from None


def _color_stop(stop: dict, where: str) -> ColorStop:
    """A colour stop: its position, colour and optional alpha (1 when absent, as in every file before version 4)."""
    color = finite_tuple(required(stop, "color", where), 3, f"{where}.color")
    alpha = finite(stop.get("alpha", 1.0), f"{where}.alpha")
    if not 0.0 <= alpha <= 1.0:
        raise SchemaError(f"{where}.alpha is {alpha:g}; an alpha lies in [0, 1]")
    return ColorStop(_position(stop, where), color, alpha)


def _stops(item: dict, key: str, where: str) -> list[tuple[str, dict]]:
    """``(place, object)`` for each element of the optional list ``item[key]``."""
    values = as_list(item.get(key, []), f"{where}.{key}")
    if len(values) > limits.MAX_CURVE_STOPS:
        raise SchemaError(f"{where}.{key} holds {len(values):,} stops; at most {limits.MAX_CURVE_STOPS:,} are read")
    return [(f"{where}.{key}[{i}]", as_object(value, f"{where}.{key}[{i}]")) for i, value in enumerate(values)]


def _position(stop: dict, where: str) -> float:
    return finite(required(stop, "position", where), f"{where}.position")


def _point(value: object, where: str) -> DiffusionPoint:
    item = as_object(value, where)
    position = finite_tuple(required(item, "position", where), 2, f"{where}.position")
    radius = finite(required(item, "radius", where), f"{where}.radius")
    if not radius > 0:
        raise SchemaError(f"{where}.radius must be positive, got {shortened(radius)}")
    color = finite_tuple(required(item, "color", where), 3, f"{where}.color")
    amplitude = finite(item.get("amplitude", 1.0), f"{where}.amplitude")
    try:
        return DiffusionPoint(position, radius, color, amplitude)
    except ValueError as error:  # e.g. a colour beyond limits.MAX_COLOR
        raise SchemaError(f"{where}: {error}") from None
