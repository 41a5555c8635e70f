"""SVG import: every path and shape of an SVG file becomes diffusion curves, each filled shape a layer.

The file is first parsed safely (``safe_xml``: no entities, bounded size), then read by ``svgelements``,
which applies transforms and the ``viewBox``, turns shapes (rectangles, circles, ellipses, lines,
polylines, polygons) into paths and arcs into cubic Beziers.  Each subpath becomes one curve of cubic
pieces: a line as a cubic with its handles at a third and two thirds, a quadratic Bezier raised to the
cubic it is.  Its colours, and where it goes:

- an element with a fill is a layer over the shapes painted before it: each of its subpaths, closed as
  SVG closes them to fill, has the fill inside, opaque, and outside the stroke's colour (the fill's where
  there is no stroke) at alpha 0, so that the shape covers exactly its inside;
- an element with a stroke only (line art) has the stroke's colour on both sides of each subpath, at the
  colour's own alpha: these diffuse together into the bottom layer, "Lines";
- one with neither stroke nor fill is left out (it shows nothing).

Filled shapes apart from every earlier one they do not overlap share a layer (``Shapes``: the same
picture, each being clear outside), so that a drawing of many shapes makes few layers.  Which side of an
outline is filled is read off the region its element fills (even-odd, or nonzero as holes usually make
it), so that holes stay clear.  A filled shape that covers the whole canvas (a background) becomes a layer
of its one colour (``T(v) = fill``, at the fill's alpha as its opacity) instead: the canvas border owns
lines along it, so its outline, on or beyond the border, would leave no curve to give the colour.  Past
``MAX_SHAPE_LAYERS`` layers of shapes, the rest share the last (``notes`` says so).

The canvas is the SVG's ``width`` x ``height`` in pixels (from the ``viewBox`` when they are absent),
rounded up.  Text, images and anything else that is not a path is left out, and ``notes`` says so; a file
with no path at all, or that breaks the model's limits, is refused with one ``DocumentLoadError``.
"""

from __future__ import annotations

import io
import math
import os
from collections import Counter
from pathlib import Path

import numpy as np
import shapely
import svgelements

from ..model import ColorStop, DiffusionCurve, Document, Layer, limits
from ..model.color_transform import ColorTransform
from .errors import DocumentLoadError
from .notes import listed
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
        lines, shapes, left_out = [], Shapes(width, height), Counter()
        for element in svg.elements():
            if isinstance(element, svgelements.Shape):
                stroke, fill = _colour(element.stroke), _colour(element.fill)
                if stroke is None and fill is None:
                    left_out["path without stroke or fill", "paths without stroke or fill"] += 1
                elif fill is None:
                    lines += _lines(element, stroke)
                else:
                    shapes.add(element, fill, stroke or fill)
                if len(lines) + shapes.curves > limits.MAX_CURVES:  # before the work grows further
                    raise DocumentLoadError(name, f"more than {limits.MAX_CURVES:,} curves to import")
            elif isinstance(element, (svgelements.Text, svgelements.Image)):
                kind = type(element).__name__.lower()
                left_out[f"{kind} element", f"{kind} elements"] += 1
        layers = ((Layer(tuple(lines), name="Lines"),) if lines else ()) + shapes.layers()
        if shapes.merged:
            left_out[f"separate layer past {MAX_SHAPE_LAYERS} (it shares the last)",
                     f"separate layers past {MAX_SHAPE_LAYERS} (the rest share the last)"] = shapes.merged
        if not layers:
            raise DocumentLoadError(name, "no path or shape with a stroke or a fill to import")
        document = Document(width, height, layers=layers, active=len(layers) - 1)
        limits.check_document(document)
    except DocumentLoadError:
        raise
    except RecursionError:  # svgelements follows groups and uses by recursion
        raise DocumentLoadError(name, "the SVG nests too deeply (groups or uses within one another)") from None
    except ValueError as error:  # the model's refusals among them
        raise DocumentLoadError(name, f"cannot import the SVG ({error})") from None
    except Exception as error:  # svgelements meets malformed input with whatever error comes (found by fuzzing)
        raise DocumentLoadError(name, f"cannot import the SVG ({type(error).__name__}: {error})") from None
    if notes is not None and left_out:
        notes.append("not imported (only paths and shapes are): "
                     + listed((count, *nouns) for nouns, count in left_out.items()))
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


def _subpaths(element: svgelements.Shape, close: bool) -> list[np.ndarray]:
    """The control points of ``element``'s subpaths as cubic chains (closed, when ``close``, as SVG closes
    them to fill)."""
    path = svgelements.Path(element.segments())  # with its transform (``Path(shape)`` drops a shape's)
    path.approximate_arcs_with_cubics()
    chains = (_cubic_chain(list(subpath), close) for subpath in path.as_subpaths())
    return [chain for chain in chains if chain is not None]


def _lines(element: svgelements.Shape, stroke: tuple) -> list[DiffusionCurve]:
    """Line art: each subpath with the stroke's colour on both sides."""
    stops = (ColorStop(0.0, stroke[0], stroke[1]),)
    return [DiffusionCurve(control, stops, stops) for control in _subpaths(element, close=False)]


