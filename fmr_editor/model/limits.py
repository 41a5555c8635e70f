"""What a document may hold: the limits checked before any work is done on it.

Readers check them as they read (``io``), the engine before it builds
(``engine.stack``), so that a hostile or broken file is refused with one
clear message instead of exhausting memory or time.  They are generous for
real drawings: the largest sample files (roses: 3,906 curves, 17,217 control
points; pink_flowers: a 1024 x 768 canvas) are far inside them.

Each limit is a module constant; ``check_document`` raises ``LimitError``
naming the limit, where it was exceeded and the value (shortened to 40
characters).
"""

from __future__ import annotations

import math
from collections.abc import Iterable

import numpy as np

from .refusals import EditRefused

#: Largest canvas side, pixels.
MAX_CANVAS_SIDE = 16384
#: Longest canvas side over the shortest (the lattice is square: a 1 x 16384 strip would cost what a
#: 16384 x 16384 canvas costs).
MAX_ASPECT = 64
#: Most curves in a document (all layers and masks together).
MAX_CURVES = 50_000
#: Most control points of one curve (10,000 cubic pieces).
MAX_CURVE_CONTROL_POINTS = 30_001
#: Most control points in a document.
MAX_CONTROL_POINTS = 1_000_000
#: Most stops on one side of a curve (colour stops left or right, or blur stops; gm_cup.xml, the most of the
#: shared real files, has 122): a million stops on one curve took 24 s.
MAX_CURVE_STOPS = 10_000
#: Most stops in a document, every side of every curve together.
MAX_STOPS = 1_000_000
#: Most diffusion points in a document.
MAX_POINTS = 1_000_000
#: Control points and point centres lie within this many times the canvas's longer side of the canvas (beyond it a curve
#: adds nothing that a curve nearer would not, and its flattening would grow with its distance).
COORDINATE_REACH = 4.0
#: Largest magnitude of a colour component or a point's amplitude (colours are nominally in [0, 1]); checked
#: by ``ColorStop``'s curve and ``DiffusionPoint`` when they are made.
MAX_COLOR = 1e3
#: Largest magnitude of a blur value (document pixels of deviation; ``engine.blur`` draws at most 96 output
#: pixels of it); checked by ``BlurStop``'s curve.
MAX_BLUR = 1e3


class LimitError(EditRefused):
    """A document exceeds one of the limits; the message names the limit and the value."""


def shortened(value, width: int = 40) -> str:
    """``repr(value)``, cut to ``width`` characters with an ellipsis (a 50 MB number stays out of messages)."""
    text = repr(value)
    return text if len(text) <= width else text[: width - 3] + "..."


def check_canvas(width: int, height: int) -> None:
    """Refuse a canvas side outside 1 to ``MAX_CANVAS_SIDE``, or one side more than ``MAX_ASPECT`` times the other."""
    for name, side in (("width", width), ("height", height)):
        if not 1 <= side <= MAX_CANVAS_SIDE:
            raise LimitError(f"the canvas {name} must be 1 to {MAX_CANVAS_SIDE} pixels, got {shortened(side)}")
    if max(width, height) > MAX_ASPECT * min(width, height):
        raise LimitError(f"the canvas may be at most {MAX_ASPECT} times as long as it is wide, got {width} x {height}")


def check_document(document) -> None:
    """Refuse ``document`` (a ``model.Document``) when it exceeds a limit.

    Raises
    ------
    LimitError
        Naming the first limit exceeded.
    """
    check_canvas(document.width, document.height)
    sets = list(_item_sets(document))
    curves = [curve for _, items in sets for curve in items.curves]
    points = [point for _, items in sets for point in items.points]
    _at_most(len(curves), MAX_CURVES, "curves")
    _at_most(len(points), MAX_POINTS, "diffusion points")
    low, high = _reach(document.width, document.height)
    if curves:
        counts = np.fromiter((len(curve.control_points) for curve in curves), np.int64, len(curves))
        owners = np.repeat([where for where, _ in sets], [len(items.curves) for _, items in sets])
        worst = int(np.argmax(counts))
        _at_most(int(counts[worst]), MAX_CURVE_CONTROL_POINTS, f"control points of a curve ({owners[worst]})")
        _at_most(int(counts.sum()), MAX_CONTROL_POINTS, "control points")
        stops = np.fromiter((max(len(curve.left), len(curve.right), len(curve.blur)) for curve in curves), np.int64,
                            len(curves))
        worst = int(np.argmax(stops))
        _at_most(int(stops[worst]), MAX_CURVE_STOPS, f"stops on a side of a curve ({owners[worst]})")
        _at_most(sum(len(curve.left) + len(curve.right) + len(curve.blur) for curve in curves), MAX_STOPS, "stops")
        _within(np.concatenate([curve.control_points for curve in curves]), low, high, "a control point")
    if points:  # colours and amplitudes are bounded by the items themselves (curve, point)
        _within(np.array([point.position for point in points]), low, high, "a diffusion point's centre")
        reach = COORDINATE_REACH * max(document.width, document.height)
        _magnitude(np.array([point.radius for point in points]), reach, "a diffusion point's radius")


def _item_sets(document) -> Iterable[tuple[str, object]]:
    """Every set of curves and points drawn on ``document``'s canvas: its layers and masks (a clone layer's
    source, on a canvas of its own, is checked as a document of its own)."""
    for index, layer in enumerate(document.layers):
        yield f"layer {index + 1}", layer
        if layer.mask is not None:
            yield f"the mask of layer {index + 1}", layer.mask
        if layer.clone is not None:
            check_document(layer.clone.source)


def _reach(width: int, height: int) -> tuple[np.ndarray, np.ndarray]:
    """Lowest and highest coordinates: ``COORDINATE_REACH`` times the longer side around the canvas."""
    margin = COORDINATE_REACH * max(width, height)
    return np.array([-margin, -margin]), np.array([width + margin, height + margin], dtype=np.float64)


def _at_most(count: int, limit: int, what: str) -> None:
    if count > limit:
        raise LimitError(f"at most {limit:,} {what} are read, got {count:,}")


def _within(xy: np.ndarray, low: np.ndarray, high: np.ndarray, what: str) -> None:
    outside = ~((xy >= low) & (xy <= high)).all(axis=1)
    if outside.any():
        x, y = xy[np.argmax(outside)]
        raise LimitError(f"{what} lies at ({shortened(float(x))}, {shortened(float(y))}), more than "
                         f"{COORDINATE_REACH:g} times the canvas's longer side off the canvas")


def _magnitude(values: np.ndarray, limit: float, what: str) -> None:
    bad = ~(np.abs(values) <= limit)  # NaN included
    if bad.any():
        value = float(np.asarray(values)[bad][0])
        shown = shortened(value) if math.isfinite(value) else str(value)
        raise LimitError(f"{what} must be finite and at most {limit:g} in size, got {shown}")
