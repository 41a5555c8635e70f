"""Hit tests in plain numpy: curves, control points, stops and diffusion points.

Every function works in document pixels; callers turn screen tolerances into
document ones (``ToolContext.tolerance``).  Sides follow the model: with y
down, the *left* normal of a tangent ``t`` is ``n = (t_y, -t_x)``, and a point
``p`` lies on the left of the curve where ``(p - foot) . n > 0``.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass

import numpy as np

from ..model import DiffusionCurve, Document

SAMPLES = 32  # samples per piece before refining


def bezier(pieces: np.ndarray, t: np.ndarray) -> np.ndarray:
    """Points of cubic pieces ``(m, 4, 2)`` at parameters ``t`` ``(m, n)``: ``(m, n, 2)``."""
    p0, p1, p2, p3 = (pieces[:, i, None, :] for i in range(4))
    t = t[..., None]
    u = 1.0 - t
    return u**3 * p0 + 3 * u * u * t * p1 + 3 * u * t * t * p2 + t**3 * p3


def _derivatives(pieces: np.ndarray, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """First and second derivatives of pieces ``(m, 4, 2)`` at one ``t`` each ``(m,)``."""
    p0, p1, p2, p3 = (pieces[:, i, :] for i in range(4))
    t = t[:, None]
    u = 1.0 - t
    first = 3 * (u * u * (p1 - p0) + 2 * u * t * (p2 - p1) + t * t * (p3 - p2))
    second = 6 * (u * (p2 - 2 * p1 + p0) + t * (p3 - 2 * p2 + p1))
    return first, second


@dataclass(frozen=True)
class CurveHit:
    """The point of a curve nearest to a query point.

    Attributes
    ----------
    curve : int
        The curve's id.
    s : float
        Position along it in piece units.
    foot : tuple of float
        The nearest point on the curve.
    distance : float
        From the query point to ``foot``, in document pixels.
    side : str
        ``"left"`` or ``"right"``: the side of the curve the query point is on.
    """

    curve: int
    s: float
    foot: tuple[float, float]
    distance: float
    side: str


class CurveIndex:
    """The cubic pieces of a document's curves, for nearest-point queries.

    Parameters
    ----------
    curves : sequence of DiffusionCurve
    """

    def __init__(self, curves) -> None:
        self.curves = tuple(curves)
        self.ids = np.array([c.id for c in self.curves], dtype=np.int64)
        if self.curves:
            self.pieces = np.concatenate([c.pieces() for c in self.curves])
            self.owner = np.concatenate([np.full(c.piece_count, i) for i, c in enumerate(self.curves)])
            self.number = np.concatenate([np.arange(c.piece_count) for c in self.curves])
        else:
            self.pieces = np.zeros((0, 4, 2))
            self.owner = self.number = np.zeros(0, dtype=np.int64)
        self.low, self.high = self.pieces.min(axis=1), self.pieces.max(axis=1)  # hull boxes
        self.counts = np.array([c.piece_count for c in self.curves], dtype=np.int64)
        self.first = np.cumsum(self.counts) - self.counts  # each curve's first row

    def evaluate(self, curve, s) -> tuple[np.ndarray, np.ndarray]:
        """Points and unit tangents of curves ``curve`` (indices into ``curves``) at positions ``s``."""
        curve = np.asarray(curve, dtype=np.int64)
        k = self.counts[curve]
        s = np.clip(np.asarray(s, dtype=np.float64), 0.0, k)
        piece = np.minimum(np.floor(s).astype(np.int64), k - 1)
        pieces, t = self.pieces[self.first[curve] + piece], s - piece
        return bezier(pieces, t[:, None])[:, 0], unit_tangents(pieces, t)

    def stop_markers(self, offset: float) -> list[tuple[int, str, int, np.ndarray]]:
        """``(curve id, side, index, marker position)`` of every stop, ``offset`` pixels off its curve."""
        keys = [(c, side, i, stop.position) for c, curve in enumerate(self.curves)
                for side in ("left", "right") for i, stop in enumerate(getattr(curve, side))]
        if not keys:
            return []
        owner, sides, _, s = zip(*keys)
        points, tangent = self.evaluate(owner, s)
        sign = np.where(np.array(sides) == "left", 1.0, -1.0)[:, None]
        markers = points + sign * offset * np.stack([tangent[:, 1], -tangent[:, 0]], axis=1)
        return [(int(self.ids[c]), side, i, marker) for (c, side, i, _), marker in zip(keys, markers)]

    def outlines(self, per_piece: int = 24) -> list[np.ndarray]:
        """Each curve sampled evenly in each piece's parameter, ``(per_piece * k + 1, 2)`` apiece."""
        grid = np.linspace(0.0, 1.0, per_piece + 1)
        samples = bezier(self.pieces, np.broadcast_to(grid, (len(self.pieces), len(grid))))
        return [
            np.concatenate([samples[a : a + k, :-1].reshape(-1, 2), samples[a + k - 1, -1:]])
            for a, k in zip(self.first, self.counts)
        ]

    def nearest(self, point, tolerance: float = np.inf, only: Iterable[int] | None = None) -> CurveHit | None:
        """The curve point nearest to ``point`` within ``tolerance``, or None.

        Parameters
        ----------
        point : tuple of float
        tolerance : float
            Largest distance in document pixels.
        only : iterable of int, optional
            Consider only the curves with these ids.
        """
        p = np.asarray(point, dtype=np.float64)
        gap = np.maximum(np.maximum(self.low - p, p - self.high), 0.0)
        keep = np.hypot(gap[:, 0], gap[:, 1]) <= tolerance  # the hull holds the piece
        if only is not None:
            keep &= np.isin(self.ids[self.owner], np.fromiter(only, dtype=np.int64))
        rows = np.flatnonzero(keep)
        if not len(rows):
            return None
        t, distance = _refine(self.pieces[rows], p)
        best = int(np.argmin(distance))
        if distance[best] > tolerance:
            return None
        row = rows[best]
        curve = self.curves[self.owner[row]]
        s = min(float(self.number[row] + t[best]), float(curve.piece_count))
        foot = tuple(float(v) for v in curve.point_at(np.array([s]))[0])
        return CurveHit(curve.id, s, foot, float(distance[best]), side_of(curve, s, p))