def _sampled(curve: DiffusionCurve, per_piece: int = 16) -> np.ndarray:
    return curve.point_at(np.linspace(0.0, curve.piece_count, per_piece * curve.piece_count + 1))


def filled_region(outlines: list[DiffusionCurve], even_odd: bool):
    """The region a fill paints inside closed ``outlines`` (a shapely geometry): even-odd, or by the nonzero
    rule as holes usually make it (outlines turning against the largest one cut it, the others add)."""
    polygons = [shapely.make_valid(shapely.Polygon(_sampled(curve))) for curve in outlines]
    if even_odd:
        region = polygons[0]
        for polygon in polygons[1:]:
            region = region.symmetric_difference(polygon)
        return region
    turns = [curve.inside_on_left() for curve in outlines]
    main = turns[int(np.argmax([polygon.area for polygon in polygons]))]
    added = shapely.union_all([p for p, turn in zip(polygons, turns) if turn == main])
    return added.difference(shapely.union_all([p for p, turn in zip(polygons, turns) if turn != main]))


def fill_on_left(curve: DiffusionCurve, region, probe: float = 0.05) -> bool:
    """True when ``region`` lies on ``curve``'s left: most of a few points ``probe`` px to its left are in it."""
    s = (np.arange(5) + 0.5) / 5 * curve.piece_count
    points, ahead = curve.point_at(s), curve.point_at(np.minimum(s + 1e-3, curve.piece_count))
    direction = ahead - points
    left = np.stack([direction[:, 1], -direction[:, 0]], axis=1)  # the left as seen, y down
    left /= np.maximum(np.hypot(*left.T), 1e-300)[:, None]
    return int(shapely.contains_xy(region, *(points + probe * left).T).sum()) >= 3


class Shapes:
    """Filled shapes, each on the lowest layer above every earlier shape it overlaps: shapes apart from one
    another share a layer (the same picture, each being clear outside), and painting order holds where
    they overlap; a shape covering the canvas is a layer of its colour.

    Attributes
    ----------
    merged : int
        Shapes that went into the last layer because there were ``MAX_SHAPE_LAYERS`` already.
    curves : int
        Curves made so far.
    """

    def __init__(self, width: int, height: int) -> None:
        self.canvas = shapely.box(0, 0, width, height)
        self.levels: list[list[tuple[str, DiffusionCurve | Layer]]] = []
        self.footprints: list[tuple[int, object]] = []  # (level, region) of each shape so far
        self.boxes = np.empty((64, 4))  # their bounding boxes (the first len(footprints) rows), to find the
        # ones that may overlap at once
        self.merged = self.curves = 0

    def add(self, element: svgelements.Shape, fill: tuple, outside: tuple) -> None:
        """Place ``element``, of ``fill`` inside and the colour ``outside`` (at alpha 0) outside."""
        outlines = [DiffusionCurve(control) for control in _subpaths(element, close=True)]
        if not outlines:
            return
        region = filled_region(outlines, str(element.values.get("fill-rule", "")).lower() == "evenodd")
        box, boxes = np.array(region.bounds), self.boxes[: len(self.footprints)]
        near = np.flatnonzero((boxes[:, 0] <= box[2]) & (box[0] <= boxes[:, 2])
                              & (boxes[:, 1] <= box[3]) & (box[1] <= boxes[:, 3]))
        level = 1 + max((self.footprints[k][0] for k in near if self.footprints[k][1].intersects(region)), default=-1)
        if level >= MAX_SHAPE_LAYERS:
            level, self.merged = MAX_SHAPE_LAYERS - 1, self.merged + 1
        if len(self.footprints) == len(self.boxes):
            self.boxes = np.concatenate([self.boxes, np.empty_like(self.boxes)])
        self.boxes[len(self.footprints)] = box
        self.footprints.append((level, region))
        self.curves += len(outlines)
        while len(self.levels) <= level:
            self.levels.append([])
        name = element.id or f"{type(element).__name__} {len(self.footprints)}"
        if region.buffer(1e-6 * self.canvas.length).covers(self.canvas):  # a background: see the module
            background = Layer(name=name, transform=ColorTransform(np.zeros((3, 3)), fill[0]), opacity=fill[1])
            self.levels[level].append((name, background))
            return
        inside, clear = (ColorStop(0.0, fill[0], fill[1]),), (ColorStop(0.0, outside[0], 0.0),)
        for curve in outlines:
            filled_left = curve.inside_on_left() if len(outlines) == 1 else fill_on_left(curve, region)
            left, right = (inside, clear) if filled_left else (clear, inside)
            self.levels[level].append((name, DiffusionCurve(curve.control_points, left, right)))

    def layers(self) -> tuple[Layer, ...]:
        """The layers, bottom first: per level its background, or its shapes' curves."""
        made = []
        for items in self.levels:
            made += [item for _, item in items if isinstance(item, Layer)]
            curves = tuple(item for _, item in items if isinstance(item, DiffusionCurve))
            names = list(dict.fromkeys(name for name, item in items if isinstance(item, DiffusionCurve)))
            if curves:
                name = names[0] if len(names) == 1 else f"{names[0]} and {len(names) - 1} more"
                made.append(Layer(curves, name=name))
        return tuple(made)


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
