"""Edits: functions from a document to the edited document.

Each returns a new ``Document`` and leaves its argument alone; tools and
scripts compose them and hand the result to a ``History``.  Curves and
points are named by their stable ids (``curve.id``, ``point.id``), which
survive edits of other items; control points and stops by their index on
their curve (from 0); ``side`` is ``"left"`` or ``"right"``.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import replace

import numpy as np

from .curve import BlurStop, Color, ColorStop, DiffusionCurve, interpolate_blur, interpolate_stops
from .document import Document
from .point import DiffusionPoint
from .refusals import EditRefused

SIDES = ("left", "right")
#: Where a curve keeps stops: its colour stops' sides and its blur stops.
STOP_SIDES = SIDES + ("blur",)


def _side(side: str, sides: tuple[str, ...] = SIDES) -> str:
    if side not in sides:
        raise ValueError(f"side must be one of {', '.join(map(repr, sides))}, got {side!r}")
    return side


def replace_curve(document: Document, curve_id: int, curve: DiffusionCurve) -> Document:
    """``document`` with the curve ``curve_id`` replaced by ``curve``."""
    curves = list(document.curves)
    curves[document.curve_index(curve_id)] = curve
    return document.with_curves(curves)


def add_curve(document: Document, curve: DiffusionCurve) -> Document:
    """``document`` with ``curve`` drawn on top of the others."""
    return document.with_curves(document.curves + (curve,))


def remove_curves(document: Document, curve_ids: Iterable[int]) -> Document:
    """``document`` without the curves ``curve_ids``."""
    drop = set(curve_ids)
    return document.with_curves(c for c in document.curves if c.id not in drop)


def move_control_point(document: Document, curve: int, point: int, position: tuple[float, float]) -> Document:
    """``document`` with control point ``point`` of the curve ``curve`` (an id) at ``position``."""
    old = document.curve(curve)
    points = np.array(old.control_points)
    points[point] = position
    return replace_curve(document, curve, replace(old, control_points=points))


def set_stop_color(document: Document, curve: int, side: str, stop: int, color: Color) -> Document:
    """``document`` with stop ``stop`` on ``side`` of curve ``curve`` coloured ``color``."""
    old = document.curve(curve)
    stops = list(getattr(old, _side(side)))
    stops[stop] = replace(stops[stop], color=tuple(color))
    return replace_curve(document, curve, replace(old, **{side: tuple(stops)}))


def set_stop_alpha(document: Document, curve: int, side: str, stop: int, alpha: float) -> Document:
    """``document`` with stop ``stop`` on ``side`` of curve ``curve`` at opacity ``alpha`` (in ``[0, 1]``)."""
    old = document.curve(curve)
    stops = list(getattr(old, _side(side)))
    stops[stop] = replace(stops[stop], alpha=float(alpha))
    return replace_curve(document, curve, replace(old, **{side: tuple(stops)}))


def set_stop_blur(document: Document, curve: int, stop: int, blur: float) -> Document:
    """``document`` with blur stop ``stop`` of curve ``curve`` at ``blur`` document pixels of deviation."""
    old = document.curve(curve)
    stops = list(old.blur)
    stops[stop] = replace(stops[stop], blur=float(blur))
    return replace_curve(document, curve, replace(old, blur=tuple(stops)))


def add_stop(document: Document, curve: int, side: str, stop: ColorStop | BlurStop) -> Document:
    """``document`` with ``stop`` added on ``side`` of curve ``curve`` (a ``BlurStop`` on side ``"blur"``)."""
    old = document.curve(curve)
    return replace_curve(document, curve, replace(old, **{side: getattr(old, _side(side, STOP_SIDES)) + (stop,)}))


def remove_stop(document: Document, curve: int, side: str, stop: int) -> Document:
    """``document`` without stop ``stop`` on ``side`` (``"blur"``: of its blur stops) of curve ``curve``."""
    old = document.curve(curve)
    stops = getattr(old, _side(side, STOP_SIDES))
    return replace_curve(document, curve, replace(old, **{side: stops[:stop] + stops[stop + 1 :]}))


def add_points(document: Document, points: Iterable[DiffusionPoint]) -> Document:
    """``document`` with ``points`` added."""
    return document.with_points(document.points + tuple(points))


def remove_points(document: Document, point_ids: Iterable[int]) -> Document:
    """``document`` without the points ``point_ids``."""
    drop = set(point_ids)
    return document.with_points(p for p in document.points if p.id not in drop) if drop else document


def translate(document: Document, delta: tuple[float, float], curves: Iterable[int] = (),
              control_points: Iterable[tuple[int, int]] = (), points: Iterable[int] = ()) -> Document:
    """``document`` with the named items moved by ``delta``.

    Parameters
    ----------
    document : Document
    delta : tuple of float
        ``(dx, dy)`` in document pixels.
    curves : iterable of int
        Ids of curves moved whole (their stops travel with them: they sit at parameters).
    control_points : iterable of (int, int)
        ``(curve id, index)`` control points moved on their own; points of curves
        already in ``curves`` move once.
    points : iterable of int
        Ids of the diffusion points moved.

    Returns
    -------
    Document
        ``document`` itself when ``delta`` is zero or nothing is named.
    """
    offset = np.array(delta, dtype=np.float64)
    whole = set(curves)
    single: dict[int, set[int]] = {}
    for curve, index in control_points:
        if curve not in whole:
            single.setdefault(curve, set()).add(index)
    moved_points = set(points)
    if not offset.any() or not (whole or single or moved_points):
        return document
    new_curves = list(document.curves)
    for curve in whole | set(single):
        index = document.curve_index(curve)
        control = np.array(new_curves[index].control_points)
        if curve in whole:
            control += offset
        else:
            control[sorted(single[curve])] += offset
        new_curves[index] = replace(new_curves[index], control_points=control)
    moved = document.with_curves(new_curves) if whole or single else document
    if not moved_points:
        return moved
    dx, dy = offset
    return moved.with_points(
        replace(p, position=(p.position[0] + dx, p.position[1] + dy)) if p.id in moved_points else p
        for p in document.points
    )


def move_stop(document: Document, curve: int, side: str, stop: int, position: float) -> Document:
    """``document`` with stop ``stop`` on ``side`` of curve ``curve`` moved to ``position``.

    The position is in piece units and clamped to ``[0, k]``; the stops are
    sorted again, so the moved stop's index may change (equal stops are
    interchangeable: find it by position and colour).
    """
    old = document.curve(curve)
    stops = list(getattr(old, _side(side, STOP_SIDES)))
    stops[stop] = replace(stops[stop], position=float(position))
    return replace_curve(document, curve, replace(old, **{side: tuple(stops)}))


def _stop_value(stops: tuple, s: float):
    """The colour (or blur) that ``stops`` give at position ``s``."""
    if isinstance(stops[0], ColorStop):
        return tuple(float(c) for c in interpolate_stops(stops, np.array([s]))[0])
    return float(interpolate_blur(stops, np.array([s]))[0])


def _cut_stops(stops: tuple, lo: float, hi: float) -> tuple:
    """The stops of the part ``[lo, hi]`` of a chain, shifted to start at 0.

    Where stops beyond the part are dropped, a stop at the cut keeps the
    colour the part had there, so the colours along the part are unchanged.
    """
    if not stops:
        return ()
    make = type(stops[0])
    kept = [make(st.position - lo, *_payload(st)) for st in stops if lo <= st.position <= hi]
    positions = [st.position for st in kept]
    if any(st.position < lo for st in stops) and 0.0 not in positions:
        kept.insert(0, make(0.0, _stop_value(stops, lo)))
    if any(st.position > hi for st in stops) and hi - lo not in positions:
        kept.append(make(hi - lo, _stop_value(stops, hi)))
    return tuple(kept)


def _payload(stop) -> tuple:
    return (stop.color,) if isinstance(stop, ColorStop) else (stop.blur,)


def _map_stops(stops: tuple, mapping) -> tuple:
    return tuple(type(st)(float(mapping(st.position)), *_payload(st)) for st in stops)


def _without_anchor(curve: DiffusionCurve, anchor: int) -> DiffusionCurve:
    """``curve`` without anchor number ``anchor`` (control point ``3 * anchor``), k >= 2."""
    k = curve.piece_count
    control = np.asarray(curve.control_points)
    if anchor == 0:
        control, lo, hi = control[3:], 1.0, float(k)
    elif anchor == k:
        control, lo, hi = control[:-3], 0.0, float(k - 1)
    else:
        keep = np.ones(len(control), dtype=bool)
        keep[3 * anchor - 1 : 3 * anchor + 2] = False
        j = anchor

        def merge(s: float) -> float:  # pieces j-1 and j become piece j-1
            return s if s <= j - 1 else (j - 1 + (s - (j - 1)) / 2 if s <= j + 1 else s - 1)

        sides = {name: _map_stops(getattr(curve, name), merge) for name in ("left", "right", "blur")}
        return replace(curve, control_points=control[keep], **sides)
    sides = {name: _cut_stops(getattr(curve, name), lo, hi) for name in ("left", "right", "blur")}
    return replace(curve, control_points=control, **sides)


def remove_anchors(document: Document, curve: int, indices: Iterable[int]) -> Document:
    """``document`` with the anchors at control-point ``indices`` of the curve ``curve`` (an id) removed.

    Removing an inner anchor joins its two pieces into one (the outer
    handles stay, the anchor's own handles go); removing an end anchor drops
    the end piece.  Stops follow: on a joined piece their positions scale
    into it; stops on a dropped end piece go, and a stop at the cut keeps the
    colour the curve had there, so the colours along what remains of the
    curve are unchanged.

    Parameters
    ----------
    indices : iterable of int
        Control-point indices of anchors (multiples of 3).

    Raises
    ------
    ValueError
        When an index is not an anchor.
    EditRefused
        When fewer than two anchors would remain (remove the curve instead).
    """
    old = document.curve(curve)
    anchors = sorted({int(i) for i in indices}, reverse=True)
    if any(i % 3 or not 0 <= i < len(old.control_points) for i in anchors):
        raise ValueError(f"anchors are control points 0, 3, ..., {len(old.control_points) - 1}, got {anchors}")
    if old.piece_count + 1 - len(anchors) < 2:
        raise EditRefused("a curve needs two anchors: remove the curve instead")
    new = old
    for index in anchors:
        new = _without_anchor(new, index // 3)
    return replace_curve(document, curve, new)


def insert_anchor(document: Document, curve: int, s: float) -> Document:
    """``document`` with the curve ``curve`` (an id) split at position ``s`` into one more piece.

    The shape does not change (de Casteljau split) and stops stay at the same
    points of the curve; colours between stops may shift slightly, since they
    interpolate along the parameter, which the split changes.  ``s`` at an
    existing anchor (or out of range) changes nothing.
    """
    old = document.curve(curve)
    k = old.piece_count
    piece = int(np.floor(s))
    t = float(s) - piece
    if not 0 <= piece < k or t <= 0.0:
        return document
    p0, p1, p2, p3 = np.asarray(old.pieces()[piece])
    a, b, c = p0 + t * (p1 - p0), p1 + t * (p2 - p1), p2 + t * (p3 - p2)
    d, e = a + t * (b - a), b + t * (c - b)
    m = d + t * (e - d)
    control = np.asarray(old.control_points)
    control = np.concatenate([control[: 3 * piece + 1], [a, d, m, e, c], control[3 * piece + 3 :]])

    def split(x: float) -> float:
        if x <= piece:
            return x
        if x >= piece + 1:
            return x + 1
        u = x - piece
        return piece + u / t if u <= t else piece + 1 + (u - t) / (1 - t)

    sides = {name: _map_stops(getattr(old, name), split) for name in ("left", "right", "blur")}
    return replace_curve(document, curve, replace(old, control_points=control, **sides))