class CurveSet:
    """Some curves of a document, by id, with their outlines and stop markers (computed once).

    Parameters
    ----------
    document : Document
    ids : iterable of int
        Indices of the curves in ``document``.
    """

    def __init__(self, document: Document, ids: Iterable[int]) -> None:
        self.ids = tuple(sorted(ids))
        self.index = CurveIndex([document.curve(c) for c in self.ids])
        self._markers: dict[float, list] = {}
        self._outlines: dict[int, np.ndarray] | None = None
        self._control: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None

    def control_points(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """All the curves' control points ``(n, 2)``, with each one's curve (id) and index."""
        if self._control is None:
            curves = self.index.curves
            if curves:
                points = np.concatenate([c.control_points for c in curves])
                owner = np.repeat(np.array(self.ids), [len(c.control_points) for c in curves])
                index = np.concatenate([np.arange(len(c.control_points)) for c in curves])
            else:
                points, owner, index = np.zeros((0, 2)), np.zeros(0, np.int64), np.zeros(0, np.int64)
            self._control = (points, owner, index)
        return self._control

    def outlines(self) -> dict[int, np.ndarray]:
        """Sampled outline of each curve, by id."""
        if self._outlines is None:
            self._outlines = dict(zip(self.ids, self.index.outlines()))
        return self._outlines

    def stop_markers(self, offset: float) -> list[tuple[int, str, int, np.ndarray]]:
        """``(curve, side, index, marker position)`` of the curves' stops, by id."""
        if offset not in self._markers:
            self._markers[offset] = self.index.stop_markers(offset)
        return self._markers[offset]


def _refine(pieces: np.ndarray, p: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Parameter and distance of each piece's point nearest to ``p``: sample, then Newton steps."""
    grid = np.linspace(0.0, 1.0, SAMPLES + 1)
    samples = bezier(pieces, np.broadcast_to(grid, (len(pieces), len(grid))))
    d2 = ((samples - p) ** 2).sum(axis=-1)
    j = np.argmin(d2, axis=1)
    t0 = grid[j]
    low, high = np.maximum(t0 - 1.0 / SAMPLES, 0.0), np.minimum(t0 + 1.0 / SAMPLES, 1.0)
    t = t0.copy()
    for _ in range(6):  # minimise |B(t) - p|^2: Newton on (B - p) . B'
        r = bezier(pieces, t[:, None])[:, 0] - p
        first, second = _derivatives(pieces, t)
        slope = (r * first).sum(axis=1)
        curvature = (first * first).sum(axis=1) + (r * second).sum(axis=1)
        step = np.divide(slope, curvature, out=np.zeros_like(slope), where=curvature > 1e-12)
        t = np.clip(t - step, low, high)
    refined = np.sqrt(((bezier(pieces, t[:, None])[:, 0] - p) ** 2).sum(axis=1))
    sampled = np.sqrt(d2[np.arange(len(pieces)), j])
    better = refined <= sampled
    return np.where(better, t, t0), np.where(better, refined, sampled)


def unit_tangents(pieces: np.ndarray, t: np.ndarray) -> np.ndarray:
    """Unit tangents of pieces ``(n, 4, 2)`` at one ``t`` each, ``(n, 2)``.

    Where the derivative vanishes (a retracted handle) a short chord inside
    the piece gives the direction; a piece shrunk to a point gives ``(1, 0)``.
    """
    direction, _ = _derivatives(pieces, t)
    flat = np.hypot(*direction.T) < 1e-9
    if flat.any():
        ends = [bezier(pieces[flat], np.clip(t[flat] + d, 0.0, 1.0)[:, None])[:, 0] for d in (-1e-3, 1e-3)]
        direction[flat] = ends[1] - ends[0]
    length = np.hypot(*direction.T)[:, None]
    return np.where(length > 0, direction / np.where(length > 0, length, 1.0), [1.0, 0.0])


def left_normal(curve: DiffusionCurve, s: float) -> np.ndarray:
    """Unit normal at ``s`` pointing into the curve's left side: ``(t_y, -t_x)`` with y down."""
    piece = min(int(np.floor(s)), curve.piece_count - 1)
    t = unit_tangents(curve.pieces()[piece : piece + 1], np.array([s - piece]))[0]
    return np.array([t[1], -t[0]])


def side_of(curve: DiffusionCurve, s: float, point) -> str:
    """``"left"`` or ``"right"``: the side of ``curve`` near position ``s`` that ``point`` is on."""
    foot = curve.point_at(np.array([s]))[0]
    return "left" if float(np.dot(np.asarray(point, dtype=np.float64) - foot, left_normal(curve, s))) >= 0 else "right"


def stop_marker(curve: DiffusionCurve, side: str, s: float, offset: float) -> np.ndarray:
    """Where a stop's marker sits: ``offset`` document pixels off the curve at ``s``, on ``side``."""
    sign = 1.0 if side == "left" else -1.0
    return curve.point_at(np.array([s]))[0] + sign * offset * left_normal(curve, s)


def polyline(curve: DiffusionCurve, per_piece: int = 24) -> np.ndarray:
    """``curve`` sampled evenly in each piece's parameter, ``(per_piece * k + 1, 2)``."""
    s = np.linspace(0.0, curve.piece_count, per_piece * curve.piece_count + 1)
    return curve.point_at(s)


def is_closed(curve: DiffusionCurve) -> bool:
    """True when the last anchor sits exactly on the first."""
    control = curve.control_points
    return len(control) > 4 and bool(np.array_equal(control[0], control[-1]))


def nearest_control_point(document: Document, curves: Iterable[int], point, tolerance: float) -> tuple[int, int] | None:
    """``(curve, index)`` of the control point of ``curves`` nearest to ``point``, or None.

    Of coincident points an anchor wins over a handle.
    """
    best, key = None, (tolerance, 1)
    p = np.asarray(point, dtype=np.float64)
    for c in sorted(curves):
        control = document.curve(c).control_points
        distance = np.hypot(*(control - p).T)
        handle = (np.arange(len(control)) % 3 != 0).astype(int)
        order = np.lexsort((handle, distance))
        i = int(order[0])
        if (distance[i], handle[i]) <= key:
            best, key = (c, i), (distance[i], handle[i])
    return best


def nearest_stop(markers: list[tuple[int, str, int, np.ndarray]], point,
                 tolerance: float) -> tuple[int, str, int] | None:
    """``(curve, side, index)`` of the marker (``CurveIndex.stop_markers``) nearest to ``point``, or None."""
    if not markers:
        return None
    distance = np.hypot(*(np.array([m[3] for m in markers]) - np.asarray(point, dtype=np.float64)).T)
    best = int(np.argmin(distance))
    return markers[best][:3] if distance[best] <= tolerance else None


def nearest_point(document: Document, point, tolerance: float) -> int | None:
    """Id of the diffusion point whose centre is nearest to ``point``, or None."""
    if not document.points:
        return None
    centres = np.array([q.position for q in document.points])
    distance = np.hypot(*(centres - np.asarray(point, dtype=np.float64)).T)
    i = int(np.argmin(distance))
    return document.points[i].id if distance[i] <= tolerance else None


def inside(corner, opposite, positions: np.ndarray) -> np.ndarray:
    """Which of ``positions`` ``(n, 2)`` lie in the rectangle spanned by two corners (edges included)."""
    low = np.minimum(corner, opposite)
    high = np.maximum(corner, opposite)
    positions = np.asarray(positions, dtype=np.float64).reshape(-1, 2)
    return np.all((positions >= low) & (positions <= high), axis=1)
