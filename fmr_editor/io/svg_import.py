"""SVG import: every path and shape of an SVG file becomes diffusion curves, each filled shape a layer.

The file is first parsed safely (``safe_xml``: no entities, bounded size), then read by ``svgelements``,
which applies transforms and the ``viewBox``, turns shapes (rectangles, circles, ellipses, lines,
polylines, polygons) into paths and arcs into cubic Beziers.  Each subpath becomes one curve of cubic
pieces: a line as a cubic with its handles at a third and two thirds, a quadratic Bezier raised to the
cubic it is.  Its colours, and where it goes:

- an element with a fill is a layer of its own, in the SVG's painting order: each of its subpaths,
  closed as SVG closes them to fill, has the fill inside, opaque, and outside the stroke's colour (the
  fill's where there is no stroke) at alpha 0, so that the shape covers exactly its inside, over the
  shapes painted before it;
- an element with a stroke only (line art) has the stroke's colour on both sides of each subpath, at the
  colour's own alpha: these diffuse together into the bottom layer, "Lines";
- one with neither stroke nor fill is left out (it shows nothing).

A filled shape that covers the whole canvas (a background) becomes a layer of its one colour
(``T(v) = fill``, at the fill's alpha as its opacity) instead: the canvas border owns lines along it,
so its outline, on or beyond the border, would leave no curve to give the colour.

Past ``MAX_SHAPE_LAYERS`` filled shapes, the rest share the last layer (``notes`` says so).

The canvas is the SVG's ``width`` x ``height`` in pixels (from the ``viewBox`` when they are absent),
rounded up.  Text, images and anything else that is not a path is left out, and ``notes`` says so; a file
with no path at all, or that breaks the model's limits, is refused with one ``DocumentLoadError``.
"""

from __future__ import annotations

import io
import math
import os
from pathlib import Path

import numpy as np
import shapely
import svgelements

from ..model import ColorStop, DiffusionCurve, Document, Layer, limits
from ..model.color_transform import ColorTransform
from .errors import DocumentLoadError
from .safe_xml import XmlRefused, parse_xml, read_bounded

#: Pieces shorter than this (pixels) are dropped: they are a point.
MIN_PIECE = 1e-9
#: Most layers of filled shapes made (each is solved apart).
MAX_SHAPE_LAYERS = 64


def load_svg(path: str | os.PathLike, notes: list[str] | None = None) -> Document:
    """The document of the SVG file ``path``; ``notes`` (a list, when given) gets a line for what was left out.

    Raises
    ------
    DocumentLoadError
        When the file cannot be read, is not SVG, holds no path, or exceeds the model's limits.
    """
    name = Path(path).name or os.fspath(path)
    return parse_svg(read_bounded(path, name), name, notes)


def parse_svg(data: bytes, name: str, notes: list[str] | None = None) -> Document:
    """The document of the SVG ``data`` (see ``load_svg``); ``name`` names the file in messages."""
    try:
        root = parse_xml(data)
    except XmlRefused as error:
        raise DocumentLoadError(name, str(error)) from None
    if not root.tag.endswith("svg"):
        raise DocumentLoadError(name, f"not an SVG file (its root element is <{root.tag.split('}')[-1]}>)")
    try:
        svg = svgelements.SVG.parse(io.BytesIO(data))
        width, height = _canvas(svg)
        limits.check_canvas(width, height)
        lines, shapes, left_out = [], [], {}
        for element in svg.elements():
            if isinstance(element, svgelements.Shape):
                made, filled = _curves(element)
                if not made:
                    left_out["paths without stroke or fill"] = left_out.get("paths without stroke or fill", 0) + 1
                elif filled:
                    name_ = element.id or f"{type(element).__name__} {len(shapes) + 1}"
                    shapes.append(_background(made[0], name_) if _covers(made, width, height)
                                  else Layer(tuple(made), name=name_))
                else:
                    lines += made
            elif isinstance(element, (svgelements.Text, svgelements.Image)):
                kind = f"{type(element).__name__.lower()} elements"
                left_out[kind] = left_out.get(kind, 0) + 1
        if len(shapes) > MAX_SHAPE_LAYERS:
            surplus = shapes[MAX_SHAPE_LAYERS - 1 :]
            shapes[MAX_SHAPE_LAYERS - 1 :] = [Layer(tuple(c for layer in surplus for c in layer.curves),
                                                    name=f"Shapes {MAX_SHAPE_LAYERS}-{len(shapes)}")]
            left_out[f"separate layers past {MAX_SHAPE_LAYERS} (the rest share the last)"] = len(surplus) - 1
        layers = ((Layer(tuple(lines), name="Lines"),) if lines else ()) + tuple(shapes)
        if not layers:
            raise DocumentLoadError(name, "no path or shape with a stroke or a fill to import")
        document = Document(width, height, layers=layers, active=len(layers) - 1)
        limits.check_document(document)
    except DocumentLoadError:
        raise
    except (ValueError, TypeError, ZeroDivisionError, OverflowError) as error:  # the model's refusals among them
        raise DocumentLoadError(name, f"cannot import the SVG ({error})") from None
    if notes is not None and left_out:
        notes.append("not imported (only paths and shapes are): "
                     + ", ".join(f"{count} {kind}" for kind, count in left_out.items()))
    return document


def _canvas(svg: svgelements.SVG) -> tuple[int, int]:
    width, height = svg.width, svg.height
    if not (width and height) and svg.viewbox is not None:
        width, height = svg.viewbox.width, svg.viewbox.height
    if not all(isinstance(v, (int, float)) and math.isfinite(v) and v > 0 for v in (width, height)):
        raise ValueError(f"its size is not a positive width and height ({width!r} x {height!r})")
    return math.ceil(width - 1e-6), math.ceil(height - 1e-6)


def _colour(paint) -> tuple[tuple[float, float, float], float] | None:
    """``(rgb, alpha)`` of an SVG paint, None for none."""
    if paint is None or paint.value is None:
        return None
    return (paint.red / 255.0, paint.green / 255.0, paint.blue / 255.0), paint.alpha / 255.0


def _curves(element: svgelements.Shape) -> tuple[list[DiffusionCurve], bool]:
    """The curves of ``element``'s subpaths, coloured as the module says, and whether it is filled."""
    stroke, fill = _colour(element.stroke), _colour(element.fill)
    line = stroke or fill
    if line is None:
        return [], False
    path = svgelements.Path(element.segments())  # with its transform (``Path(shape)`` drops a shape's)
    path.approximate_arcs_with_cubics()
    curves = []
    for subpath in path.as_subpaths():
        control = _cubic_chain(list(subpath), close=fill is not None)
        if control is None:
            continue
        if fill is not None:
            inside = (ColorStop(0.0, fill[0], fill[1]),)
            outside = (ColorStop(0.0, line[0], 0.0),)
            left, right = (inside, outside) if DiffusionCurve(control).inside_on_left() else (outside, inside)
        else:
            left = right = (ColorStop(0.0, line[0], line[1]),)
        curves.append(DiffusionCurve(control, left, right))
    return curves, fill is not None


def _covers(curves: list[DiffusionCurve], width: int, height: int) -> bool:
    """True when ``curves`` are one closed outline around the whole canvas."""
    if len(curves) != 1:
        return False
    curve = curves[0]
    outline = shapely.Polygon(curve.point_at(np.linspace(0.0, curve.piece_count, 16 * curve.piece_count + 1)))
    return outline.is_valid and outline.buffer(1e-6 * max(width, height)).covers(shapely.box(0, 0, width, height))


def _background(curve: DiffusionCurve, name: str) -> Layer:
    """A layer of the one colour inside ``curve``, at its alpha."""
    inside = (curve.left if curve.left[0].alpha > 0 else curve.right)[0]
    return Layer(name=name, transform=ColorTransform(np.zeros((3, 3)), inside.color), opacity=inside.alpha)


def _cubic_chain(segments: list, close: bool) -> np.ndarray | None:
    """The control points of a subpath's pieces as cubics, with a line back to its start when ``close`` (as
    SVG closes a subpath to fill it); None without a piece."""
    points: list[tuple[float, float]] = []
    start = None
    if close and segments and not isinstance(segments[-1], svgelements.Close):
        segments = [*segments, svgelements.Close(segments[-1].end, segments[0].end)]
    for segment in segments:
        if isinstance(segment, svgelements.Move):
            start = (segment.end.x, segment.end.y)
            continue
        a = (segment.start.x, segment.start.y)
        b = (segment.end.x, segment.end.y)
        if isinstance(segment, svgelements.Close):
            b = start if start is not None else b
        if isinstance(segment, svgelements.CubicBezier):
            handles = [(segment.control1.x, segment.control1.y), (segment.control2.x, segment.control2.y)]
        elif isinstance(segment, svgelements.QuadraticBezier):
            c = (segment.control.x, segment.control.y)
            handles = [(a[0] + 2 / 3 * (c[0] - a[0]), a[1] + 2 / 3 * (c[1] - a[1])),
                       (b[0] + 2 / 3 * (c[0] - b[0]), b[1] + 2 / 3 * (c[1] - b[1]))]
        else:  # a line, or the line that closes the subpath
            handles = [(a[0] + (b[0] - a[0]) / 3, a[1] + (b[1] - a[1]) / 3),
                       (a[0] + 2 * (b[0] - a[0]) / 3, a[1] + 2 * (b[1] - a[1]) / 3)]
        if math.dist(a, b) <= MIN_PIECE and all(math.dist(a, h) <= MIN_PIECE for h in handles):
            continue  # a point
        if not points:
            points.append(a)
        points += [*handles, b]
    return np.array(points, dtype=np.float64) if len(points) >= 4 else None
